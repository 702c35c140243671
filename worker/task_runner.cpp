#include "worker/task_runner.h"

#include <unistd.h>

#include <chrono>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

#include "farm/scene_source.h"
#include "progressive/contact_control.h"
#include "progressive/frame_stats.h"
#include "progressive/level_system.h"
#include "progressive/level_task.h"
#include "hierarchy/safe_upsampling.h"
#include "scene/scene_file.h"
#include "store/hierarchy_store.h"
#include "util/memory_budget.h"

namespace pd::worker {

namespace fs = std::filesystem;

namespace {

// Thrown inside the solver thread when the attempt is cancelled; ends it without a report.
struct Cancelled {};

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot read");
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error(path + ": cannot write");
}

Eigen::VectorXd to_vector(const std::vector<double>& v) {
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// The scene of an assignment with the job's frame and level counts (the job may override both). A
// scene sent with the assignment is kept under <scratch>/scenes/<hash>/ (its files, its text, its
// name), so the later assignments of this session that name the hash without the scene (the
// scheduler sends each scene once per session) read it from there.
Scene job_scene(const protocol::AssignTask& task, const std::string& scratch_dir, const std::string& job_dir) {
  fs::create_directories(job_dir);
  const fs::path dir = fs::path(scratch_dir) / "scenes" / task.scene_hash;  // hex: checked by the decoder
  Scene scene;
  if (task.scene) {
    const std::string hash = farm::scene_source_hash(*task.scene);
    if (hash != task.scene_hash)
      throw std::runtime_error("the scene sent with task " + std::to_string(task.task) + " has hash " + hash +
                               ", the task names " + task.scene_hash);
    fs::remove_all(dir);
    fs::create_directories(dir);
    scene = farm::scene_from_source(*task.scene, (dir / "files").string());
    write_file((dir / "name").string(), task.scene->name);
    write_file((dir / "scene.json").string(), task.scene->text);
  } else {
    if (!fs::exists(dir / "scene.json"))
      throw std::runtime_error("no scene " + task.scene_hash + " on this worker and none was sent with task " +
                               std::to_string(task.task));
    scene = parse_scene(read_file((dir / "scene.json").string()), read_file((dir / "name").string()),
                        (dir / "files").string());
  }
  if (task.frames >= 1) scene.frames = task.frames;
  if (task.levels >= 1) scene.hierarchy.levels = task.levels;
  return scene;
}

// Refuses, before anything is built, a level task this worker cannot hold (issue 47 item 2): the
// estimate pd simulate checks (util/memory_budget.h) against what this process may take and
// --max-memory. The refusal fails the attempt like any error, so the scheduler gives the task to
// another worker (and fails it, with this message, after three refusals).
void check_task_memory(const protocol::AssignTask& task, long long vertices, double max_memory_bytes) {
  const double needed = simulation_bytes(vertices);
  MemoryBudget budget = memory_budget();
  if (max_memory_bytes > 0.0 && max_memory_bytes < budget.bytes) budget = {max_memory_bytes, "--max-memory"};
  if (needed > budget.bytes)
    throw std::runtime_error("task " + std::to_string(task.task) + " (level " + std::to_string(task.level) + ", " +
                             std::to_string(vertices) + " vertices) needs about " + gib_text(needed) + " (about " +
                             std::to_string(static_cast<int>(kSimulationBytesPerVertex / 1024)) +
                             " KiB a vertex); this worker may take " + gib_text(budget.bytes) + " (limited by " +
                             budget.limited_by + ")");
}

}  // namespace

std::shared_ptr<const SceneHierarchy> HierarchyCache::find(const std::string& hash) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = by_hash_.find(hash);
  return it == by_hash_.end() ? nullptr : it->second;
}

void HierarchyCache::put(const std::string& hash, std::shared_ptr<const SceneHierarchy> h) {
  std::lock_guard<std::mutex> lock(mutex_);
  by_hash_[hash] = std::move(h);
}

bool HierarchyCache::has(const std::string& hash) const { return find(hash) != nullptr; }

TaskRunner::TaskRunner(int wake_fd, std::string scratch_dir, HierarchyCache& cache, int fail_level,
                       bool refuse_vertical_starts, int refuse_vertical_starts_before, double max_memory_bytes)
    : wake_fd_(wake_fd),
      scratch_dir_(std::move(scratch_dir)),
      cache_(cache),
      fail_level_(fail_level),
      refuse_vertical_starts_(refuse_vertical_starts),
      refuse_vertical_starts_before_(refuse_vertical_starts_before),
      max_memory_bytes_(max_memory_bytes) {
  fs::create_directories(scratch_dir_);
}

TaskRunner::~TaskRunner() {
  cancel();
  if (thread_.joinable()) thread_.join();
}

