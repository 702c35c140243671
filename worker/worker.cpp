#include "worker/worker.h"

#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <optional>
#include <set>
#include <thread>

#include <zmq.hpp>

#include "farm/messaging.h"
#include "util/process_setup.h"
#include "worker/task_runner.h"

#ifndef PD_VERSION
#define PD_VERSION "unknown"
#endif

namespace pd::worker {

namespace {

using Clock = std::chrono::steady_clock;

void log_line(const WorkerOptions& o, const std::string& event, const std::string& detail) {
  std::fprintf(stderr, "pd-worker %s: %s%s%s\n", o.name.c_str(), event.c_str(), detail.empty() ? "" : ": ",
               detail.c_str());
}

std::string host_name() {
  char buf[256] = {};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

// One connection's life: from Hello until the scheduler is lost or the worker stops. Returns true
// when it ended because the scheduler went silent (reconnect), false when asked to stop.
class Session {
 public:
  // last_contact: when a message last came from the scheduler, updated by this session.
  Session(zmq::context_t& ctx, const WorkerOptions& o, TaskRunner& runner, int wake_fd, Clock::time_point& last_contact)
      : socket_(ctx, zmq::socket_type::dealer),
        options_(o),
        runner_(runner),
        wake_fd_(wake_fd),
        last_contact_(last_contact) {
    farm::configure_socket(socket_);
    if (o.curve) farm::apply_curve_client(socket_, *o.curve);
    // A refused handshake (this worker's key not authorized, or no CURVE here and CURVE there) ends
    // libzmq's session for good: the DEALER keeps no pipe and a send would block forever, out of
    // reach of the liveness check. Bounded, the send gives up, the scheduler counts as lost after
    // kLiveness heartbeats and the next session's fresh socket tries again (so the worker gets in
    // once a scheduler admits its key, e.g. restarted with the key listed).
    socket_.set(zmq::sockopt::sndtimeo, kLiveness * o.heartbeat_ms);
    socket_.connect(o.endpoint);
    protocol::Hello hello;
    hello.name = o.name;
    hello.version = PD_VERSION;
    hello.cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    hello.host = host_name();
    hello.slurm_job = o.slurm_job;
    hello.blas_kernel = blas_kernel_in_use();
    farm::send_parts(socket_, protocol::encode(hello));
    heartbeat_ = std::chrono::milliseconds(o.heartbeat_ms);
    last_heard_ = last_sent_ = Clock::now();
  }

  bool run(const std::atomic<bool>& stop) {
    while (!stop) {
      try {
        if (const std::optional<bool> ended = turn()) return *ended;
      } catch (const zmq::error_t& e) {
        // A signal interrupted a ZeroMQ call: the loop condition sees `stop`.
        if (e.num() != EINTR) throw;
      }
    }
    say_goodbye();
    return false;
  }

  bool welcomed() const { return welcomed_; }

 private:
  // One loop turn; a value when the session ends (true: reconnect).
  std::optional<bool> turn() {
    zmq::pollitem_t items[] = {{socket_.handle(), 0, ZMQ_POLLIN, 0}, {nullptr, wake_fd_, ZMQ_POLLIN, 0}};
    zmq::poll(items, 2, heartbeat_ / 4);
    if (items[1].revents & ZMQ_POLLIN) {
      uint64_t count;
      if (read(wake_fd_, &count, sizeof count) < 0) {
        // EAGAIN: another turn consumed the wake-up already
      }
    }
    if (items[0].revents & ZMQ_POLLIN) {
      std::optional<protocol::Parts> parts = farm::recv_parts(socket_);
      if (parts) handle(*parts);
    }
    flush_runner();
    const auto now = Clock::now();
    if (now - last_sent_ >= heartbeat_) send_heartbeat();
    if (unknown_) {
      if (runner_.busy()) runner_.cancel();
      return true;
    }
    if (now - last_heard_ > kLiveness * heartbeat_) {
      log_line(options_, "scheduler lost", "no message for " + std::to_string(kLiveness) + " heartbeats");
      if (runner_.busy()) runner_.cancel();
      return true;
    }
    return std::nullopt;
  }

  void send(const protocol::Parts& parts) {
    farm::send_parts(socket_, parts);
    last_sent_ = Clock::now();
  }

  // Asked to stop: the scheduler hears it now and gives the running attempt away at once. Best
  // effort (the send is bounded by sndtimeo; LINGER 0 drops what is still queued at close).
  void say_goodbye() {
    if (!welcomed_) return;
    protocol::Goodbye g;
    g.attempt = runner_.attempt();
    g.reason = "stopping on a signal" + std::string(g.attempt ? " during attempt " + std::to_string(g.attempt) : "");
    try {
      send(protocol::encode(g));
      // LINGER 0 would drop the message if the socket closed before libzmq wrote it: give the I/O
      // thread a moment (a local or LAN write takes well under this).
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    } catch (const zmq::error_t&) {
      // the scheduler is unreachable: it loses this worker by liveness instead
    }
  }

  void send_heartbeat() {
    protocol::WorkerHeartbeat hb;
    hb.attempt = runner_.attempt();
    send(protocol::encode(hb));
  }

  // Reports of the running attempt go out in the order they were made; a finished attempt's
  // thread is joined and an immediate heartbeat says the worker is free.
  void flush_runner() {
    for (const protocol::Parts& p : runner_.take_outbox()) send(p);
    const bool was_busy = running_attempt_ != 0;
    runner_.poll();
    if (was_busy && !runner_.busy()) {
      running_attempt_ = 0;
      for (const protocol::Parts& p : runner_.take_outbox()) send(p);
      send_heartbeat();
    }
  }

  void handle(const protocol::Parts& parts) {
    last_heard_ = last_contact_ = Clock::now();
    protocol::Command command;
    try {
      command = protocol::decode_command(parts);
    } catch (const protocol::ProtocolError& e) {
      log_line(options_, "refused a message", e.what());
      return;
    }
    std::visit([this](auto& m) { on(m); }, command);
  }

  void on(protocol::Welcome& m) {
    welcomed_ = true;
    worker_id_ = m.worker;
    if (m.heartbeat_ms > 0) heartbeat_ = std::chrono::milliseconds(m.heartbeat_ms);
    log_line(options_, "connected", options_.endpoint + " as worker " + std::to_string(m.worker) +
                                         " (OpenBLAS kernel " + blas_kernel_in_use() + ")");
  }
  void on(protocol::AssignTask& m) {
    if (runner_.busy()) {
      protocol::TaskFailed f;
      f.attempt = m.attempt;
      f.task = m.task;
      f.message = "worker " + options_.name + " is still running attempt " + std::to_string(runner_.attempt());
      send(protocol::encode(f));
      return;
    }
    log_line(options_, "task", std::to_string(m.task) + " attempt " + std::to_string(m.attempt) + " (" +
                                   (m.kind == protocol::TaskKind::hierarchy
                                        ? std::string("hierarchy")
                                        : "level " + std::to_string(m.level) + ", frames (" + std::to_string(m.first) +
                                              ", " + std::to_string(m.last) + "]") +
                                   ")");
    running_attempt_ = m.attempt;
    runner_.start(std::move(m));
  }
  void on(protocol::BelowFrame& m) { runner_.feed(m); }
  void on(protocol::GuideFrame& m) { runner_.feed(m); }
  void on(protocol::CancelTask& m) {
    if (m.attempt != runner_.attempt()) return;
    log_line(options_, "cancel", "attempt " + std::to_string(m.attempt) + ": " + m.reason);
    runner_.cancel();
  }
  void on(protocol::SchedulerHeartbeat&) {}
  void on(protocol::Refused& m) {
    log_line(options_, "scheduler refused a report", m.reason);
    // The scheduler does not know this worker (it restarted, or gave it up as lost): start again.
    if (m.reason == protocol::kUnknownWorkerReason) unknown_ = true;
  }

  zmq::socket_t socket_;
  const WorkerOptions& options_;
  TaskRunner& runner_;
  int wake_fd_;
  Clock::time_point& last_contact_;
  std::chrono::milliseconds heartbeat_;
  Clock::time_point last_heard_, last_sent_;
  bool welcomed_ = false;
  bool unknown_ = false;  // the scheduler said it has no session for this worker
  int64_t worker_id_ = 0, running_attempt_ = 0;
};

// Sleeps up to `d`, waking early when asked to stop.
void sleep_unless_stopped(std::chrono::milliseconds d, const std::atomic<bool>& stop) {
  const auto end = Clock::now() + d;
  while (!stop && Clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(50));
}

}  // namespace

int run_worker(const WorkerOptions& options, const std::atomic<bool>& stop) {
  const int wake_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd < 0) {
    std::perror("pd-worker: eventfd");
    return 1;
  }
  zmq::context_t ctx(1);
  HierarchyCache cache;
  auto backoff = kMinBackoff;
  int code = 0;
  Clock::time_point last_contact = Clock::now();
  const auto timeout = std::chrono::duration_cast<std::chrono::milliseconds>(
      std::chrono::duration<double>(options.scheduler_timeout_s));
  {
    TaskRunner runner(wake_fd, options.scratch_dir, cache, options.fail_level, options.refuse_vertical_starts,
                      options.refuse_vertical_starts_before, options.max_memory_bytes);
    while (!stop) {
      bool reconnect;
      bool welcomed;
      {
        Session session(ctx, options, runner, wake_fd, last_contact);
        reconnect = session.run(stop);
        welcomed = session.welcomed();
      }
      if (!reconnect) break;
      // The lost attempt was cancelled; its thread ends at its next frame or input wait.
      while (runner.busy() && !stop) {
        runner.poll();
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
      runner.take_outbox();  // reports of an attempt the scheduler has given away
      if (welcomed) backoff = kMinBackoff;  // a session that got through starts the backoff anew
      const auto silent = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - last_contact);
      if (timeout.count() > 0 && silent >= timeout) {
        log_line(options, "exiting", "nothing from the scheduler for " + std::to_string(silent.count() / 1000) +
                                         " s (--scheduler-timeout " + std::to_string(timeout.count() / 1000) + ")");
        code = kSchedulerGoneExit;
        break;
      }
      // The wait never runs past the moment the timeout is reached, so that the exit is on time.
      const auto wait = timeout.count() > 0 ? std::min(backoff, timeout - silent) : backoff;
      log_line(options, "reconnecting", "in " + std::to_string(wait.count()) + " ms");
      sleep_unless_stopped(wait, stop);
      backoff = std::min(backoff * 2, kMaxBackoff);
    }
  }
  close(wake_fd);
  return code;
}

}  // namespace pd::worker
