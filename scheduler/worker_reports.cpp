// pd-scheduler: what it does with each worker report (protocol/protocol.h, "Reports").
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "farm/messaging.h"
#include "farm/slurm.h"
#include "farm/task_graph.h"
#include "scheduler/scheduler.h"
#include "util/input_error.h"

namespace pd::scheduler {

namespace {

// The barrier stiffness stat of a frame (J/m^4), kept in the task store so that a task continuing
// horizontally from this frame restarts with it (progressive/level_task.h).
std::optional<double> kappa_of(const std::vector<protocol::Stat>& stats) {
  for (const auto& [name, value] : stats)
    if (name == "barrier_stiffness") return value;
  return std::nullopt;
}

}  // namespace

void Scheduler::refuse(const std::string& identity, const std::string& reason) {
  auto it = sessions_.find(identity);
  // Always a log line; a row in farm.sqlite only within the peer's budget (refusal_rows.h).
  event("report_refused", it == sessions_.end() ? 0 : it->second.job, it == sessions_.end() ? 0 : it->second.task,
        it == sessions_.end() ? 0 : it->second.worker, reason, refusal_rows_.admit(identity, unix_now()));
  protocol::Refused r;
  r.reason = reason;
  send_worker(identity, protocol::encode(r));
}

void Scheduler::on_worker_message(const std::string& identity, const protocol::Parts& parts) {
  protocol::Report report;
  try {
    report = protocol::decode_report(parts);
  } catch (const protocol::ProtocolError& e) {
    refuse(identity, std::string("malformed report: ") + e.what());
    return;
  }
  auto it = sessions_.find(identity);
  if (it == sessions_.end() && !std::holds_alternative<protocol::Hello>(report)) {
    refuse(identity, protocol::kUnknownWorkerReason);
    return;
  }
  if (it != sessions_.end()) it->second.last_heard = Clock::now();
  try {
    std::visit([&](auto& m) { on_report(identity, m); }, report);
  } catch (const std::exception& e) {
    // A report the store or the job file cannot take (a hello with 0 cores, say) is refused; the
    // scheduler goes on serving every other peer.
    refuse(identity, std::string(protocol::message_type(parts)) + ": " + e.what());
  }
}

void Scheduler::on_report(const std::string& identity, protocol::Hello& m) {
  // Refused before anything is stored (on_worker_message turns the throw into a Refused).
  if (!m.slurm_job.empty() && !farm::valid_slurm_job_id(m.slurm_job))
    throw InputError("field 'slurm_job': expected a Slurm job id (123 or 123_4), got '" + m.slurm_job.substr(0, 40) + "'");
  // A name is one worker's while its session is alive: a hello naming a worker heard from within the
  // liveness time is refused instead of evicting it (and losing its attempt), whoever sends it. A
  // worker that restarted before its old session timed out is refused too; it says hello again when
  // no heartbeat answers (worker.cpp) and gets in once the old session is lost, kLiveness heartbeats
  // after its last message.
  const auto now = Clock::now();
  for (const auto& [other, o] : sessions_) {
    if (other == identity || o.name != m.name || now - o.last_heard > kLiveness * heartbeat_) continue;
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now - o.last_heard).count();
    throw InputError("field 'name': worker '" + m.name.substr(0, 80) + "' is connected (heard " + std::to_string(ms) +
                     " ms ago); a worker of that name is let in once that session has been silent for " +
                     std::to_string(kLiveness) + " heartbeats");
  }
  if (sessions_.count(identity)) lose(identity, "said hello again");
  Session s;
  s.worker = store_->add_worker(m.name, m.host, m.version, m.cores);
  // The same worker (by name) on a new connection whose old session went silent: it restarted, or
  // reconnected. The old session's attempt is lost.
  for (const auto& [other, o] : sessions_) {
    if (o.worker != s.worker) continue;
    lose(other, "connected again as " + m.name);
    break;
  }
  s.name = m.name;
  s.blas_kernel = m.blas_kernel;
  if (!m.slurm_job.empty()) {
    s.slurm_job = m.slurm_job;
    slurm_->worker_joined(m.slurm_job, m.name, unix_now());
  }
  s.last_heard = s.last_sent = Clock::now();
  sessions_[identity] = s;
  protocol::Welcome w;
  w.worker = s.worker;
  w.heartbeat_ms = options_.heartbeat_ms;
  send_worker(identity, protocol::encode(w));
  event("worker_joined", 0, 0, s.worker,
        m.name + " on " + m.host + ", " + std::to_string(m.cores) + " cores, version " + m.version +
            ", OpenBLAS kernel " + m.blas_kernel + (m.slurm_job.empty() ? "" : ", Slurm job " + m.slurm_job));
  // Not refused (the frames are still right to the solver's tolerance), but a job whose tasks run on
  // both gives frames that differ in the last bits from run to run: say so, once per joining worker.
  for (const auto& [other, o] : sessions_) {
    if (other == identity || o.blas_kernel == m.blas_kernel) continue;
    event("worker_kernel_differs", 0, 0, s.worker,
          m.name + " runs OpenBLAS kernel '" + m.blas_kernel + "', " + o.name + " runs '" + o.blas_kernel +
              "': frames will depend on which of them solves a task (docs/deploy.md)");
    break;
  }
}

