#pragma once
// pd-scheduler's core: one thread, two ROUTER sockets (workers, clients), the task store
// (store/task_store.h: the state that survives the process) and the job files. Each loop turn
// receives what arrived, dispatches ready tasks to idle workers, feeds running refinement tasks the
// frames of the level below as they are stored, sends heartbeats and drops workers that went
// silent (zguide's Paranoid Pirate: kLiveness missed heartbeats).
//
// In memory only, and rebuilt from the messages that follow a restart: the worker sessions (which
// socket identity is which worker, what each was sent). Everything else lives in SQLite, frames
// included; the job files are rebuilt from it at start (recover()).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>

#include <zmq.hpp>

#include "farm/curve.h"
#include "protocol/protocol.h"
#include "scheduler/job_files.h"
#include "scheduler/refusal_rows.h"
#include "scheduler/slurm_pool.h"
#include "store/task_store.h"

namespace pd::scheduler {

struct SchedulerOptions {
  std::string dir;  // FARM_DIR
  std::string workers_endpoint = "tcp://127.0.0.1:7400";
  std::string clients_endpoint = "tcp://127.0.0.1:7401";
  int heartbeat_ms = 1000;
  // CURVE (scheduler/security.h): this scheduler's key pair and the public keys it admits; both or
  // neither, and both whenever an endpoint is not loopback.
  std::string key_file, authorized_keys_file;
  SlurmOptions slurm;  // workers started as Slurm jobs (scheduler/slurm_pool.h); disabled without a script
};

// Unix time, seconds (the task store's and the Slurm store's clock).
double unix_now();

constexpr int kLiveness = 3;

// Flow control of the frames of the level below (BelowFrame): a running refinement attempt is sent
// frames only up to kFeedWindow past the last frame it reported, so its frame reports are the
// acknowledgements that open the window further. Without it an attempt assigned after thousands of
// frames of the level below were stored got them all in one burst, past ZeroMQ's send high-water
// mark (1 000 messages). 16 frames keep a worker from ever waiting for the window (it needs one new
// frame per step and reports one per step) while bounding what is queued to 16 frames per worker.
constexpr int kFeedWindow = 16;

// A refused vertical start moves its seam this many frames later, at most kMaxSeamMoves times, before
// the subset continues horizontally instead (worker_reports.cpp). Refusals come in tight contact and
// last a few frames (cube-impact-sheet's impact: frames 28-31 of level 1).
constexpr int kSeamMoveFrames = 3;
constexpr int kMaxSeamMoves = 2;

// A stored task's kind and range, as the task graph's functions (farm/task_graph.h) take them.
NewTask as_new_task(const TaskRow& t);

using Clock = std::chrono::steady_clock;

// A connected worker (one DEALER identity).
struct Session {
  int64_t worker = 0;
  std::string name;
  Clock::time_point last_heard, last_sent;
  std::set<std::string> hierarchies;  // hashes this worker has (sent to it, or built by it)
  std::set<std::string> scenes;       // scene hashes sent to it (AssignTask.scene_hash)
  int64_t attempt = 0, task = 0, job = 0;  // the attempt it runs; 0 when idle
  bool draining = false;  // told to cancel; free once a heartbeat says it runs nothing
  std::set<int> fed;      // frames of the level below sent (queued whole) for the running attempt
  std::set<int> fed_guides;  // guide frames sent to the running stitch (GuideFrame)
  int progress = 0;       // the last frame the running attempt reported (its first frame before any)
  std::string slurm_job;  // Hello.slurm_job: the Slurm job it runs as ("" when not a Slurm worker)
  std::string blas_kernel;  // Hello.blas_kernel
};

// Replies queued to one client at most (its socket's send high-water mark; scheduler.cpp).
constexpr int kClientReplyQueue = 16;

class Scheduler {
 public:
  explicit Scheduler(const SchedulerOptions& options);
  ~Scheduler();

  // The endpoints actually bound (port 0 resolved).
  std::string workers_endpoint() const;
  std::string clients_endpoint() const;

  // Serves until `stop` becomes true. Whenever `reload_keys` (if given) is true, it is reset and the
  // keys are reloaded (reload_keys() below) within a loop turn (a quarter heartbeat).
  void run(const std::atomic<bool>& stop, std::atomic<bool>* reload_keys = nullptr);

  // Reads --authorized-keys again (SIGHUP): handshakes from then on admit the file's keys; peers
  // already connected keep their sessions. A file that cannot be read or lists no valid key keeps
  // the keys in use. Logged as keys_reloaded / keys_reload_failed (or keys_reload_ignored without
  // CURVE).
  void reload_keys();

