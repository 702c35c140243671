// The simulated workers of pd_bench_farm_load: the protocol of pd-worker (worker/worker.cpp) without
// a solver. Each thread waits on its workers' DEALER sockets (2 ms turns), answers what arrived, sends
// the heartbeats that are due and as many frames as its share of --rate allows (a token bucket,
// round robin over the workers whose next frame is ready).
#include "farm_load_workers.h"

#include <sys/epoll.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>

#include <zmq_addon.hpp>

#include "farm/messaging.h"
#include "farm/scene_source.h"
#include "store/hierarchy_store.h"
#include "util/process_setup.h"

namespace pd::farm_load {

using protocol::Parts;

namespace {

bool try_send(zmq::socket_t& s, const Parts& parts) {
  std::vector<zmq::const_buffer> buffers;
  for (const std::string& p : parts) buffers.emplace_back(p.data(), p.size());
  return zmq::send_multipart(s, buffers, zmq::send_flags::dontwait).has_value();
}

std::optional<Parts> try_recv(zmq::socket_t& s) {
  std::vector<zmq::message_t> messages;
  if (!zmq::recv_multipart(s, std::back_inserter(messages), zmq::recv_flags::dontwait)) return std::nullopt;
  Parts parts;
  for (const zmq::message_t& m : messages) parts.push_back(m.to_string());
  return parts;
}

}  // namespace

Recording record(const Options& o) {
  Recording r;
  Scene scene;
  r.source = farm::read_scene_source(o.scene, &scene);
  if (o.levels > 0) scene.hierarchy.levels = o.levels;
  if (o.frames > 0) scene.frames = o.frames;
  // As the worker's hierarchy task does (worker/task_runner.cpp run_hierarchy): build into a frame
  // file and ship that file's bytes.
  const std::string path =
      (std::filesystem::temp_directory_path() / ("pd-farm-load-" + std::to_string(getpid()) + ".h5")).string();
  const SceneHierarchy h = load_or_build_hierarchy(scene, path);
  std::ifstream in(path, std::ios::binary);
  r.blob.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  std::filesystem::remove(path);
  r.hash = h.hash;
  r.frames = scene.frames;
  r.levels = h.num_levels();
  for (const SceneLevel& lv : h.levels) {
    r.vertices.push_back(lv.rest.num_vertices());
    r.rest.emplace_back(lv.rest.V.data(), lv.rest.V.data() + lv.rest.V.size());  // row-major: x0 y0 z0 x1 ...
  }
  return r;
}

// The simulated workers one thread serves.
class Shard {
 public:
  Shard(const Options& o, const Recording& rec, Shared& shared, int first, int count)
      : o_(o), rec_(rec), shared_(shared), ctx_(1), rate_(o.rate / o.threads) {
    heartbeat_ = std::chrono::milliseconds(o.heartbeat_ms);
    const auto now = Clock::now();
    for (int k = 0; k < count; ++k) {
      SimWorker w;
      w.index = static_cast<std::size_t>(k);
      w.name = "sim-" + std::to_string(first + k);
      w.socket = std::make_unique<zmq::socket_t>(ctx_, zmq::socket_type::dealer);
      farm::configure_socket(*w.socket);
      w.socket->connect(o.workers_endpoint);
      // Heartbeats spread over one period, as independent machines' would be.
      w.next_heartbeat = now + heartbeat_ * (k + 1) / (count + 1);
      w.last_heard = now;
      workers_.push_back(std::move(w));
    }
  }

