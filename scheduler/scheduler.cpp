#include "scheduler/scheduler.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <ctime>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "farm/messaging.h"
#include "farm/scene_source.h"
#include "farm/task_graph.h"
#include "scheduler/security.h"

namespace pd::scheduler {

namespace {

std::vector<double> as_vector(const Positions& x) { return std::vector<double>(x.data(), x.data() + x.size()); }

// A scene source's size as sent (its text and files), bytes: the log says what a first assignment carried.
std::size_t scene_bytes(const protocol::SceneSource& s) {
  std::size_t n = s.text.size();
  for (const protocol::SceneFile& f : s.files) n += f.content.size();
  return n;
}


}  // namespace

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

NewTask as_new_task(const TaskRow& t) {
  NewTask n;
  n.kind = t.kind;
  n.level = t.level;
  n.first = t.first;
  n.last = t.last;
  n.stitch = t.stitch;
  n.guides = t.guides;
  return n;
}

Scheduler::Scheduler(const SchedulerOptions& options)
    : options_(options),
      ctx_(1),
      workers_(ctx_, zmq::socket_type::router),
      clients_(ctx_, zmq::socket_type::router),
      // Hierarchy files come from workers: HDF5 reads them first in a child, where a crafted file can
      // crash it (fuzz/known_hdf5_bugs) without taking the farm down.
      files_(options.dir + "/jobs", "/proc/self/exe"),
      heartbeat_(options.heartbeat_ms) {
  std::filesystem::create_directories(options.dir);
  store_ = std::make_unique<TaskStore>(options.dir + "/farm.sqlite");
  for (zmq::socket_t* s : {&workers_, &clients_}) {
    farm::configure_socket(*s);
    // A reply to a peer that is gone fails loudly (EHOSTUNREACH) instead of vanishing.
    s->set(zmq::sockopt::router_mandatory, 1);
  }
  // Replies waiting for a client to read them: a pd client sends one request and reads its reply
  // before the next, so 16 leave room for a script pipelining a few (libzmq sees the client's reads
  // only every 8 messages: more than 8 unread replies may already be refused); the rest are dropped
  // (reply_failed). With libzmq's default of 1 000 a client pipelining 849 fetches without reading
  // held 378 MB of replies here. In bytes this bounds fetches only by the job file's size (a fetch
  // reply is the whole file).
  clients_.set(zmq::sockopt::sndhwm, kClientReplyQueue);
  // CURVE and the ZAP handler before binding, or refusal of a non-loopback endpoint without keys.
  zap_ = secure_sockets(ctx_, options_, {&workers_, &clients_});
  workers_.bind(options.workers_endpoint);
  clients_.bind(options.clients_endpoint);
  // Slurm workers connect to the endpoint as bound (port 0 resolved) unless told another address.
  if (options_.slurm.connect.empty()) options_.slurm.connect = workers_endpoint();
  slurm_ = std::make_unique<SlurmPool>(options_.slurm, options.dir + "/farm.sqlite",
                                       [this](const std::string& kind, const std::string& message) {
                                         event(kind, 0, 0, 0, message);
                                       });
  recover();
}

// A scheduler starting on a directory an earlier one used (it was stopped, or killed): attempts that
// were running end (their workers say hello again and their tasks continue from their stored
// frames), and every job file is rebuilt from the store, which holds every stored frame's data: a
// file the earlier process left half-written is replaced whole.
void Scheduler::recover() {
  for (const TaskRow& t : store_->recover_after_restart())
    event("task_released", t.job, t.id, 0, "attempt " + std::to_string(t.attempt) + " ended with the earlier scheduler");
  for (const JobRow& job : store_->jobs())
    if (!job.hierarchy_hash.empty() && rebuild_job_file(job)) add_pending_refinement(job);
}

bool Scheduler::rebuild_job_file(const JobRow& job) {
  const auto start = Clock::now();
  try {
    const std::vector<FrameKey> keys = store_->frame_keys(job.id);
    files_.create(job.id, job.spec.scene.text, job.spec.frames, job.spec.levels, job.hierarchy_hash,
                  store_->hierarchy_blob(job.id), keys.size(),
                  [&](std::size_t i) { return StoredFrame{keys[i], *store_->frame_data(job.id, keys[i])}; });
    event("job_file_rebuilt", job.id, 0, 0,
          std::to_string(keys.size()) + " frames from the store in " +
              std::to_string(std::chrono::duration<double>(Clock::now() - start).count()) + " s");
    return true;
  } catch (const std::exception& e) {
    event("job_file_error", job.id, 0, 0, e.what());
    if (job.state == protocol::JobState::queued || job.state == protocol::JobState::running) {
      store_->set_job_state(job.id, protocol::JobState::failed, std::string("the job file cannot be rebuilt: ") + e.what());
      cancel_attempts_of_job(job.id, "job failed");
    }
    return false;
  }
}

Scheduler::~Scheduler() { files_.close_all(); }

std::string Scheduler::workers_endpoint() const { return farm::last_endpoint(workers_); }
std::string Scheduler::clients_endpoint() const { return farm::last_endpoint(clients_); }

void Scheduler::event(const std::string& kind, int64_t job, int64_t task, int64_t worker, const std::string& message,
                      bool persist) {
  nlohmann::json line = {{"time", unix_now()}, {"event", kind}};
  if (job) line["job"] = job;
  if (task) line["task"] = task;
  if (worker) line["worker"] = worker;
  if (!message.empty()) line["message"] = message;
  // replace: a message quoting a peer's bytes must not make the log line fail (invalid UTF-8 would throw).
  std::fprintf(stderr, "%s\n", line.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
  if (persist) store_->log_event(job, task, worker, kind, message);
}

void Scheduler::run(const std::atomic<bool>& stop, std::atomic<bool>* reload) {
  while (!stop) {
    if (reload && reload->exchange(false)) reload_keys();
    try {
      turn();
    } catch (const zmq::error_t& e) {
      // A signal interrupted a ZeroMQ call (poll, a socket option, a receive): the loop condition
      // sees `stop`. Anything else is a real failure.
      if (e.num() != EINTR) throw;
    }
  }
}

void Scheduler::reload_keys() {
  if (!zap_) {
    event("keys_reload_ignored", 0, 0, 0, "no --authorized-keys: this scheduler admits loopback peers without keys");
    return;
  }
  try {
    const std::vector<std::string> keys = farm::read_authorized_keys(options_.authorized_keys_file);
    zap_->set_authorized(keys);
    event("keys_reloaded", 0, 0, 0,
          options_.authorized_keys_file + ": " + std::to_string(keys.size()) +
              " key(s) admitted from now on (connected peers keep their sessions)");
  } catch (const std::exception& e) {
    event("keys_reload_failed", 0, 0, 0, std::string(e.what()) + "; the keys in use are kept");
  }
}

void Scheduler::turn() {
  zmq::pollitem_t items[] = {{workers_.handle(), 0, ZMQ_POLLIN, 0}, {clients_.handle(), 0, ZMQ_POLLIN, 0}};
  zmq::poll(items, 2, heartbeat_ / 4);
  // Drain what is queued on each socket, a bounded number per turn so neither side starves.
  for (int k = 0; k < 256 && (items[0].revents & ZMQ_POLLIN); ++k) {
    if (!(workers_.get(zmq::sockopt::events) & ZMQ_POLLIN)) break;
    std::optional<farm::Routed> m = farm::recv_routed(workers_);
    if (m) on_worker_message(m->identity, m->parts);
  }
  for (int k = 0; k < 64 && (items[1].revents & ZMQ_POLLIN); ++k) {
    if (!(clients_.get(zmq::sockopt::events) & ZMQ_POLLIN)) break;
    std::optional<farm::Routed> m = farm::recv_routed(clients_);
    if (m) on_client_message(m->identity, m->parts);
  }
  dispatch();
  preempt_starved();
  heartbeats_and_liveness();
  slurm_->tick(
      unix_now(),
      [this] {
        for (const JobRow& j : store_->jobs())
          if (j.state == protocol::JobState::queued || j.state == protocol::JobState::running) return true;
        return false;
      },
      [this](const std::string& name) { return worker_busy(name); });
}

bool Scheduler::worker_busy(const std::string& name) const {
  for (const auto& [identity, s] : sessions_)
    if (s.name == name) return s.attempt != 0;
  return false;
}

bool Scheduler::send_worker(const std::string& identity, const protocol::Parts& parts) {
  auto it = sessions_.find(identity);
  try {
    if (!farm::send_parts_to(workers_, identity, parts)) {
      // Its queue is full: the message is dropped and the caller told. That is our own backlog, not
      // the peer's silence: liveness is judged only by what the peer sends (a worker that stopped
      // reading has stopped heartbeating too, and is lost by the liveness check). Frames of the level
      // below are flow-controlled (kFeedWindow) and sent again from top_up_feed.
      event("send_failed", 0, 0, it == sessions_.end() ? 0 : it->second.worker, "queue full, message dropped", false);
      return false;
    }
    if (it != sessions_.end()) it->second.last_sent = Clock::now();
    return true;
  } catch (const zmq::error_t& e) {
    // EHOSTUNREACH: the peer is gone; its session is dropped at the next liveness check.
    event("send_failed", 0, 0, it == sessions_.end() ? 0 : it->second.worker, e.what(), false);
    return false;
  }
}

void Scheduler::dispatch() {
  if (!store_->has_ready_task()) return;
  for (auto& [identity, s] : sessions_) {
    if (s.attempt != 0 || s.draining) continue;
    if (!s.slurm_job.empty() && slurm_->draining(s.name)) continue;  // pd workers remove: no new task
    // Claims are per worker (a task is not given to a worker that failed it, nor a job's tasks to a
    // worker blocklisted for it): nothing for this one may still leave something for the next.
    std::optional<Claim> claim = store_->claim_next(s.worker);
    if (!claim) continue;
    if (!assign(identity, s, *claim)) continue;
  }
}

bool Scheduler::assign(const std::string& identity, Session& s, const Claim& claim) {
  const TaskRow& t = claim.task;
  const JobRow job = store_->job(t.job);
  protocol::AssignTask a;
  a.attempt = claim.attempt;
  a.task = t.id;
  a.job = t.job;
  a.kind = t.kind;
  a.level = t.level;
  a.first = t.first;
  a.last = t.last;
  a.start = t.first;
  a.frames = job.spec.frames;
  a.levels = job.spec.levels;
  a.hessian = job.spec.hessian;
  auto hash = scene_hashes_.find(job.id);
  if (hash == scene_hashes_.end()) hash = scene_hashes_.emplace(job.id, farm::scene_source_hash(job.spec.scene)).first;
  a.scene_hash = hash->second;
  if (!s.scenes.count(a.scene_hash)) a.scene = job.spec.scene;
  if (t.kind == protocol::TaskKind::level) {
    JobFile* f = files_.find(t.job);
    if (!f) {  // cannot happen: level tasks wait for the hierarchy task
      store_->release_task(t.id, "no job file");
      event("dispatch_error", t.job, t.id, s.worker, "level task ready before the job file exists");
      return false;
    }
    a.hierarchy_hash = f->hierarchy_hash;
    if (!s.hierarchies.count(f->hierarchy_hash)) a.hierarchy_blob = f->hierarchy_blob;
    a.start = continuation_start(t);
    if (a.start >= t.last) {  // every frame is stored: the attempt that solved them died before saying done
      store_->finish_task(t.id);
      event("task_done", t.job, t.id, s.worker, "every frame was stored already");
      if (t.level == 0) add_pending_refinement(store_->job(t.job));
      return false;
    }
    // Continuing horizontally from its own frames start-1 and start (and their barrier stiffness):
    // the preview after its first chunk, a subset whose vertical start was refused, and any task
    // whose earlier attempt stored some frames.
    if (a.start > t.first || (t.first > 0 && (t.level == 0 || store_->continues_horizontally(t.id)))) {
      a.own_before = as_vector(f->writer->read_frame(t.level, a.start - 1));
      a.own_start = as_vector(f->writer->read_frame(t.level, a.start));
      a.own_kappa = store_->frame_kappa(t.job, {t.level, a.start});
    }
    // A stitch task: its guide frames follow as GuideFrame messages as the later subset stores them
    // (top_up_feed, feed_guide_frame), so it runs one step behind the later subset instead of after it.
    a.stitch = t.stitch;
  }
  send_worker(identity, protocol::encode(a));
  if (a.hierarchy_blob) s.hierarchies.insert(a.hierarchy_hash);
  s.scenes.insert(a.scene_hash);
  s.attempt = claim.attempt;
  s.task = t.id;
  s.job = t.job;
  s.fed.clear();
  s.fed_guides.clear();
  s.progress = a.start;
  event("task_assigned", t.job, t.id, s.worker,
        "attempt " + std::to_string(claim.attempt) + ": " +
            (t.kind == protocol::TaskKind::hierarchy ? std::string("hierarchy")
                                                     : "level " + std::to_string(t.level) + (t.stitch ? " stitch" : "")) +
            " frames (" + std::to_string(t.first) + ", " + std::to_string(t.last) + "] to " +
            s.name + (a.start > t.first ? ", continuing from frame " + std::to_string(a.start) : "") +
            (a.scene ? ", with the scene (" + std::to_string(scene_bytes(*a.scene)) + " bytes)" : ""));
  top_up_feed(identity, s);
  return true;
}

// Where a new attempt of a level task starts: from the last of the task's frames stored without a gap
// (as the task solved them, so it repeats the uninterrupted run bit for bit), when that frame and the
// one before it are both the task's own or its predecessor's; else from the task's first frame. A
// task that starts vertically (level >= 1, first > 0) begins from an upsampled frame `first` that is
// not stored, so it continues only from first + 2 on.
int Scheduler::continuation_start(const TaskRow& t) const {
  const std::optional<farm::FrameRange> own = farm::produced_frames(as_new_task(t));
  if (!own) return t.first;
  int last_stored = -1;
  for (int frame : store_->stored_frames(t.job, own->level, own->first, own->last)) {
    if (frame != (last_stored < 0 ? own->first : last_stored + 1)) break;
    last_stored = frame;
  }
  const bool vertical = t.level >= 1 && t.first > 0 && !store_->continues_horizontally(t.id);
  const int earliest = (vertical ? t.first + 2 : t.first + 1) + t.guides;  // own frames are after the guides
  return last_stored >= earliest ? last_stored : t.first;
}

void Scheduler::attempt_failed(Session& s, const TaskRow& t, const std::string& message) {
  const int64_t attempt = s.attempt;
  end_attempt_of(s);
  const FailOutcome o = store_->fail_attempt(t.id, attempt, message);
  event("attempt_failed", t.job, t.id, s.worker, "attempt " + std::to_string(attempt) + " on " + s.name + ": " + message);
  if (o.worker_blocklisted)
    event("worker_blocklisted", t.job, 0, s.worker,
          s.name + " failed " + std::to_string(kBlocklistFailures) + " tasks of the job and takes none of its tasks");
  if (!o.task_failed) {
    // Retried on another worker; when no connected worker may take it, it fails now instead of
    // waiting for a worker that may never come (OpenCue #1081's dependents waited for ever).
    for (const auto& [identity, other] : sessions_)
      if (store_->may_run(t.id, other.worker)) {
        event("task_retry", t.job, t.id, 0, "failed on " + std::to_string(o.workers_failed) + " worker(s)");
        return;
      }
    store_->fail_task(t.id, message + " (failed on " + std::to_string(o.workers_failed) +
                                " worker(s); no other connected worker may run it)");
  }
  event("task_failed", t.job, t.id, s.worker, message);
  event("job_failed", t.job, 0, 0, store_->job(t.job).reason);
  cancel_attempts_of_job(t.job, "job failed");
}

void Scheduler::top_up_feed(const std::string& identity, Session& s) {
  if (s.attempt == 0 || s.draining) return;
  const TaskRow task = store_->task(s.task);
  if (task.kind != protocol::TaskKind::level || task.level < 1) return;
  JobFile* f = files_.find(task.job);
  if (!f) return;
  // Step progress -> progress + 1 reads frames progress - 1 and progress of the level below, and
  // nothing before them is asked for again: a continuation from frame 10 000 is not sent frames 0..9 998.
  if (const std::optional<farm::FrameRange> range = farm::fed_frames(as_new_task(task))) {
    const int first = std::max(range->first, s.progress - 1);
    const int last = std::min(range->last, s.progress + kFeedWindow);
    if (!(last < first || std::distance(s.fed.lower_bound(first), s.fed.end()) == last - first + 1)) {
      for (int t : store_->stored_frames(task.job, range->level, first, last)) {
        if (s.fed.count(t)) continue;
        protocol::BelowFrame b;
        b.attempt = s.attempt;
        b.task = task.id;
        b.level = range->level;
        b.frame = t;
        b.positions = as_vector(f->writer->read_frame(range->level, t));
        if (!send_worker(identity, protocol::encode(b))) return;  // the rest on the next top-up, in order
        s.fed.insert(t);
      }
    }
  }
  if (!task.stitch) return;
  // A stitch's step progress -> progress + 1 is guided toward guide frame progress + 1.
  const int first = std::max(task.first + 1, s.progress + 1);
  const int last = std::min(task.last, s.progress + kFeedWindow);
  if (last < first || std::distance(s.fed_guides.lower_bound(first), s.fed_guides.end()) == last - first + 1)
    return;  // every guide frame of the window was sent already: no store query on each report
  for (int g : store_->stored_guide_frames(task.job, task.level, first, last)) {
    if (s.fed_guides.count(g)) continue;
    std::optional<std::vector<double>> positions = store_->guide_frame(task.job, {task.level, g});
    if (!positions) return;  // cannot happen: just listed
    const protocol::GuideFrame m{s.attempt, task.id, task.level, g, std::move(*positions)};
    if (!send_worker(identity, protocol::encode(m))) return;  // the rest on the next top-up, in order
    s.fed_guides.insert(g);
  }
}

// A frame of (job, level) was stored: every running attempt of the job one level up that will ask
// for it gets it now when it is within the attempt's window (kFeedWindow), later from top_up_feed.
void Scheduler::feed_new_frame(int64_t job, int level, int frame) {
  JobFile* f = files_.find(job);
  protocol::BelowFrame b;
  for (auto& [identity, s] : sessions_) {
    if (s.attempt == 0 || s.job != job || s.draining || s.fed.count(frame)) continue;
    const TaskRow t = store_->task(s.task);
    if (t.kind != protocol::TaskKind::level || t.level != level + 1) continue;
    const std::optional<farm::FrameRange> range = farm::fed_frames(as_new_task(t));
    if (!range || frame < range->first || frame > range->last) continue;
    if (frame > s.progress + kFeedWindow) continue;  // outside its window: top_up_feed sends it later
    if (b.positions.empty()) b.positions = as_vector(f->writer->read_frame(level, frame));
    b.attempt = s.attempt;
    b.task = t.id;
    b.level = level;
    b.frame = frame;
    if (send_worker(identity, protocol::encode(b))) s.fed.insert(frame);
  }
}

// A guide frame of (job, level) was stored: the running stitch of the same level whose frames hold
// it gets it now when it is within its window (kFeedWindow), later from top_up_feed.
void Scheduler::feed_guide_frame(int64_t job, int level, int frame, const std::vector<double>& positions) {
  for (auto& [identity, s] : sessions_) {
    if (s.attempt == 0 || s.job != job || s.draining || s.fed_guides.count(frame)) continue;
    const TaskRow t = store_->task(s.task);
    if (!t.stitch || t.level != level || frame <= t.first || frame > t.last) continue;
    if (frame > s.progress + kFeedWindow) continue;
    if (send_worker(identity, protocol::encode(protocol::GuideFrame{s.attempt, t.id, level, frame, positions})))
      s.fed_guides.insert(frame);
  }
}

// A refinement task holds its worker while it waits for frames of the level below (a stitch also for
// its guide frames). When every worker is held and the task that would produce the awaited frame is
// ready but has no worker (its own worker was lost, say), nothing can move: the waiting attempt is
// taken back (cancelled, its task ready again) so that its worker takes the producer. The taken-back task later starts
// again from its first frame and gives the same frames (the solve is deterministic).
void Scheduler::preempt_starved() {
  for (const auto& [identity, s] : sessions_)
    if (s.attempt == 0 && !s.draining) return;  // a free worker: dispatch serves what is ready
  for (auto& [identity, s] : sessions_) {
    if (s.attempt == 0 || s.draining) continue;
    const TaskRow t = store_->task(s.task);
    if (t.kind != protocol::TaskKind::level || t.level == 0) continue;
    // Step progress -> progress + 1 needs frame `progress` of the level below (PD eq. 5); a stitch's
    // step needs guide frame progress + 1 as well.
    FrameKey need{t.level - 1, s.progress};
    bool guide = false;
    if (store_->frame_stored(t.job, need)) {
      if (!t.stitch || s.progress + 1 > t.last) continue;
      need = FrameKey{t.level, s.progress + 1};
      guide = true;
      if (!store_->stored_guide_frames(t.job, need.level, need.frame, need.frame).empty()) continue;
    }
    bool producer_waits = false;
    for (const TaskRow& p : store_->tasks(t.job)) {
      // The task that stores the frame (a later subset's guide frames are not the job's: a seam's
      // stitch task stores those frames of the level, task_graph.h; the later subset stores them
      // as guide frames).
      const std::optional<farm::FrameRange> own =
          guide ? farm::guide_frames(as_new_task(p)) : farm::produced_frames(as_new_task(p));
      if (own && own->level == need.level && own->first <= need.frame && need.frame <= own->last)
        producer_waits = p.state == protocol::TaskState::ready;
    }
    if (!producer_waits) continue;
    protocol::CancelTask c;
    c.attempt = s.attempt;
    c.task = s.task;
    c.reason = "preempted: the frames it waits for come from a task that has no worker";
    send_worker(identity, protocol::encode(c));
    store_->release_task(s.task, "preempted");
    event("task_preempted", t.job, t.id, s.worker,
          "attempt " + std::to_string(s.attempt) + " waited for level " + std::to_string(need.level) +
              (guide ? " guide frame " : " frame ") + std::to_string(need.frame));
    s.draining = true;
    return;  // one per turn: the freed worker may be all it takes
  }
}

void Scheduler::heartbeats_and_liveness() {
  for (const RefusalRows::Counted& c : refusal_rows_.closed(unix_now())) {
    const auto it = sessions_.find(c.identity);
    event("report_refused_counted", 0, 0, it == sessions_.end() ? 0 : it->second.worker,
          std::to_string(c.refusals) + " more refused reports " +
              (c.identity == RefusalRows::kOtherPeers ? std::string("of peers beyond the ") +
                                                            std::to_string(RefusalRows::kMaxPeers) + " tracked"
                                                      : std::string("of one peer")) +
              " within " + std::to_string(int(RefusalRows::kWindowSeconds)) +
              " s were logged but not stored (the first " + std::to_string(RefusalRows::kRowsPerPeer) + " were)");
  }
  const auto now = Clock::now();
  std::vector<std::string> lost;
  for (auto& [identity, s] : sessions_) {
    if (now - s.last_heard > kLiveness * heartbeat_) {
      lost.push_back(identity);
      continue;
    }
    if (now - s.last_sent >= heartbeat_) send_worker(identity, protocol::encode(protocol::SchedulerHeartbeat{}));
  }
  for (const std::string& identity : lost)
    lose(identity, "no message for " + std::to_string(kLiveness) + " heartbeats");
}

void Scheduler::lose(const std::string& identity, const std::string& why) {
  auto it = sessions_.find(identity);
  if (it == sessions_.end()) return;
  Session& s = it->second;
  event("worker_lost", s.job, s.task, s.worker, s.name + ": " + why);
  if (s.attempt != 0 && !s.draining) {
    const TaskRow t = store_->task(s.task);
    if (t.state == protocol::TaskState::running && t.attempt == s.attempt) {
      store_->release_task(s.task, "lost");
      event("task_released", s.job, s.task, s.worker, "attempt " + std::to_string(s.attempt) + " lost with its worker");
    }
  }
  store_->set_worker_state(s.worker, "lost");
  if (!s.slurm_job.empty()) slurm_->worker_lost(s.name, unix_now());
  sessions_.erase(it);
}

void Scheduler::end_attempt_of(Session& s) {
  s.attempt = s.task = s.job = 0;
  s.fed.clear();
  s.fed_guides.clear();
  if (!s.slurm_job.empty()) slurm_->cancel_drained(s.name, unix_now());  // pd workers remove waited for it
}

void Scheduler::cancel_attempts_of_job(int64_t job, const std::string& reason) {
  for (auto& [identity, s] : sessions_) {
    if (s.job != job || s.attempt == 0 || s.draining) continue;
    protocol::CancelTask c;
    c.attempt = s.attempt;
    c.task = s.task;
    c.reason = reason;
    send_worker(identity, protocol::encode(c));
    event("task_cancel_sent", job, s.task, s.worker, "attempt " + std::to_string(s.attempt) + ": " + reason);
    s.draining = true;
  }
}

}  // namespace pd::scheduler
