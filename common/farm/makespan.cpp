#include "farm/makespan.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <queue>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>

namespace pd::farm {
namespace {

void require_cost(const std::string& field, double value) {
  if (std::isfinite(value) && value >= 0.0) return;
  std::ostringstream msg;
  msg << "makespan: " << field << " must be finite and >= 0, got " << value;
  throw std::invalid_argument(msg.str());
}

void validate_costs(const GraphOptions& o, const Costs& c, int workers) {
  if (workers < 1) throw std::invalid_argument("makespan: workers must be >= 1, got " + std::to_string(workers));
  const auto check_vector = [&](const char* name, const std::vector<double>& v) {
    if (static_cast<int>(v.size()) != o.levels)
      throw std::invalid_argument(std::string("makespan: ") + name + " has " + std::to_string(v.size()) +
                                  " entries, expected one per level (" + std::to_string(o.levels) + ")");
    for (std::size_t l = 0; l < v.size(); ++l) require_cost(std::string(name) + "[" + std::to_string(l) + "]", v[l]);
  };
  check_vector("step_seconds", c.step_seconds);
  check_vector("vertical_start_seconds", c.vertical_start_seconds);
  require_cost("hierarchy_seconds", c.hierarchy_seconds);
  require_cost("dispatch_seconds", c.dispatch_seconds);
  if (c.frame_step_seconds.empty()) return;
  if (static_cast<int>(c.frame_step_seconds.size()) != o.levels)
    throw std::invalid_argument("makespan: frame_step_seconds has " + std::to_string(c.frame_step_seconds.size()) +
                                " levels, expected " + std::to_string(o.levels));
  for (std::size_t l = 0; l < c.frame_step_seconds.size(); ++l) {
    if (static_cast<int>(c.frame_step_seconds[l].size()) != o.frames + 1)
      throw std::invalid_argument("makespan: frame_step_seconds[" + std::to_string(l) + "] has " +
                                  std::to_string(c.frame_step_seconds[l].size()) + " frames, expected N + 1 = " +
                                  std::to_string(o.frames + 1));
    for (std::size_t t = 1; t < c.frame_step_seconds[l].size(); ++t)
      require_cost("frame_step_seconds[" + std::to_string(l) + "][" + std::to_string(t) + "]", c.frame_step_seconds[l][t]);
  }
}

enum class State { waiting, ready, running, done };

struct SimTask {
  NewTask spec;
  State state = State::waiting;
  int needs_left = 0;      // needed frames not stored yet
  int next = 0;            // the frame it solves next (its frame next - 1 is stored at own_time)
  double own_time = 0.0;
  bool in_flight = false;  // an event for its next frame (or frame 0, or the hierarchy) is queued
};

struct Event {
  double time;
  int64_t seq;  // insertion order: ties are processed first in, first out (determinism)
  int task;
  int frame;  // -1: the hierarchy task is done
};

struct Later {
  bool operator()(const Event& x, const Event& y) const {
    return x.time > y.time || (x.time == y.time && x.seq > y.seq);
  }
};

class Simulation {
 public:
  Simulation(const GraphOptions& o, std::vector<NewTask> graph, const Costs& c, int workers)
      : costs_(c), frames_(o.frames), levels_(o.preview_only ? 1 : o.levels), workers_(workers), free_(workers) {
    for (NewTask& t : graph) tasks_.push_back(SimTask{std::move(t)});
    const std::size_t slots = static_cast<std::size_t>(levels_) * (frames_ + 1);
    stored_.assign(slots, -1.0);  // -1: not stored (every stored time is >= 0)
    guide_stored_.assign(slots, -1.0);
    needed_by_.resize(slots);
    guide_needed_by_.resize(slots);
    step_owners_.resize(slots);
    for (int i = 0; i < static_cast<int>(tasks_.size()); ++i) {
      SimTask& t = tasks_[static_cast<std::size_t>(i)];
      t.needs_left = static_cast<int>(t.spec.needs.size() + t.spec.guide_needs.size());
      for (const FrameKey& k : t.spec.needs) needed_by_[slot(k.level, k.frame)].push_back(i);
      for (const FrameKey& k : t.spec.guide_needs) guide_needed_by_[slot(k.level, k.frame)].push_back(i);
      // A seam's stitch task and the later subset both read the level below over the stitch's frames.
      if (t.spec.kind == protocol::TaskKind::level && t.spec.level >= 1)
        for (int f = t.spec.first; f < t.spec.last; ++f) step_owners_[slot(t.spec.level, f)].push_back(i);
    }
    tasks_[0].state = State::ready;  // the hierarchy task, first in job_tasks
    ready_.insert({tasks_[0].spec.level, tasks_[0].spec.first, 0});
  }