  void run() {
    // epoll over the sockets' ZMQ_FD, not zmq::poll over every socket each turn (which costs about
    // 0.7 us per socket and turn: a third of a core for 500 sockets). ZMQ_FD only says "look at this
    // socket"; a send can consume that notice, so a socket sent on is also read at the turn's end,
    // and every socket is read every 50 ms whatever epoll says.
    const int ep = epoll_create1(EPOLL_CLOEXEC);
    if (ep < 0) throw std::runtime_error("epoll_create1 failed");
    for (std::size_t k = 0; k < workers_.size(); ++k) {
      epoll_event ev{};
      ev.events = EPOLLIN;
      ev.data.u64 = k;
      if (epoll_ctl(ep, EPOLL_CTL_ADD, workers_[k].socket->get(zmq::sockopt::fd), &ev) != 0)
        throw std::runtime_error("epoll_ctl failed for a worker socket");
    }
    for (SimWorker& w : workers_) hello(w);
    auto last = Clock::now(), next_sweep = last;
    double tokens = 0;
    std::vector<epoll_event> events(workers_.size());
    while (!shared_.stop) {
      const int n = epoll_wait(ep, events.data(), static_cast<int>(events.size()), 2);  // ms
      const auto now = Clock::now();
      for (int i = 0; i < n; ++i) receive(workers_[events[static_cast<std::size_t>(i)].data.u64], now);
      if (now >= next_sweep) {
        for (SimWorker& w : workers_) receive(w, now);
        next_sweep = now + std::chrono::milliseconds(50);
      }
      for (SimWorker& w : workers_) {
        flush_outbox(w);
        heartbeat_if_due(w, now);
      }
      tokens = std::min(tokens + rate_ * seconds_between(last, now), std::max(4.0, rate_ * 0.02));
      last = now;
      while (tokens >= 1 && send_one_frame(now)) tokens -= 1;
      std::vector<std::size_t> sent;
      sent.swap(sent_on_);
      for (std::size_t k : sent) workers_[k].sent = false, receive(workers_[k], now);
      const double turn_ms = seconds_between(now, Clock::now()) * 1e3;
      if (shared_.in_window(now)) tally_.max_turn_ms = std::max(tally_.max_turn_ms, turn_ms);
    }
    close(ep);
  }

  const Tally& tally() const { return tally_; }
  const std::vector<SimWorker>& workers() const { return workers_; }

 private:
  // Sends in order without blocking; the socket is read at the turn's end. A message that finds the
  // socket's queue full (the scheduler is far behind) waits in the worker's outbox, unless it is
  // `droppable` (a frame, made again later; a ping). True when it went out now.
  bool send(SimWorker& w, const Parts& parts, bool droppable = false) {
    if (!w.sent) sent_on_.push_back(w.index);
    w.sent = true;
    if (w.outbox.empty() && try_send(*w.socket, parts)) return true;
    ++tally_.send_blocked;
    if (!droppable) w.outbox.push_back(parts);
    return false;
  }

  void flush_outbox(SimWorker& w) {
    while (!w.outbox.empty() && try_send(*w.socket, w.outbox.front())) w.outbox.pop_front();
  }

  void hello(SimWorker& w) {
    protocol::Hello h;
    h.name = w.name;
    h.version = "farm-load";
    h.cores = 1;
    h.host = "localhost";
    h.blas_kernel = blas_kernel_in_use();  // as a real worker on this machine: no kernel warnings
    send(w, protocol::encode(h));
    w.hello_pending = true;
  }

  void heartbeat(SimWorker& w, int64_t ping, Clock::time_point now) {
    protocol::WorkerHeartbeat hb;
    hb.attempt = w.busy ? w.run.attempt : 0;
    hb.ping = ping;
    if (send(w, protocol::encode(hb), ping != 0) && ping != 0) w.pings.emplace_back(ping, now);
  }

  void heartbeat_if_due(SimWorker& w, Clock::time_point now) {
    if (!w.silent && now - w.last_heard > 3 * heartbeat_) {  // what a real worker calls a lost scheduler
      w.silent = true;
      ++tally_.scheduler_silences;
    }
    if (!w.welcomed || now < w.next_heartbeat) return;
    w.next_heartbeat += heartbeat_;
    if (w.next_heartbeat < now) w.next_heartbeat = now + heartbeat_;
    heartbeat(w, w.next_ping++, now);
  }

  void receive(SimWorker& w, Clock::time_point now) {
    for (int k = 0; k < 64; ++k) {
      std::optional<Parts> parts = try_recv(*w.socket);
      if (!parts) return;
      w.last_heard = now;
      w.silent = false;
      protocol::Command c;
      try {
        c = protocol::decode_command(*parts);
      } catch (const protocol::ProtocolError& e) {
        ++tally_.refused;  // counted as a refusal: the run is not clean
        ++tally_.refusals[std::string("load program: undecodable command: ") + e.what()];
        continue;
      }
      std::visit([&](auto& m) { on(w, m, now); }, c);
    }
  }