void TaskRunner::start(protocol::AssignTask task) {
  poll();
  if (thread_.joinable()) throw std::logic_error("TaskRunner::start while an attempt runs");
  {
    std::lock_guard<std::mutex> lock(mutex_);
    below_.clear();
    guides_.clear();
    attempt_ = task.attempt;
    cancelled_ = false;
    finished_ = false;
  }
  thread_ = std::thread([this, t = std::move(task)]() mutable { run(std::move(t)); });
}

void TaskRunner::feed(const protocol::BelowFrame& frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (frame.attempt != attempt_ || cancelled_) return;
  below_[frame.frame] = to_vector(frame.positions);
  frame_arrived_.notify_all();
}

void TaskRunner::feed(const protocol::GuideFrame& frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (frame.attempt != attempt_ || cancelled_) return;
  guides_[frame.frame] = to_vector(frame.positions);
  frame_arrived_.notify_all();
}

void TaskRunner::cancel() {
  std::lock_guard<std::mutex> lock(mutex_);
  cancelled_ = true;
  frame_arrived_.notify_all();
}

int64_t TaskRunner::attempt() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return finished_ ? 0 : attempt_;
}

bool TaskRunner::busy() const { return attempt() != 0; }

void TaskRunner::poll() {
  bool done;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    done = finished_;
  }
  if (done && thread_.joinable()) thread_.join();
}

std::vector<protocol::Parts> TaskRunner::take_outbox() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<protocol::Parts> out;
  out.swap(outbox_);
  return out;
}

void TaskRunner::post(protocol::Parts parts) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (cancelled_) throw Cancelled{};
    outbox_.push_back(std::move(parts));
  }
  const uint64_t one = 1;
  if (write(wake_fd_, &one, sizeof one) < 0) {
    // eventfd writes fail only on counter overflow; the connection loop also polls on a timer.
  }
}

Eigen::VectorXd TaskRunner::wait_below(int t) {
  std::unique_lock<std::mutex> lock(mutex_);
  frame_arrived_.wait(lock, [&] { return cancelled_ || below_.count(t) != 0; });
  if (cancelled_) throw Cancelled{};
  // The solve asks for frames t and t - 1 of each step in increasing t (progressive/level_task.h):
  // nothing before t - 1 is asked for again, so an attempt holds a window of frames, not its range.
  below_.erase(below_.begin(), below_.lower_bound(t - 1));
  return below_.at(t);
}

Eigen::VectorXd TaskRunner::wait_guide(int f) {
  std::unique_lock<std::mutex> lock(mutex_);
  frame_arrived_.wait(lock, [&] { return cancelled_ || guides_.count(f) != 0; });
  if (cancelled_) throw Cancelled{};
  // The stitch asks for each guide frame once, in increasing f (progressive/level_task.cpp).
  Eigen::VectorXd g = std::move(guides_.at(f));
  guides_.erase(guides_.begin(), guides_.upper_bound(f));
  return g;
}

void TaskRunner::run(protocol::AssignTask task) {
  const auto t0 = std::chrono::steady_clock::now();
  try {
    protocol::Parts last;
    if (task.kind == protocol::TaskKind::hierarchy) {
      last = run_hierarchy(task);
    } else {
      run_level(task);
      protocol::TaskDone done;
      done.attempt = task.attempt;
      done.task = task.task;
      done.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      last = protocol::encode(done);
    }
    finish(std::move(last));
  } catch (const Cancelled&) {
    finish({});
  } catch (const std::exception& e) {
    protocol::TaskFailed failed;
    failed.attempt = task.attempt;
    failed.task = task.task;
    failed.message = e.what();
    // Only a vertical start upsamples (level_task.h): the scheduler lets such a task continue
    // horizontally instead of retrying the same refusal elsewhere.
    if (dynamic_cast<const UpsamplingFailed*>(&e)) failed.failure = protocol::FailureKind::vertical_start_refused;
    protocol::Parts parts;
    try {
      parts = protocol::encode(failed);
    } catch (const protocol::ProtocolError&) {
      // The message is not valid UTF-8 (text from a file, say): send it with the odd bytes masked.
      for (char& c : failed.message)
        if (static_cast<unsigned char>(c) >= 0x80) c = '?';
      parts = protocol::encode(failed);
    }
    finish(std::move(parts));
  }
}

// The attempt's last report and the end of the attempt in one step: by the time the connection
// thread sends that report (and the scheduler answers with the next task), the runner is free.
void TaskRunner::finish(protocol::Parts last) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!last.empty() && !cancelled_) outbox_.push_back(std::move(last));
    finished_ = true;
  }
  const uint64_t one = 1;
  if (write(wake_fd_, &one, sizeof one) < 0) {
    // only on counter overflow; the connection loop also wakes on a timer
  }
}