void Scheduler::on_report(const std::string& identity, protocol::WorkerHeartbeat& m) {
  Session& s = sessions_.at(identity);
  // A cancelled attempt's worker is free again once it says it runs nothing (or something else).
  if (s.draining && m.attempt != s.attempt) {
    end_attempt_of(s);
    s.draining = false;
    store_->set_worker_state(s.worker, "idle");
  }
  if (s.attempt == 0 && m.attempt != 0) {
    // It runs an attempt this scheduler never gave it (it started before a scheduler restart): that
    // attempt is stopped, and the worker takes nothing until a heartbeat says it is free.
    protocol::CancelTask c;
    c.attempt = m.attempt;
    c.reason = "unknown attempt (the scheduler restarted); its task continues from its stored frames";
    send_worker(identity, protocol::encode(c));
    event("attempt_unknown", 0, 0, s.worker, "attempt " + std::to_string(m.attempt) + " cancelled");
    s.attempt = m.attempt;
    s.draining = true;
  }
  store_->touch_worker(s.worker);
  top_up_feed(identity, s);  // frames a full queue refused earlier
  if (m.ping != 0) send_worker(identity, protocol::encode(protocol::SchedulerHeartbeat{m.ping}));
}

Session* Scheduler::attempt_session(const std::string& identity, int64_t attempt, int64_t task, const char* what) {
  Session& s = sessions_.at(identity);
  if (s.attempt == 0 || s.attempt != attempt || s.task != task) {
    refuse(identity, std::string(what) + " for attempt " + std::to_string(attempt) + " of task " +
                         std::to_string(task) + ", which is not this worker's running attempt");
    return nullptr;
  }
  if (s.draining) return nullptr;  // cancelled: late reports are dropped without a word
  return &s;
}

void Scheduler::on_report(const std::string& identity, protocol::FrameReport& m) {
  Session* s = attempt_session(identity, m.attempt, m.task, "frame");
  if (!s) return;
  const TaskRow t = store_->task(m.task);
  JobFile* f = files_.find(t.job);
  std::string bad;
  const std::optional<farm::FrameRange> own = farm::produced_frames(as_new_task(t));
  const std::optional<farm::FrameRange> guides = farm::guide_frames(as_new_task(t));
  const int lo = guides ? guides->first : own ? own->first : 0;
  if (!own || !f)
    bad = "a frame for a task that solves no frames";
  else if (m.level != t.level)
    bad = "frame of level " + std::to_string(m.level) + " for a task of level " + std::to_string(t.level);
  else if (m.frame < lo || m.frame > t.last)
    bad = "frame " + std::to_string(m.frame) + " outside the task's frames [" + std::to_string(lo) + ", " +
          std::to_string(t.last) + "]";
  else if (m.positions.size() != 3 * static_cast<std::size_t>(f->vertices[m.level]))
    bad = "frame with " + std::to_string(m.positions.size() / 3) + " vertices, level " + std::to_string(m.level) +
          " has " + std::to_string(f->vertices[m.level]);
  else if (!m.center_of_mass.empty() && m.center_of_mass.size() != 3 * static_cast<std::size_t>(f->objects[m.level]))
    bad = "center_of_mass with " + std::to_string(m.center_of_mass.size() / 3) + " objects, the level has " +
          std::to_string(f->objects[m.level]);
  if (!bad.empty()) {
    refuse(identity, bad);
    return;
  }
  for (double x : m.positions) {
    if (!std::isfinite(x)) {
      attempt_failed(*s, t, "frame " + std::to_string(m.frame) + " of level " + std::to_string(m.level) +
                                " is not finite (the solver diverged)");
      return;
    }
  }
  if (guides && m.frame <= guides->last) {
    store_guide_frame(identity, *s, t, m);
    return;
  }
  FrameData data;
  data.positions = std::move(m.positions);
  data.stats = std::move(m.stats);
  data.center_of_mass = std::move(m.center_of_mass);
  data.kappa = kappa_of(data.stats);
  s->progress = std::max(s->progress, m.frame);
  top_up_feed(identity, *s);  // the report acknowledges the frames below it: the window moves on
  if (const std::optional<FrameData> stored = store_->frame_data(t.job, {m.level, m.frame})) {
    // Solved again (a task restarted from its first frame): a stored frame is never changed. The
    // solve is deterministic, so the two agree; a difference is logged for a look.
    // Bit for bit (memcmp, not ==: -0.0 == 0.0); sizes first, and never memcmp on empty data.
    const bool same = stored->positions.size() == data.positions.size() &&
                      (data.positions.empty() || std::memcmp(stored->positions.data(), data.positions.data(),
                                                             sizeof(double) * data.positions.size()) == 0);
    event(same ? "frame_repeated" : "frame_differs", t.job, t.id, s->worker,
          "level " + std::to_string(m.level) + " frame " + std::to_string(m.frame) + " was stored already; kept");
    return;
  }
  try {
    check_frame_stats(data.stats);
  } catch (const InputError& e) {
    refuse(identity, e.what());  // a bad statistic name, say: the frame is not stored
    return;
  }
  // Recorded first (the store is the authority and keeps the data), then written and flushed to the
  // job file; a crash in between is repaired from the store when the scheduler starts again.
  store_->record_frame(t.job, {m.level, m.frame}, data);
  try {
    files_.write_frame(*f, m.level, m.frame, data);
  } catch (const std::exception& e) {
    // The disk, not the worker: the file is built again from the store, which has the frame.
    event("job_file_error", t.job, t.id, s->worker, e.what());
    if (!rebuild_job_file(store_->job(t.job))) return;
  }
  for (const auto& [name, value] : data.stats) {
    if (name != "solve_seconds") continue;
    auto& [sum, count] = step_seconds_[{t.job, m.level}];
    sum += value;
    ++count;
  }
  event("frame_stored", t.job, t.id, s->worker,
        "level " + std::to_string(m.level) + " frame " + std::to_string(m.frame), false);
  feed_new_frame(t.job, m.level, m.frame);
}