  void on(SimWorker& w, protocol::Welcome& m, Clock::time_point) {
    if (w.welcomed && !w.hello_pending) ++tally_.leases_lost;  // a Welcome it did not ask for
    if (!w.welcomed) ++shared_.welcomed;
    w.welcomed = true;
    w.hello_pending = false;
    w.id = m.worker;
    if (m.heartbeat_ms > 0) heartbeat_ = std::chrono::milliseconds(m.heartbeat_ms);
  }

  void on(SimWorker& w, protocol::AssignTask& m, Clock::time_point now) {
    if (w.busy) {  // the scheduler never does this to a worker that said it runs an attempt
      ++tally_.assigned_while_busy;
      return;
    }
    if (m.kind == protocol::TaskKind::hierarchy) {
      protocol::HierarchyDone d;
      d.attempt = m.attempt;
      d.task = m.task;
      d.hash = rec_.hash;
      d.levels = rec_.levels;
      d.vertices = rec_.vertices;
      d.blob = rec_.blob;
      send(w, protocol::encode(d));
      end_task(w, m.job, m.task, now);
      ++tally_.hierarchies_done;
      return;
    }
    set_busy(w, true);
    w.run = Attempt{};
    w.run.attempt = m.attempt;
    w.run.task = m.task;
    w.run.job = m.job;
    w.run.level = m.level;
    w.run.last = m.last;
    w.run.next = m.start == 0 ? 0 : m.start + 1;  // frame 0 too when the attempt starts there
    w.run.last_frame = now;
  }

  void on(SimWorker& w, protocol::BelowFrame& m, Clock::time_point) {
    if (w.busy && m.attempt == w.run.attempt) w.run.below.insert(m.frame);
  }

  // A simulated stitch steps on the level below alone: its guide frames only cost the transfer.
  void on(SimWorker&, protocol::GuideFrame&, Clock::time_point) {}

  void on(SimWorker& w, protocol::CancelTask& m, Clock::time_point now) {
    if (!w.busy || m.attempt != w.run.attempt) return;
    ++tally_.cancels;
    set_busy(w, false);
    heartbeat(w, 0, now);  // as a real worker does once its attempt ended: "I run nothing"
  }

  void on(SimWorker& w, protocol::SchedulerHeartbeat& m, Clock::time_point now) {
    if (m.pong == 0) return;
    while (!w.pings.empty() && w.pings.front().first < m.pong) w.pings.pop_front();  // answered before? never
    if (w.pings.empty() || w.pings.front().first != m.pong) return;
    const Clock::time_point sent = w.pings.front().second;
    const double rtt_ms = seconds_between(sent, now) * 1e3;
    shared_.rtt_smoothed_ms = 0.95 * shared_.rtt_smoothed_ms + 0.05 * rtt_ms;
    if (shared_.in_window(sent)) {
      tally_.rtt_ms.push_back(rtt_ms);
      tally_.rtt_at.push_back(static_cast<double>(Shared::ns(sent) - shared_.window_start) * 1e-9);
    }
    w.pings.pop_front();
  }

  void on(SimWorker& w, protocol::Refused& m, Clock::time_point) {
    ++tally_.refused;
    ++tally_.refusals[m.reason.substr(0, 80)];
    if (m.reason != protocol::kUnknownWorkerReason) return;
    ++tally_.leases_lost;  // the scheduler dropped this worker: start again, as pd-worker does
    set_busy(w, false);
    if (w.welcomed) --shared_.welcomed;
    w.welcomed = false;
    w.pings.clear();
    w.outbox.clear();  // reports of the session the scheduler dropped, as pd-worker drops them
    hello(w);
  }

  void end_task(SimWorker& w, int64_t job, int64_t task, Clock::time_point now) {
    shared_.task_done(job, task);
    set_busy(w, false);
    heartbeat(w, 0, now);  // pd-worker sends one when an attempt ends
  }

  void set_busy(SimWorker& w, bool busy) {
    if (w.busy != busy) shared_.busy += busy ? 1 : -1;
    w.busy = busy;
  }

  bool ready(const SimWorker& w, Clock::time_point now) const {
    if (!w.busy || now < w.blocked_until || !w.outbox.empty()) return false;
    // Step t -> t + 1 of level l >= 1 reads level l - 1's frame t (PD eq. 5).
    return w.run.level == 0 || w.run.next == 0 || w.run.below.count(w.run.next - 1) != 0;
  }