  Plan run() {
    dispatch(0.0);
    while (!events_.empty()) {
      const double now = events_.top().time;
      while (!events_.empty() && events_.top().time == now) {
        const Event e = events_.top();
        events_.pop();
        if (e.frame < 0) {
          hierarchy_done(e.task, e.time);
        } else {
          frame_stored(e.task, e.frame, e.time);
        }
      }
      dispatch(now);  // after every event of this instant, so the choice sees all that is ready
    }
    for (const SimTask& t : tasks_)
      if (t.state != State::done) throw std::logic_error("makespan: simulation stalled with a task not done");
    return plan();
  }

 private:
  std::size_t slot(int level, int frame) const {
    return static_cast<std::size_t>(level) * (frames_ + 1) + static_cast<std::size_t>(frame);
  }

  void push(double time, int task, int frame) { events_.push(Event{time, seq_++, task, frame}); }

  // The step that solves frame `frame` of `level` (Costs::frame_step_seconds where given).
  double step_cost(int level, int frame) const {
    const auto l = static_cast<std::size_t>(level);
    return costs_.frame_step_seconds.empty() ? costs_.step_seconds[l]
                                             : costs_.frame_step_seconds[l][static_cast<std::size_t>(frame)];
  }

  void dispatch(double now) {
    while (free_ > 0 && !ready_.empty()) {
      const int i = std::get<2>(*ready_.begin());
      ready_.erase(ready_.begin());
      --free_;
      start(i, now);
    }
  }

  void start(int i, double now) {
    SimTask& t = tasks_[static_cast<std::size_t>(i)];
    t.state = State::running;
    const double working = now + costs_.dispatch_seconds;
    if (t.spec.kind == protocol::TaskKind::hierarchy) {
      t.in_flight = true;
      push(working + costs_.hierarchy_seconds, i, -1);
      return;
    }
    if (t.spec.first == 0) {  // stores the level's initial state first
      t.in_flight = true;
      push(working, i, 0);
      return;
    }
    const bool vertical = t.spec.level >= 1 && !t.spec.stitch;  // a stitch continues horizontally
    t.own_time = working + (vertical ? costs_.vertical_start_seconds[static_cast<std::size_t>(t.spec.level)] : 0.0);
    t.next = t.spec.first + 1;
    advance(i);
  }

  // Queues the task's next frame if its own previous frame and its input from the level below are stored.
  void advance(int i) {
    SimTask& t = tasks_[static_cast<std::size_t>(i)];
    if (t.state != State::running || t.in_flight || t.next > t.spec.last) return;
    double begin = t.own_time;
    if (t.spec.level >= 1) {
      const double below = stored_[slot(t.spec.level - 1, t.next - 1)];
      if (below < 0.0) return;  // held, idle, until that frame lands
      begin = std::max(begin, below);
    }
    if (t.spec.stitch) {  // guided toward the later subset's frame t.next: fed once it is stored
      const double guide = guide_stored_[slot(t.spec.level, t.next)];
      if (guide < 0.0) return;
      begin = std::max(begin, guide);
    }
    t.in_flight = true;
    push(begin + step_cost(t.spec.level, t.next), i, t.next);
  }

  void hierarchy_done(int i, double now) {
    finish(i, now);
    hierarchy_done_ = true;
    for (int j = 0; j < static_cast<int>(tasks_.size()); ++j) promote_if_ready(j);
  }