protocol::Parts TaskRunner::run_hierarchy(const protocol::AssignTask& task) {
  const std::string job_dir = scratch_dir_ + "/job-" + std::to_string(task.job);
  const Scene scene = job_scene(task, scratch_dir_, job_dir);
  const std::string path = job_dir + "/hierarchy-" + std::to_string(task.attempt) + ".h5";
  auto h = std::make_shared<const SceneHierarchy>(load_or_build_hierarchy(scene, path));
  // Every level must start admissibly (a coarse level can overlap where the finest does not), as
  // pd simulate checks before it writes anything: the job fails here with the same message.
  LevelSystemOptions system;
  system.hessian = parse_level_hessian(task.hessian);
  for (int l = 0; l < h->num_levels(); ++l) {
    try {
      check_start_state(scene_at_level(scene, *h, l), build_level_system(scene, *h, l, system));
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string(e.what()) + " (at hierarchy level " + std::to_string(l) + " of " +
                               std::to_string(h->num_levels()) + ", 0 = coarsest)");
    }
  }
  protocol::HierarchyDone done;
  done.attempt = task.attempt;
  done.task = task.task;
  done.hash = h->hash;
  done.levels = h->num_levels();
  for (const SceneLevel& lv : h->levels) done.vertices.push_back(static_cast<int>(lv.rest.V.rows()));
  done.blob = read_file(path);
  fs::remove(path);
  cache_.put(h->hash, h);
  return protocol::encode(done);
}

std::shared_ptr<const SceneHierarchy> TaskRunner::hierarchy_for(const protocol::AssignTask& task,
                                                                const std::string& job_dir) {
  if (task.hierarchy_blob) {
    const std::string path = job_dir + "/received-" + std::to_string(task.attempt) + ".h5";
    write_file(path, *task.hierarchy_blob);
    std::optional<SceneHierarchy> read = read_hierarchy(path);
    fs::remove(path);
    if (!read) throw std::runtime_error("the hierarchy sent with task " + std::to_string(task.task) + " has no hash");
    if (read->hash != task.hierarchy_hash)
      throw std::runtime_error("the hierarchy sent with task " + std::to_string(task.task) + " has hash " + read->hash +
                               ", the task names " + task.hierarchy_hash);
    auto h = std::make_shared<const SceneHierarchy>(std::move(*read));
    cache_.put(h->hash, h);
    return h;
  }
  std::shared_ptr<const SceneHierarchy> h = cache_.find(task.hierarchy_hash);
  if (!h) throw std::runtime_error("no hierarchy " + task.hierarchy_hash + " on this worker and none was sent");
  return h;
}

void TaskRunner::run_level(const protocol::AssignTask& task) {
  if (task.level == fail_level_)
    throw std::runtime_error("injected failure: this worker fails every level-" + std::to_string(fail_level_) +
                             " task (--fail-level)");
  const std::string job_dir = scratch_dir_ + "/job-" + std::to_string(task.job);
  const Scene scene = job_scene(task, scratch_dir_, job_dir);
  const std::shared_ptr<const SceneHierarchy> h = hierarchy_for(task, job_dir);
  check_task_memory(task, static_cast<long long>(h->levels.at(static_cast<std::size_t>(task.level)).rest.V.rows()),
                    max_memory_bytes_);
  LevelTaskInputs inputs;
  if (task.level >= 1) inputs.below = [this](int t) { return wait_below(t); };
  // A vertical start: a later subset of a refinement level that does not continue from own frames.
  const bool vertical = task.level >= 1 && task.start > 0 && !task.own_start;
  if (vertical && (refuse_vertical_starts_ ||
                   (refuse_vertical_starts_before_ > 0 && task.start < refuse_vertical_starts_before_)))
    throw UpsamplingFailed("injected refusal: this worker refuses vertical starts (--refuse-vertical-starts" +
                           std::string(refuse_vertical_starts_ ? "" : "-before") + ")");
  if (task.own_before && task.own_start) {
    inputs.own_before = to_vector(*task.own_before);
    inputs.own_start = to_vector(*task.own_start);
    inputs.own_kappa = task.own_kappa;
  }
  // A seam's stitch task (farm/task_graph.h): guided toward the later subset's frames first+1..last,
  // fed as the later subset solves them, its ramp counted from the seam (its first frame) whichever
  // frame this attempt starts from.
  if (task.stitch) {
    inputs.stitch_frames = task.last - task.first + 1;
    inputs.stitch_seam = task.first;
    inputs.stitch_target = [this](int f) { return wait_guide(f); };
  }
  LevelTaskOptions options;
  options.system.hessian = parse_level_hessian(task.hessian);
  const auto sink = [&](const FrameRecord& r) {
    protocol::FrameReport report;
    report.attempt = task.attempt;
    report.task = task.task;
    report.level = task.level;
    report.frame = r.frame;
    report.positions.assign(r.x.data(), r.x.data() + r.x.size());
    const FrameStats stats = frame_stats(r);
    report.stats = stats.scalars;
    report.center_of_mass.assign(stats.center_of_mass.data(),
                                 stats.center_of_mass.data() + stats.center_of_mass.size());
    post(protocol::encode(report));
  };
  solve_level_task(scene, *h, {task.level, task.start, task.last}, inputs, sink, options);
}

}  // namespace pd::worker