// A later subset's frame that its seam's stitch task is guided toward (farm/task_graph.h): kept in the
// store's guide frames, not the job's (never written to its file nor fed to the level above).
void Scheduler::store_guide_frame(const std::string& identity, Session& s, const TaskRow& t,
                                  const protocol::FrameReport& m) {
  s.progress = std::max(s.progress, m.frame);
  top_up_feed(identity, s);
  if (const std::optional<std::vector<double>> stored = store_->guide_frame(t.job, {m.level, m.frame})) {
    const bool same = stored->size() == m.positions.size() &&
                      (m.positions.empty() ||
                       std::memcmp(stored->data(), m.positions.data(), sizeof(double) * m.positions.size()) == 0);
    event(same ? "frame_repeated" : "frame_differs", t.job, t.id, s.worker,
          "level " + std::to_string(m.level) + " guide frame " + std::to_string(m.frame) + " was stored already; kept");
    return;
  }
  store_->record_guide_frame(t.job, {m.level, m.frame}, m.positions);
  feed_guide_frame(t.job, m.level, m.frame, m.positions);
  // Its solve time is logged (it is in no job file): bench/farm_timeline.py counts the guide frames'
  // solves as the later subset's work.
  double solve = 0.0;
  for (const auto& [name, value] : m.stats)
    if (name == "solve_seconds") solve = value;
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.6g", solve);
  event("guide_stored", t.job, t.id, s.worker,
        "level " + std::to_string(m.level) + " guide frame " + std::to_string(m.frame) + ", solve " + seconds + " s",
        false);
}

void Scheduler::on_report(const std::string& identity, protocol::TaskDone& m) {
  Session* s = attempt_session(identity, m.attempt, m.task, "task_done");
  if (!s) return;
  const TaskRow t = store_->task(m.task);
  const std::optional<farm::FrameRange> own = farm::produced_frames(as_new_task(t));
  const std::optional<farm::FrameRange> guides = farm::guide_frames(as_new_task(t));
  std::size_t stored = own ? store_->stored_frames(t.job, own->level, own->first, own->last).size() : 0;
  std::size_t expected = own ? static_cast<std::size_t>(own->last - own->first + 1) : 1;
  if (guides) {
    stored += store_->stored_guide_frames(t.job, guides->level, guides->first, guides->last).size();
    expected += static_cast<std::size_t>(guides->last - guides->first + 1);
  }
  if (!own || stored != expected) {
    const std::string why = "reported done with " + std::to_string(stored) + " of " + std::to_string(expected) +
                            " frames stored";
    refuse(identity, why);
    attempt_failed(*s, t, why);
    return;
  }
  store_->finish_task(t.id);
  if (t.level == 0) add_pending_refinement(store_->job(t.job));  // the preview's last chunk: seams placed
  event("task_done", t.job, t.id, s->worker,
        "level " + std::to_string(t.level) + " frames (" + std::to_string(t.first) + ", " + std::to_string(t.last) +
            "] in " + std::to_string(m.seconds) + " s, " + std::to_string(m.unconverged_steps) + " steps unconverged");
  end_attempt_of(*s);
  if (store_->job(t.job).state == protocol::JobState::done) {
    files_.flush(t.job);  // a finished job's file is complete on disk
    event("job_done", t.job, 0, 0, "");
  }
}