  void frame_stored(int i, int frame, double now) {
    SimTask& t = tasks_[static_cast<std::size_t>(i)];
    const int level = t.spec.level;
    t.own_time = now;
    t.next = frame + 1;
    t.in_flight = false;
    if (frame == t.spec.last) {
      finish(i, now);
    } else {
      advance(i);
    }
    if (frame <= t.spec.first + t.spec.guides && frame > t.spec.first) {  // a guide frame (task_graph.h)
      guide_stored_[slot(level, frame)] = now;
      for (int owner : step_owners_[slot(level, frame - 1)]) advance(owner);  // the stitch it guides
      for (int j : guide_needed_by_[slot(level, frame)]) {
        --tasks_[static_cast<std::size_t>(j)].needs_left;
        promote_if_ready(j);
      }
      return;
    }
    stored_[slot(level, frame)] = now;
    if (level + 1 < levels_ && frame < frames_)  // the tasks of level + 1 whose step frame -> frame + 1 reads it
      for (int owner : step_owners_[slot(level + 1, frame)]) advance(owner);
    for (int j : needed_by_[slot(level, frame)]) {
      --tasks_[static_cast<std::size_t>(j)].needs_left;
      promote_if_ready(j);
    }
  }

  void promote_if_ready(int j) {
    SimTask& t = tasks_[static_cast<std::size_t>(j)];
    if (t.state != State::waiting || t.needs_left > 0 || !hierarchy_done_) return;
    t.state = State::ready;
    ready_.insert({t.spec.level, t.spec.first, j});
  }

  void finish(int i, double now) {
    tasks_[static_cast<std::size_t>(i)].state = State::done;
    tasks_[static_cast<std::size_t>(i)].in_flight = false;
    ++free_;
    makespan_ = std::max(makespan_, now);
  }

  // Total work is independent of the schedule: every task's dispatch and work, once.
  double total_work() const {
    double work = 0.0;
    for (const SimTask& t : tasks_) {
      work += costs_.dispatch_seconds;
      const auto l = static_cast<std::size_t>(t.spec.level);
      if (t.spec.kind == protocol::TaskKind::hierarchy) {
        work += costs_.hierarchy_seconds;
        continue;
      }
      if (t.spec.level >= 1 && t.spec.first > 0 && !t.spec.stitch) work += costs_.vertical_start_seconds[l];
      for (int f = t.spec.first + 1; f <= t.spec.last; ++f) work += step_cost(t.spec.level, f);
    }
    return work;
  }

  Plan plan() const {
    Plan p;
    p.makespan = makespan_;
    p.preview_seconds = stored_[slot(0, frames_)];
    p.first_preview_frame_seconds = stored_[slot(0, 1)];
    for (int l = 0; l < levels_; ++l) p.level_finish.push_back(stored_[slot(l, frames_)]);
    p.busy_fraction = makespan_ > 0.0 ? total_work() / (workers_ * makespan_) : 0.0;
    return p;
  }

  const Costs& costs_;
  const int frames_;
  const int levels_;  // simulated levels
  const int workers_;
  int free_;          // free workers
  bool hierarchy_done_ = false;
  double makespan_ = 0.0;
  int64_t seq_ = 0;
  std::vector<SimTask> tasks_;
  std::vector<double> stored_;                // per (level, frame): time stored, -1 while not
  std::vector<double> guide_stored_;          // per (level, frame): time its guide frame was stored, -1 while not
  std::vector<std::vector<int>> needed_by_;   // per (level, frame): tasks that need it before dispatch
  std::vector<std::vector<int>> guide_needed_by_;  // per (level, frame): tasks that need its guide frame
  std::vector<std::vector<int>> step_owners_;  // per (level >= 1, frame t): the tasks solving t -> t + 1
  std::set<std::tuple<int, int, int>> ready_;  // (level, first, task index)
  std::priority_queue<Event, std::vector<Event>, Later> events_;
};

}  // namespace

Plan predict_plan(const GraphOptions& options, const Costs& costs, int workers, const std::vector<int>& seams) {
  std::vector<NewTask> graph = job_tasks(options, seams);  // validates the options before the costs are checked
  validate_costs(options, costs, workers);
  // With K >= 2 the scheduler adds the refinement levels once the preview is stored whole, to place
  // their seams from it (scheduler/seams.cpp): each of their tasks waits for level 0's frame N.
  if (options.subsets >= 2 && !options.preview_only)
    for (NewTask& t : graph)
      if (t.kind == protocol::TaskKind::level && t.level >= 1) t.needs.push_back(FrameKey{0, options.frames});
  return Simulation(options, std::move(graph), costs, workers).run();
}

}  // namespace pd::farm
