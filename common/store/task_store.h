#pragma once
// The farm's task store: one SQLite file (FARM_DIR/farm.sqlite) holding the scheduler's whole state,
// so that a restarted scheduler rebuilds everything from it (docs/farm.md, "Task store").
//
// Tables (schema version kTaskStoreSchemaVersion in PRAGMA user_version; another version is refused):
//   jobs(id, name, scene_name, scene_text, scene_files (JSON), frames, levels, subsets, priority,
//        preview_only, preview_chunk, hessian, state, reason, hierarchy_hash, submitted, finished,
//        stitch, seams (JSON))
//   tasks(id, job_id, kind, level, first, last, state, reason, worker_id, attempts, stitch, guides)
//   task_after(task_id, after_task_id)      the task waits until after_task_id is done (hierarchy)
//   task_frames(task_id, level, frame, guide)  frames of the job that must be stored before dispatch
//                                            (guide = 1: in guide_frames)
//   frames(job_id, level, frame, kappa, positions, stat_names, stat_values, center_of_mass)
//                                            every stored frame with its data (kappa: barrier
//                                            stiffness at the frame, J/m^4, NULL without contact)
//   guide_frames(job_id, level, frame, positions)  a later time subset's first frames, which a seam's
//                                            stitch task is guided toward (farm/task_graph.h) and
//                                            which are not the job's frames (never in its file)
//   hierarchies(job_id, hash, blob)          the job's hierarchy file as its hierarchy task built it
//   attempts(id, task_id, worker_id, started, ended, outcome, message)
//   workers(id, name, host, version, cores, state, last_seen, tasks_done)
//   events(id, time, job_id, task_id, worker_id, kind, message)
// Times are seconds since the Unix epoch (double). States are stored by their protocol names
// (protocol/protocol.h), one enum each, defined there.
//
// The store is the farm's authority on frames: a frame is recorded here (with its data) before it is
// written to the job's HDF5 file, so a job file lost or broken by a crash is repaired from the store
// (scheduler/job_files.h) and every frame recorded as stored reads back exactly.
//
// Durability: WAL mode with synchronous = NORMAL (a committed transaction survives a crash of the
// process), a busy timeout of 5 s, foreign keys on. Every method is one transaction; claim_next runs
// in BEGIN IMMEDIATE so that two claimers can never take the same task.
//
// Errors: StoreError naming the file and the statement that failed ("farm.sqlite: claim: database
// is locked"); an unknown id throws StoreError "farm.sqlite: no job 17".
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "protocol/protocol.h"

namespace pd {

// 3: jobs.stitch and jobs.seams, tasks.stitch and tasks.guides, task_frames.guide, guide_frames. A version-2 store is
// upgraded in place when opened (its jobs have no stitches).
constexpr int kTaskStoreSchemaVersion = 3;

class StoreError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct FrameKey {
  int level = 0;
  int frame = 0;
};

struct NewJob {
  std::string name;  // the scene's name
  protocol::SceneSource scene;
  int frames = 0;
  int levels = 0;        // hierarchy levels of the job (the scene's, or --levels)
  int subsets = 1;
  int priority = 0;
  bool preview_only = false;
  int preview_chunk = 0;
  std::string hessian;
  int stitch = 0;  // W: frames each seam of a refinement level is stitched over (farm/task_graph.h); 0: none
};

// A task to add. `after_hierarchy`: waits for the job's hierarchy task (added in the same call, or
// already in the store); `needs`: frames of the job that must be stored before it is dispatched.
struct NewTask {
  protocol::TaskKind kind = protocol::TaskKind::level;
  int level = 0;
  int first = 0;
  int last = 0;
  bool after_hierarchy = false;
  std::vector<FrameKey> needs;
  // Seam stitching (farm/task_graph.h): a stitch task (level l, (s, s + W - 1]) continues the level
  // horizontally from its own frames s - 1 and s, guided toward the later subset's first frames, which
  // it needs stored as guide frames (guide_needs); the later subset (s, b] reports its frames
  // s + 1 .. s + guides as guide frames (guides = W - 1), not as the job's frames.
  bool stitch = false;
  int guides = 0;
  std::vector<FrameKey> guide_needs;
};

// A stored frame's data, as the worker reported it and the job file holds it.
struct FrameData {
  std::vector<double> positions;             // 3 n, stacked x0 y0 z0 x1 ... (metres)
  std::vector<protocol::Stat> stats;         // in report order
  std::vector<double> center_of_mass;        // 3 per object, or empty
  std::optional<double> kappa;               // barrier stiffness at the frame (J/m^4); none without contact
};

// Flamenco's rules for failures: a task that failed on this many distinct workers fails for good;
// a worker that failed this many tasks of a job is blocklisted for the job (takes none of its tasks).
constexpr int kMaxTaskWorkers = 3;
constexpr int kBlocklistFailures = 3;

// What fail_attempt decided.
struct FailOutcome {
  bool task_failed = false;         // for good: the task is failed, its dependents blocked, the job failed
  int workers_failed = 0;           // distinct workers whose attempts of the task failed (this one included)
  bool worker_blocklisted = false;  // this failure blocklisted the worker for the job
};

struct JobRow {
  int64_t id = 0;
  NewJob spec;
  protocol::JobState state = protocol::JobState::queued;
  std::string reason;
  std::string hierarchy_hash;  // empty until the hierarchy task is done
  double submitted = 0.0, finished = 0.0;  // finished = 0 while not ended
  std::vector<std::string> seams;  // where each seam of its refinement levels was placed, and why (set_seams)
};

struct TaskRow {
  int64_t id = 0;
  int64_t job = 0;
  protocol::TaskKind kind = protocol::TaskKind::level;
  int level = 0, first = 0, last = 0;
  protocol::TaskState state = protocol::TaskState::waiting;
  std::string reason;
  int64_t worker = 0;   // running: the worker holding it; done: the one that finished it; else 0
  int attempts = 0;     // attempts started
  int64_t attempt = 0;  // running: the current attempt id; else 0
  bool stitch = false;  // a seam's stitch task (NewTask::stitch)
  int guides = 0;       // its frames first + 1 .. first + guides are guide frames (NewTask::guides)
};

struct WorkerRow {
  int64_t id = 0;
  std::string name, host, version;
  int cores = 0;
  std::string state;    // "idle", "busy", "lost"
  double last_seen = 0.0;
  int tasks_done = 0;
};

struct Claim {
  TaskRow task;  // now running, task.attempt set
  int64_t attempt = 0;
};

struct EventRow {
  int64_t id = 0;
  double time = 0.0;
  int64_t job = 0, task = 0, worker = 0;
  std::string kind, message;
};

class TaskStore {
 public:
  // Opens (creating when missing) the store at `path`; throws StoreError for a file that is not a
  // task store or has another schema version.
  explicit TaskStore(const std::string& path);
  ~TaskStore();
  TaskStore(const TaskStore&) = delete;
  TaskStore& operator=(const TaskStore&) = delete;