void Scheduler::on_report(const std::string& identity, protocol::TaskFailed& m) {
  Session* s = attempt_session(identity, m.attempt, m.task, "task_failed");
  if (!s) return;
  const TaskRow t = store_->task(m.task);
  // A refusal after an earlier attempt of the task made the same start and stored guide frames (its
  // seam's stitch may be running on them) is not the frames' doing (a worker started with
  // --refuse-vertical-starts, say): the seam stays, and the attempt fails like any other.
  const bool started_before =
      t.guides > 0 && !store_->stored_guide_frames(t.job, t.level, t.first + 1, t.first + t.guides).empty();
  if (m.failure == protocol::FailureKind::vertical_start_refused && t.kind == protocol::TaskKind::level &&
      t.level >= 1 && t.first >= 1 && !store_->continues_horizontally(t.id) && !started_before) {
    // Deterministic (the same frames upsample the same way on every worker): rather than retrying,
    // the seam moves kSeamMoveFrames later, where the start may be made (a bridge task continues the
    // level horizontally over the frames it leaves), up to kMaxSeamMoves times; then the subset
    // waits for the one before it and continues from its frames, as if the seam were not there (the
    // level then loses that seam's parallelism, not the job).
    const int64_t attempt = s->attempt;
    const int moved_to = t.first + kSeamMoveFrames;
    end_attempt_of(*s);
    if (store_->refused_starts(t.id) < kMaxSeamMoves && moved_to < t.last) {
      const int64_t bridge =
          store_->move_seam(t.id, attempt, moved_to, farm::subset_needs(t.level, moved_to, t.last),
                            farm::stitch_task(t.level, moved_to, t.last, store_->job(t.job).spec.stitch), m.message);
      event("seam_moved", t.job, t.id, s->worker,
            "level " + std::to_string(t.level) + " seam " + std::to_string(t.first) + " -> " + std::to_string(moved_to) +
                " (task " + std::to_string(bridge) + " bridges (" + std::to_string(t.first) + ", " +
                std::to_string(moved_to) + "] horizontally): " + m.message.substr(0, 300));
      return;
    }
    store_->continue_horizontally(t.id, attempt, m.message);
    event("task_continues_horizontally", t.job, t.id, s->worker,
          "attempt " + std::to_string(attempt) + ": " + m.message.substr(0, 300));
    return;
  }
  attempt_failed(*s, t, m.message);
}

// A stopping worker: lost now rather than after the liveness time, so its task moves at once (a
// Slurm worker's scancel or time limit, a systemd stop). Its attempt's stored frames stay: the next
// attempt continues from them.
void Scheduler::on_report(const std::string& identity, protocol::Goodbye& m) {
  lose(identity, "said goodbye: " + m.reason.substr(0, 200));
}

void Scheduler::on_report(const std::string& identity, protocol::HierarchyDone& m) {
  Session* s = attempt_session(identity, m.attempt, m.task, "hierarchy_done");
  if (!s) return;
  const TaskRow t = store_->task(m.task);
  const JobRow job = store_->job(t.job);
  if (t.kind != protocol::TaskKind::hierarchy) {
    refuse(identity, "hierarchy_done for a level task");
    return;
  }
  try {
    files_.create(t.job, job.spec.scene.text, job.spec.frames, job.spec.levels, m.hash, m.blob);
  } catch (const std::exception& e) {
    attempt_failed(*s, t, e.what());
    return;
  }
  s->hierarchies.insert(m.hash);
  store_->store_hierarchy(t.job, m.hash, m.blob);
  store_->finish_task(t.id);
  std::string sizes;
  for (int v : m.vertices) sizes += (sizes.empty() ? "" : "/") + std::to_string(v);
  event("hierarchy_stored", t.job, t.id, s->worker, std::to_string(m.levels) + " levels, " + sizes + " vertices");
  end_attempt_of(*s);
}

}  // namespace pd::scheduler