 private:
  // worker_reports.cpp
  void on_worker_message(const std::string& identity, const protocol::Parts& parts);
  void on_report(const std::string& identity, protocol::Hello& m);
  void on_report(const std::string& identity, protocol::WorkerHeartbeat& m);
  void on_report(const std::string& identity, protocol::FrameReport& m);
  void on_report(const std::string& identity, protocol::TaskDone& m);
  void on_report(const std::string& identity, protocol::TaskFailed& m);
  void on_report(const std::string& identity, protocol::HierarchyDone& m);
  void on_report(const std::string& identity, protocol::Goodbye& m);
  // The session running `attempt`, or nullptr after refusing the report (logged, Refused sent).
  Session* attempt_session(const std::string& identity, int64_t attempt, int64_t task, const char* what);
  void refuse(const std::string& identity, const std::string& reason);

  // client_requests.cpp
  void on_client_message(const std::string& identity, const protocol::Parts& parts);
  protocol::Reply serve(protocol::SubmitJob& m);
  protocol::Reply serve(protocol::RefineJob& m);
  protocol::Reply serve(protocol::StatusRequest& m);
  protocol::Reply serve(protocol::FetchRequest& m);
  protocol::Reply serve(protocol::CancelJob& m);
  protocol::Reply serve(protocol::RequeueJob& m);
  protocol::Reply serve(protocol::WorkersRequest& m);
  protocol::Reply serve(protocol::AddSlurmWorkers& m);
  protocol::Reply serve(protocol::RemoveSlurmWorkers& m);
  // Whether the worker named `name` is connected and running an attempt (SlurmPool's Busy).
  bool worker_busy(const std::string& name) const;
  protocol::JobStatus job_status(const JobRow& job);

  // seams.cpp: refinement of K >= 2 subsets waits for the whole preview, whose calm frames get the seams.
  bool refinement_pending(const JobRow& job) const;
  std::vector<int> place_job_seams(const JobRow& job);  // logged as seams_placed, with the reasons
  // Adds the refinement tasks of a pending job whose preview is stored whole; nothing otherwise.
  void add_pending_refinement(const JobRow& job);

  // scheduler.cpp
  void recover();
  // Builds the job's file anew from the store; false (logged, an unfinished job failed) when it cannot.
  bool rebuild_job_file(const JobRow& job);
  int continuation_start(const TaskRow& t) const;
  // The running attempt of s on task t failed: retried elsewhere or failed for good (store rules).
  void attempt_failed(Session& s, const TaskRow& t, const std::string& message);
  void turn();  // one loop turn: receive, dispatch, preempt, heartbeats
  void dispatch();
  bool assign(const std::string& identity, Session& s, const Claim& claim);
  // Sends the running refinement attempt of s every stored frame of the level below it will ask for
  // up to s.progress + kFeedWindow that it was not sent yet (on assignment, on each of its frame
  // reports and heartbeats: a send refused by a full queue is tried again there), and a running
  // stitch its stored guide frames in the same window.
  void top_up_feed(const std::string& identity, Session& s);
  void store_guide_frame(const std::string& identity, Session& s, const TaskRow& t, const protocol::FrameReport& m);
  void feed_new_frame(int64_t job, int level, int frame);
  void feed_guide_frame(int64_t job, int level, int frame, const std::vector<double>& positions);
  // False when the message was not queued: the peer's queue is full (the message is dropped; the
  // peer is not blamed for it) or the peer is gone.
  bool send_worker(const std::string& identity, const protocol::Parts& parts);
  void preempt_starved();
  void heartbeats_and_liveness();
  void lose(const std::string& identity, const std::string& why);
  void end_attempt_of(Session& s);
  void cancel_attempts_of_job(int64_t job, const std::string& reason);
  void event(const std::string& kind, int64_t job, int64_t task, int64_t worker, const std::string& message,
             bool persist = true);

  SchedulerOptions options_;
  zmq::context_t ctx_;
  // The ZAP handler (null without CURVE). Declared between ctx_ and the sockets so that it is
  // destroyed after them (while a CURVE socket is open without its handler, libzmq lets handshakes
  // through unchecked) and before ctx_ (whose termination waits for the handler's socket to close).
  // Every socket has LINGER 0, so none of these closings can block.
  std::unique_ptr<farm::ZapAuthenticator> zap_;
  zmq::socket_t workers_, clients_;
  std::unique_ptr<TaskStore> store_;
  std::unique_ptr<SlurmPool> slurm_;  // after store_: its tables live in the same file
  JobFiles files_;
  std::map<std::string, Session> sessions_;  // by identity
  RefusalRows refusal_rows_;  // which refused reports get an events row (refusal_rows.h)
  std::chrono::milliseconds heartbeat_;
  // Per job and level: summed solve time and count of frames reported (for ETAs; approximate).
  std::map<std::pair<int64_t, int>, std::pair<double, int>> step_seconds_;
  // Per job: the hash of its scene source (farm::scene_source_hash), computed at its first dispatch
  // from the stored scene (a cache: rebuilt from SQLite after a restart).
  std::map<int64_t, std::string> scene_hashes_;
};

}  // namespace pd::scheduler