  const std::string& path() const;

  // Jobs. add_job inserts the job (state queued) and its tasks in one transaction and promotes the
  // tasks whose inputs are met to ready. Returns the job id.
  int64_t add_job(const NewJob& job, const std::vector<NewTask>& tasks);
  // Adds tasks to an existing job (pd refine), promotes ready ones; a done job goes back to running.
  void add_tasks(int64_t job, const std::vector<NewTask>& tasks);
  JobRow job(int64_t id) const;
  std::optional<JobRow> find_job(int64_t id) const;
  std::vector<JobRow> jobs() const;  // by id
  void set_job_state(int64_t job, protocol::JobState state, const std::string& reason = "");
  // The hierarchy task's result: sets the job's hierarchy_hash and keeps the file's bytes.
  void store_hierarchy(int64_t job, const std::string& hash, const std::string& blob);
  std::string hierarchy_blob(int64_t job) const;  // StoreError when the job has none
  // Sets preview_only = false (pd refine).
  void set_preview_only(int64_t job, bool preview_only);
  // Keeps where the job's seams were placed and why (farm/seam_placement.h PlacedSeam::reason), for
  // pd status.
  void set_seams(int64_t job, const std::vector<std::string>& reasons);
  // Sets the job's subsets K and stitch width W (pd refine --subsets, --stitch).
  void set_subsets(int64_t job, int subsets, int stitch);