  // Sends one frame of the next ready worker (round robin); false when none is ready.
  bool send_one_frame(Clock::time_point now) {
    const std::size_t n = workers_.size();
    for (std::size_t k = 0; k < n; ++k) {
      cursor_ = (cursor_ + 1) % n;
      SimWorker& w = workers_[cursor_];
      if (!ready(w, now)) continue;
      protocol::FrameReport f;
      f.attempt = w.run.attempt;
      f.task = w.run.task;
      f.level = w.run.level;
      f.frame = w.run.next;
      f.positions = rec_.rest[static_cast<std::size_t>(w.run.level)];
      f.stats = {{"solve_seconds", seconds_between(w.run.last_frame, now)}};
      if (!send(w, protocol::encode(f), true)) {  // its queue is full: the scheduler is behind
        w.blocked_until = now + std::chrono::milliseconds(10);
        continue;
      }
      w.run.last_frame = now;
      ++tally_.frames_sent;
      if (shared_.in_window(now)) {
        ++tally_.frames_in_window;
        const auto second = static_cast<std::size_t>((Shared::ns(now) - shared_.window_start) / 1000000000);
        if (tally_.per_second.size() <= second) tally_.per_second.resize(second + 1, 0);
        ++tally_.per_second[second];
      }
      if (++w.run.next > w.run.last) {
        protocol::TaskDone d;
        d.attempt = w.run.attempt;
        d.task = w.run.task;
        send(w, protocol::encode(d));
        ++tally_.tasks_done;
        end_task(w, w.run.job, w.run.task, now);
      }
      return true;
    }
    return false;
  }

  const Options& o_;
  const Recording& rec_;
  Shared& shared_;
  zmq::context_t ctx_;
  double rate_;  // frames/s of this thread
  std::chrono::milliseconds heartbeat_;
  std::vector<SimWorker> workers_;
  std::size_t cursor_ = 0;
  std::vector<std::size_t> sent_on_;  // workers whose socket was sent on this turn
  Tally tally_;
};

ShardSet::ShardSet(const Options& o, const Recording& rec, Shared& shared) : shared_(shared) {
  for (int t = 0; t < o.threads; ++t) {
    const int first = o.workers * t / o.threads, end = o.workers * (t + 1) / o.threads;
    shards_.push_back(std::make_unique<Shard>(o, rec, shared, first, end - first));
  }
  errors_.resize(shards_.size());
  for (std::size_t k = 0; k < shards_.size(); ++k)
    threads_.emplace_back([this, k] {
      try {
        shards_[k]->run();
      } catch (const std::exception& e) {
        errors_[k] = e.what();
      }
    });
}

ShardSet::~ShardSet() { stop(); }

void ShardSet::stop() {
  shared_.stop = true;
  for (std::thread& t : threads_)
    if (t.joinable()) t.join();
}

Tally ShardSet::sum() const {
  Tally s;
  for (const auto& shard : shards_) {
    const Tally& t = shard->tally();
    for (int64_t Tally::*f : {&Tally::frames_sent, &Tally::frames_in_window, &Tally::tasks_done,
                              &Tally::hierarchies_done, &Tally::cancels, &Tally::leases_lost,
                              &Tally::scheduler_silences, &Tally::refused, &Tally::send_blocked,
                              &Tally::assigned_while_busy})
      s.*f += t.*f;
    for (const auto& [reason, n] : t.refusals) s.refusals[reason] += n;
    s.rtt_ms.insert(s.rtt_ms.end(), t.rtt_ms.begin(), t.rtt_ms.end());
    s.rtt_at.insert(s.rtt_at.end(), t.rtt_at.begin(), t.rtt_at.end());
    if (s.per_second.size() < t.per_second.size()) s.per_second.resize(t.per_second.size(), 0);
    for (std::size_t k = 0; k < t.per_second.size(); ++k) s.per_second[k] += t.per_second[k];
    s.max_turn_ms = std::max(s.max_turn_ms, t.max_turn_ms);
  }
  return s;
}

std::vector<const SimWorker*> ShardSet::workers() const {
  std::vector<const SimWorker*> out;
  for (const auto& shard : shards_)
    for (const SimWorker& w : shard->workers()) out.push_back(&w);
  return out;
}

std::string ShardSet::errors() const {
  std::string all;
  for (const std::string& e : errors_) all += e.empty() ? "" : (all.empty() ? "" : "; ") + e;
  return all;
}

}  // namespace pd::farm_load
