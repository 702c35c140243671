#pragma once
// The farm's messages: every message between pd-scheduler, pd-worker and the pd client is declared
// here, once (docs/farm.md, "Protocol"). protocol/ knows plain data only (ids, levels, frame ranges,
// arrays, text), not the simulation library: the worker turns an AssignTask into a LevelTask, the
// scheduler turns FrameReports into the job file.
//
// Wire format: a ZeroMQ multipart message (without the ROUTER's identity frames) is a list of
// parts. Part 0 is a JSON object header with at least
//   "v": kProtocolVersion (integer), "type": the message type name (string, see MessageType),
// and the message's fields. Parts 1.. carry bulk data, raw and never inside JSON:
//   float64 arrays: little-endian IEEE-754 doubles, 8 bytes each, no header;
//   byte blobs: a file's bytes as they are (an HDF5 hierarchy or job file).
// Which data parts a message has, and their exact byte sizes, follow from its header fields
// (e.g. FrameReport: one part of 3 * vertices doubles), and decoding checks them.
//
// Families: Command (scheduler -> worker), Report (worker -> scheduler), Request (client ->
// scheduler), Reply (scheduler -> client). Each family decodes into its own std::variant; a message
// of another family, an unknown type, another version, a missing or mistyped field, a wrong part
// count or part size, or a part over kMaxMessageBytes throws ProtocolError naming the message type
// and the field, e.g. "frame: field 'level': missing" or "frame: part 1: 96 bytes, expected 3 * 5 *
// 8 = 120". Decoding never crashes and never reads outside the given parts.
//
// Conventions: ids are positive 64-bit integers given by the scheduler's task store (0 = none);
// frames t = 0..N, level 0 = coarsest; a level task solves frames (first, last]; positions are
// stacked x0 y0 z0 x1 ... in metres, in the level's global vertex ids.
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace pd::protocol {

// Bumped on any change to a message's fields or meaning; peers with another version are refused.
// 2: AssignTask.start, heartbeat ping/pong, RequeueJob.
// 3: Hello.slurm_job, Goodbye, AddSlurmWorkers / RemoveSlurmWorkers / SlurmAccepted, WorkersReply's
//    Slurm part.
// 4: TaskFailed.failure (FailureKind), TaskStatus.horizontal.
// 5: the prolonged Hessian name "auto" (SubmitJob's default; AssignTask.hessian may carry it).
// 6: Hello.blas_kernel.
// 7: seam stitches: AssignTask.guides, SubmitJob.stitch, RefineJob.stitch, TaskStatus.stitch,
//    JobStatus.stitch; JobStatus.seams.
// 8: a stitch's guide frames stream as GuideFrame commands; AssignTask.guides becomes AssignTask.stitch.
// 9: AssignTask.scene_hash, and AssignTask.scene only when the worker has not been sent that scene;
//    scene files with bytes that are not plain text travel as "content_base64" (PC2 caches).
constexpr int kProtocolVersion = 9;

// Upper bound on a whole message (all parts), bytes; larger messages are refused when decoded (and
// sockets set ZMQ_MAXMSGSIZE to it). 1 GiB: a job file fetched in one reply must fit.
constexpr std::size_t kMaxMessageBytes = std::size_t{1} << 30;

using Parts = std::vector<std::string>;

class ProtocolError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// ---------------------------------------------------------------------------------------------------
// States, defined once. The task store holds them as their names (to_string / parse_*).

enum class JobState {
  queued,     // submitted, no task has started yet
  running,    // at least one task has started and the job is not finished
  done,       // every task of the job is done: every frame of every level asked for is stored
  failed,     // a task failed for good (reason stored with the job); its dependents are blocked
  cancelled,  // cancelled by a client; its running tasks were told to stop, no frame is added
};

enum class TaskState {
  waiting,    // some input it needs before its first step (hierarchy, frames) is not stored yet
  ready,      // every input of its first step is stored; waits for a free worker
  running,    // held by one attempt on one worker; frames stream back as they are solved
  done,       // every frame of its range is stored
  failed,     // its last attempt failed (message stored with the task)
  blocked,    // cannot run because a task whose frames it needs failed (reason stored)
  cancelled,  // its job was cancelled
};

enum class TaskKind {
  hierarchy,  // build the job's level hierarchy (stored in the job file, shipped to workers)
  level,      // solve level `level`, frames (first, last] (progressive/level_task.h)
};

// Why an attempt failed, as far as the scheduler acts on it.
enum class FailureKind {
  error,                   // anything else (bad input, a solver error): retried on other workers,
                           // then the task fails for good (TaskStore::fail_attempt)
  vertical_start_refused,  // a level >= 1 subset (a, b], a > 0, found no safe upsampling of level
                           // l - 1's frame a (UpsamplingFailed): deterministic, so no other worker
                           // would do better; the task continues horizontally from its own level's
                           // frames a - 1 and a instead (TaskStore::continue_horizontally)
};

std::string to_string(JobState s);
std::string to_string(TaskState s);
std::string to_string(TaskKind k);
std::string to_string(FailureKind k);
// Throw ProtocolError("<what>: unknown job state 'x'") etc. for an unknown name.
JobState parse_job_state(const std::string& name, const std::string& what);
TaskState parse_task_state(const std::string& name, const std::string& what);
TaskKind parse_task_kind(const std::string& name, const std::string& what);
FailureKind parse_failure_kind(const std::string& name, const std::string& what);

// A named scalar statistic of a frame (store/frame_store.h FrameStats::scalars).
using Stat = std::pair<std::string, double>;

// A file a scene refers to (an OBJ mesh), shipped with the scene so that a worker needs nothing but
// the endpoint. path: relative to the scene file's folder, as the scene writes it.
struct SceneFile {
  std::string path;
  std::string content;
};

// What a job's scene is on the wire: the scene file's text, the name used in error messages, and the
// files it refers to.
struct SceneSource {
  std::string name;  // the scene file's path as the client gave it (for messages)
  std::string text;  // the scene JSON
  std::vector<SceneFile> files;
};

// ---------------------------------------------------------------------------------------------------
// Commands: scheduler -> worker.

// Reply to Hello: the worker's id in the task store and the heartbeat period both sides use.
struct Welcome {
  int64_t worker = 0;
  int heartbeat_ms = 1000;
};

// Run one attempt of a task. For kind == level the worker then receives the frames of level - 1 it
// needs as BelowFrame messages (frames max(first - 1, 0) .. last - 1), in any order, while it runs;
// a stitch also receives its guide frames first + 1 .. last as GuideFrame messages.
struct AssignTask {
  int64_t attempt = 0;
  int64_t task = 0;
  int64_t job = 0;
  TaskKind kind = TaskKind::level;
  int level = 0;
  int first = 0;  // a
  int last = 0;   // b
  // The frame this attempt starts from, first <= start < last: first for a task's first attempt;
  // a later attempt continues horizontally from the task's last stored frames (own_before/own_start
  // are then frames start - 1 and start, own_kappa the barrier stiffness at start).
  int start = 0;
  int frames = 0;  // the job's frame count N (overrides the scene's)
  int levels = 0;  // the job's hierarchy level count (overrides the scene's hierarchy.levels)
  std::string hessian;  // prolonged Hessian name ("auto", "lagged", "galerkin", "coarse", "coarse-first")
  // The job's scene (text and files: meshes, an animated obstacle's cache, possibly megabytes) is sent
  // once per worker session: scene_hash always (farm::scene_source_hash), scene only when the
  // scheduler has not sent this hash to this worker yet; the worker keeps what it was sent.
  std::string scene_hash;
  std::optional<SceneSource> scene;
  std::string hierarchy_hash;  // kind == level: the hierarchy the task runs on
  // kind == level: the hierarchy file's bytes when the scheduler has not sent this hash to this
  // worker yet (data part 1 when present; "hierarchy_bytes" in the header says its size).
  std::optional<std::string> hierarchy_blob;
  // Horizontal continuation: the level's own frames start - 1 and start (3 n_l doubles each, data
  // parts after the blob) and, with contact, the barrier stiffness at frame start (J/m^4).
  std::optional<std::vector<double>> own_before, own_start;
  std::optional<double> own_kappa;
  // A seam's stitch task (farm/task_graph.h; it continues horizontally, so own frames are present):
  // its guide frames come as GuideFrame messages while it runs, as the later subset solves them.
  bool stitch = false;
};

// A frame of level `level` (the level below the task's) for the running attempt.
struct BelowFrame {
  int64_t attempt = 0;
  int64_t task = 0;
  int level = 0;
  int frame = 0;
  std::vector<double> positions;  // data part 1
};

// A guide frame of a running stitch (AssignTask.stitch): the later subset's frame `frame` of the
// task's own level, first + 1 <= frame <= last. Sent in frame order as the later subset stores them.
struct GuideFrame {
  int64_t attempt = 0;
  int64_t task = 0;
  int level = 0;
  int frame = 0;
  std::vector<double> positions;  // data part 1
};

// Stop the attempt (job cancelled, or the attempt was taken away); the worker sends nothing more for it.
struct CancelTask {
  int64_t attempt = 0;
  int64_t task = 0;
  std::string reason;
};

// The scheduler is alive (sent every heartbeat_ms to each connected worker). pong: the ping of the
// worker heartbeat it answers at once (0 for a periodic heartbeat), so the worker can time the round trip.
struct SchedulerHeartbeat {
  int64_t pong = 0;
};

// A report was refused (stale attempt, malformed, out of order); the worker logs it.
struct Refused {
  std::string reason;
};
// The reason a scheduler gives a peer it has no session for (it restarted, or dropped the worker as
// lost): a worker that gets it says Hello again.
constexpr const char* kUnknownWorkerReason = "unknown worker: send hello first";

using Command = std::variant<Welcome, AssignTask, BelowFrame, GuideFrame, CancelTask, SchedulerHeartbeat, Refused>;

// ---------------------------------------------------------------------------------------------------
// Reports: worker -> scheduler.

// First message of a worker connection (and after every reconnect).
struct Hello {
  std::string name;      // --name, default host:pid
  std::string version;   // the worker's software version (PROJECT_VERSION)
  int cores = 1;         // hardware threads of its machine
  std::string host;
  // The Slurm job this worker runs as, "<array job>_<array task>" (or "<job>" outside an array), from
  // the SLURM_* variables Slurm gives a batch job; "" when not started by Slurm.
  std::string slurm_job;
  // The OpenBLAS kernel the worker's solves run on (util/process_setup.h: "Haswell" on every AVX2
  // machine unless set by hand). Workers on different kernels give frames that differ in the last
  // bits; the scheduler logs it.
  std::string blas_kernel;
};

// The worker is alive; `attempt` is the attempt it is running (0 = idle). ping != 0 asks for an
// immediate SchedulerHeartbeat with pong = ping (a round-trip probe; load tests use it).
struct WorkerHeartbeat {
  int64_t attempt = 0;
  int64_t ping = 0;
};

// One solved frame of the attempt's task (frame 0 too, when the task starts at frame 0).
struct FrameReport {
  int64_t attempt = 0;
  int64_t task = 0;
  int level = 0;
  int frame = 0;
  std::vector<double> positions;  // data part 1, 3 n_l doubles
  std::vector<Stat> stats;        // scalar statistics (names as frame_stats gives them)
  std::vector<double> center_of_mass;  // 3 per object (may be empty): in the header, not a part
};

// The attempt solved every frame of its task.
struct TaskDone {
  int64_t attempt = 0;
  int64_t task = 0;
  int unconverged_steps = 0;
  bool vertical_start = false;
  double seconds = 0.0;  // wall time of the attempt on the worker
};

// The attempt failed (bad scene, no safe upsampling, solver error); message says why.
struct TaskFailed {
  int64_t attempt = 0;
  int64_t task = 0;
  std::string message;
  FailureKind failure = FailureKind::error;
};

// A hierarchy task's result: the hierarchy file (store/hierarchy_store.h) as bytes (data part 1).
struct HierarchyDone {
  int64_t attempt = 0;
  int64_t task = 0;
  std::string hash;
  int levels = 0;
  std::vector<int> vertices;  // per level, coarsest first
  std::string blob;
};

// The worker is stopping (SIGTERM from Slurm's scancel or time limit, systemd, Ctrl-C): its session
// ends now and the attempt it ran (0: none) goes to another worker at once, instead of after the
// liveness time. Sent once, best effort: a worker that dies without it is lost by liveness.
struct Goodbye {
  int64_t attempt = 0;
  std::string reason;
};

using Report = std::variant<Hello, WorkerHeartbeat, FrameReport, TaskDone, TaskFailed, HierarchyDone, Goodbye>;

// ---------------------------------------------------------------------------------------------------
// Requests: client -> scheduler. Each gets exactly one Reply (an ErrorReply when it cannot be served).

struct SubmitJob {
  SceneSource scene;
  bool preview_only = false;
  int levels = 0;      // 0: the scene's hierarchy.levels
  int subsets = 1;     // K time subsets per refinement level
  int priority = 0;    // higher runs first
  int frames = 0;      // 0: the scene's frame count
  int preview_chunk = 0;  // frames per preview (level 0) task; 0: the scheduler's default
  std::string hessian = "auto";  // progressive/level_system.h: parse_level_hessian
  int stitch = 0;      // W: frames each seam is stitched over (farm/task_graph.h); 0: none
};

// Add the refinement levels to a preview-only job (running or done).
struct RefineJob {
  int64_t job = 0;
  int subsets = 1;
  int stitch = 0;      // as SubmitJob::stitch
};

// Status of one job (job != 0) or of every job.
struct StatusRequest {
  int64_t job = 0;
};

// The job file as stored so far.
struct FetchRequest {
  int64_t job = 0;
};

struct CancelJob {
  int64_t job = 0;
};

// Retry a failed job: its failed and blocked tasks go back to waiting (ready when their inputs are
// stored), the failures that excluded workers are forgotten, the job runs again.
struct RequeueJob {
  int64_t job = 0;
};

struct WorkersRequest {};

// Start `count` workers as one Slurm job array (sbatch run by the scheduler with its --slurm-script;
// docs/deploy.md). Empty strings and 0 leave Slurm's or the script's default. The values are checked
// by farm/slurm.h's rules before anything runs.
struct AddSlurmWorkers {
  int count = 1;
  std::string partition;   // sbatch --partition
  std::string time_limit;  // sbatch --time, Slurm's format ("30", "2:00:00", "1-00:00:00")
  int cpus = 0;            // sbatch --cpus-per-task
  std::string memory;      // sbatch --mem ("4G", "500M")
  // The number of Slurm workers the scheduler keeps running while work remains (submitting a
  // replacement when one ends); -1 leaves the current target (0 at first: none kept).
  int keep = -1;
};

// Drain Slurm workers: slurm_job is an array job ("123": all its workers) or one array task
// ("123_4"). Pending or idle workers are cancelled (scancel) at once; a busy one finishes its task
// first, unless `now`, which cancels it at once (its task goes to another worker). Lowers the keep
// target by the number of workers removed.
struct RemoveSlurmWorkers {
  std::string slurm_job;
  bool now = false;
};

using Request = std::variant<SubmitJob, RefineJob, StatusRequest, FetchRequest, CancelJob, RequeueJob, WorkersRequest,
                             AddSlurmWorkers, RemoveSlurmWorkers>;

// ---------------------------------------------------------------------------------------------------
// Replies: scheduler -> client.

struct Submitted {
  int64_t job = 0;
};

// Reply to RefineJob, CancelJob and RequeueJob.
struct Accepted {
  int64_t job = 0;
  std::string message;
};

struct LevelProgress {
  int level = 0;
  int frames_done = 0;   // frames of this level stored (frame 0 included)
  int frames_total = 0;  // N + 1
  int vertices = 0;      // 0 until the hierarchy is built
};

struct TaskStatus {
  int64_t id = 0;
  TaskKind kind = TaskKind::level;
  int level = 0;
  int first = 0;
  int last = 0;
  TaskState state = TaskState::waiting;
  int frames_done = 0;    // frames of (first, last] stored
  std::string worker;     // name of the worker running it, or of the one that finished it
  int attempts = 0;
  std::string reason;     // failed / blocked: why
  // A subset (level >= 1, first > 0) whose vertical start was refused and that continues from its
  // own level's frames instead (FailureKind::vertical_start_refused).
  bool horizontal = false;
  bool stitch = false;    // a seam's stitch task (farm/task_graph.h)
};

struct JobStatus {
  int64_t id = 0;
  std::string name;       // the scene's name
  JobState state = JobState::queued;
  std::string reason;     // failed: why
  int priority = 0;
  int frames = 0;         // N
  int subsets = 1;
  int stitch = 0;         // W (SubmitJob::stitch)
  std::vector<std::string> seams;  // where each seam was placed from the preview, and why (K >= 2)
  bool preview_only = false;
  double elapsed_seconds = 0.0;  // since submission (until the end for a finished job)
  double eta_seconds = -1.0;     // estimated time to finish, -1 when unknown
  std::vector<LevelProgress> levels;
  std::vector<TaskStatus> tasks;
};

struct StatusReply {
  std::vector<JobStatus> jobs;
};

struct FetchReply {
  int64_t job = 0;
  std::string blob;  // the job file's bytes (data part 1)
};

struct WorkerStatus {
  int64_t id = 0;
  std::string name;
  std::string host;
  std::string version;
  int cores = 0;
  std::string state;       // "idle", "busy", "lost"
  int64_t task = 0;        // running task, 0 when idle
  double seen_seconds_ago = 0.0;
  int tasks_done = 0;
  std::string slurm_job;   // Hello.slurm_job ("" when not a Slurm worker)
};

// A Slurm array task the scheduler submitted (or a Slurm worker that connected on its own).
struct SlurmWorkerStatus {
  std::string slurm_job;   // "<array job>_<array task>"
  // Slurm's job state as squeue last showed it (PENDING, RUNNING, COMPLETED, CANCELLED, TIMEOUT,
  // FAILED, ...), "SUBMITTED" before the first poll, "CANCELLING" from the scheduler's scancel
  // until squeue shows the end, "GONE" once squeue no longer lists it, "ENDED" for a job submitted
  // by hand (not polled) once its worker is lost.
  std::string state;
  std::string worker;      // the name of the pd-worker it became ("" until it says hello)
  bool draining = false;   // pd workers remove: cancelled once its task ends
  bool replacement = false;  // submitted by the scheduler to keep the target (AddSlurmWorkers.keep)
  double submitted_seconds_ago = 0.0;
  std::string reason;      // squeue's reason (pending: "Resources", ...) or why it ended
};

struct WorkersReply {
  std::vector<WorkerStatus> workers;
  std::vector<SlurmWorkerStatus> slurm;  // newest first; ended ones are kept for an hour
  int slurm_keep = 0;                    // the keep target (AddSlurmWorkers.keep)
};

// Reply to AddSlurmWorkers and RemoveSlurmWorkers.
struct SlurmAccepted {
  std::string slurm_job;               // the array job submitted, or the one named
  std::vector<std::string> tasks;      // its array tasks ("123_0", ...) added, cancelled or draining
  std::string message;
};

// The request could not be served; message says why (e.g. "no job 17").
struct ErrorReply {
  std::string message;
};

using Reply = std::variant<Submitted, Accepted, StatusReply, FetchReply, WorkersReply, SlurmAccepted, ErrorReply>;

// ---------------------------------------------------------------------------------------------------
// Encoding and decoding. encode(x) gives the parts of x; decode_<family>(parts) gives the message or
// throws ProtocolError as described at the top.

Parts encode(const Welcome& m);
Parts encode(const AssignTask& m);
Parts encode(const BelowFrame& m);
Parts encode(const GuideFrame& m);
Parts encode(const CancelTask& m);
Parts encode(const SchedulerHeartbeat& m);
Parts encode(const Refused& m);
Parts encode(const Command& m);

Parts encode(const Hello& m);
Parts encode(const WorkerHeartbeat& m);
Parts encode(const FrameReport& m);
Parts encode(const TaskDone& m);
Parts encode(const TaskFailed& m);
Parts encode(const HierarchyDone& m);
Parts encode(const Goodbye& m);
Parts encode(const Report& m);

Parts encode(const SubmitJob& m);
Parts encode(const RefineJob& m);
Parts encode(const StatusRequest& m);
Parts encode(const FetchRequest& m);
Parts encode(const CancelJob& m);
Parts encode(const RequeueJob& m);
Parts encode(const WorkersRequest& m);
Parts encode(const AddSlurmWorkers& m);
Parts encode(const RemoveSlurmWorkers& m);
Parts encode(const Request& m);

Parts encode(const Submitted& m);
Parts encode(const Accepted& m);
Parts encode(const StatusReply& m);
Parts encode(const FetchReply& m);
Parts encode(const WorkersReply& m);
Parts encode(const SlurmAccepted& m);
Parts encode(const ErrorReply& m);
Parts encode(const Reply& m);

Command decode_command(const Parts& parts);
Report decode_report(const Parts& parts);
Request decode_request(const Parts& parts);
Reply decode_reply(const Parts& parts);

// The message type name of part 0 ("frame", "hello", ...) without checking the rest; ProtocolError
// when part 0 is not a JSON object with an integer "v" and a string "type". For log lines.
std::string message_type(const Parts& parts);

// JSON text of a status or workers reply as `pd status --json` / `pd workers --json` print them
// (docs/farm.md gives the shapes).
std::string to_json_text(const StatusReply& m);
std::string to_json_text(const WorkersReply& m);

}  // namespace pd::protocol