  // Tasks.
  TaskRow task(int64_t id) const;
  std::vector<TaskRow> tasks(int64_t job) const;  // by level, then first
  // Marks a running or ready task done (worker credited with tasks_done + 1 when given); promotes the
  // tasks waiting after it; the job becomes done when all its tasks are.
  void finish_task(int64_t task);
  // The task fails for good with `reason`: every task of the job that needs one of its frames
  // (directly or through others) becomes blocked, and the job failed. Its open attempt closes failed.
  void fail_task(int64_t task, const std::string& reason);
  // The running attempt `attempt` of `task` failed with `message` (a soft failure): closed as failed;
  // after kMaxTaskWorkers distinct workers the task fails for good (fail_task), else it is ready
  // again for any worker but those that failed it. The attempt's worker is blocklisted for the job
  // after kBlocklistFailures failed tasks of it.
  FailOutcome fail_attempt(int64_t task, int64_t attempt, const std::string& message);
  // The running attempt `attempt` of a level >= 1 task (a, b], a > 0, found no safe upsampling for
  // its vertical start (protocol::FailureKind::vertical_start_refused). That refusal depends only on
  // the frames, so another worker would fail the same way: instead the task now also needs its own
  // level's frames a - 1 and a (stored by the subset before it) and continues horizontally from them
  // once they are (waiting until then). The attempt closes as "vertical start refused", which counts
  // against neither the task nor the worker. Without a vertical start there is no seam to stitch: the
  // task's guides become 0 and its seam's stitch task (waiting for guide frames it would never get) is
  // removed. Throws StoreError for another attempt or task.
  void continue_horizontally(int64_t task, int64_t attempt, const std::string& message);
  // The running attempt `attempt` of a level >= 1 task (a, b], a > 0, found no safe upsampling at a
  // (as continue_horizontally), and the seam moves to a' (a < a' < b): the task becomes (a', b],
  // waiting for `needs` (the task graph's, farm/task_graph.h subset_needs) to start vertically
  // there, and a new task (a, a'] of the same level continues horizontally from the level's own
  // frames a-1 and a (a bridge over the frames the seam left). The attempt closes as "vertical start
  // refused". The seam's stitch task, if any, goes with it: replaced by `stitch` (the task graph's
  // stitch for a', farm/task_graph.h stitch_task), or removed when that is nullopt; the task's guides
  // follow. Returns the bridge's id. Throws StoreError for another attempt or task, or a' outside
  // (a, b).
  int64_t move_seam(int64_t task, int64_t attempt, int new_first, const std::vector<FrameKey>& needs,
                    const std::optional<NewTask>& stitch, const std::string& message);
  // Vertical starts of the task refused so far (attempts closed "vertical start refused").
  int refused_starts(int64_t task) const;
  // Whether the task continues horizontally from its own level's frames (level >= 1, first > 0, and
  // continue_horizontally made it need its own frame `first`). Level-0 chunks always do and are not
  // reported here.
  bool continues_horizontally(int64_t task) const;
  // Whether `worker` may take `task`: it has not failed it and is not blocklisted for its job.
  bool may_run(int64_t task, int64_t worker) const;
  // A failed job runs again: its failed and blocked tasks go back to waiting (ready when their inputs
  // are stored), earlier failures stop counting against tasks and workers. Returns the tasks requeued.
  int requeue_job(int64_t job);
  // At scheduler start: every attempt still open ends "scheduler restarted", its task goes back to
  // ready, and every worker is lost until it says hello again. Returns the tasks released.
  std::vector<TaskRow> recover_after_restart();
  // A running task goes back to ready (its worker was lost or the attempt was refused); its attempt
  // is closed with `outcome`.
  void release_task(int64_t task, const std::string& outcome);
  // Every waiting, ready or running task of the job becomes cancelled, the job cancelled.
  void cancel_job(int64_t job);

  // Frames. record_frame stores the frame's data (before the job file is written, see the top) and
  // promotes the waiting tasks whose inputs are all stored. Recording a frame again replaces it.
  void record_frame(int64_t job, const FrameKey& key, const FrameData& data);
  std::optional<FrameData> frame_data(int64_t job, const FrameKey& key) const;  // nullopt when not stored
  std::vector<FrameKey> frame_keys(int64_t job) const;  // the job's stored frames, by level then frame
  bool frame_stored(int64_t job, const FrameKey& key) const;
  std::optional<double> frame_kappa(int64_t job, const FrameKey& key) const;
  // Stored frames per level (index = level, size = the job's levels).
  std::vector<int> frames_stored(int64_t job) const;
  // Stored frames of a level in [first, last] (sorted).
  std::vector<int> stored_frames(int64_t job, int level, int first, int last) const;
  // Guide frames (NewTask::guides): recorded like frames (promoting the tasks that need them; again
  // replaces), but never the job's frames.
  void record_guide_frame(int64_t job, const FrameKey& key, const std::vector<double>& positions);
  std::optional<std::vector<double>> guide_frame(int64_t job, const FrameKey& key) const;  // nullopt when not stored
  std::vector<int> stored_guide_frames(int64_t job, int level, int first, int last) const;  // sorted

  // Claims, in BEGIN IMMEDIATE: the best ready task of a queued or running job (highest job
  // priority, then oldest job, then lowest level, then earliest first frame), marked running on
  // `worker` with a new attempt; the job becomes running. nullopt when none is ready.
  std::optional<Claim> claim_next(int64_t worker);
  // Whether any task of a queued or running job is ready (a read: lets the scheduler skip claiming
  // for each idle worker when there is nothing to claim).
  bool has_ready_task() const;
  // Closes an attempt (outcome: "done", "failed", "lost", "cancelled", "refused", ...).
  void end_attempt(int64_t attempt, const std::string& outcome, const std::string& message = "");

  // Workers. A worker is known by its name: add_worker for a name already in the store updates and
  // returns that row (so failures and blocklists follow a worker across reconnections).
  int64_t add_worker(const std::string& name, const std::string& host, const std::string& version, int cores);
  void set_worker_state(int64_t worker, const std::string& state);
  void touch_worker(int64_t worker);  // last_seen = now
  WorkerRow worker(int64_t id) const;
  std::vector<WorkerRow> workers() const;  // by id

  // Event log (one row per event; the scheduler also prints each on stderr).
  void log_event(int64_t job, int64_t task, int64_t worker, const std::string& kind, const std::string& message);
  std::vector<EventRow> events(int64_t job) const;  // job = 0: all

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pd
