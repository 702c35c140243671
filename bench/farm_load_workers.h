#pragma once
// The simulated workers of pd_bench_farm_load (bench/farm_load.cpp describes the program): what
// they send, the state the serving threads share with the main thread, and the threads themselves.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <deque>
#include <string>
#include <thread>
#include <vector>

#include <zmq.hpp>

#include "protocol/protocol.h"

namespace pd::farm_load {

using Clock = std::chrono::steady_clock;

inline double seconds_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

struct Options {
  std::string workers_endpoint, clients_endpoint;
  std::string scene = std::string(PD_SOURCE_DIR) + "/scenes/slope-friction.json";
  int workers = 500;
  int threads = 1;        // threads serving the simulated workers
  double seconds = 60;    // measured window
  double warmup = 15;     // s from the first submission to the window (jobs ramp up at submit_rate)
  double rate = 2000;     // frames/s, all workers together
  int heartbeat_ms = 1000;  // until the Welcome gives the scheduler's
  int frames = 0, levels = 0, subsets = 1, preview_chunk = 5;  // per job; 0 = the scene's
  bool preview_only = false;
  double submit_rate = 5;  // jobs/s at most
  int jobs = 0;           // unfinished jobs kept; 0: enough tasks for every worker, adapted
  double drain_seconds = 300;  // bound on the wait for the submitted jobs after the window
  int scheduler_pid = 0;
  std::string scheduler_log;
  std::string rtt_csv;  // every round trip of the window: "seconds,rtt_ms" lines
};

// What every simulated worker sends, built once: the hierarchy task's result and each level's rest
// positions (the recorded frame of that level).
struct Recording {
  protocol::SceneSource source;
  std::string hash, blob;
  std::vector<int> vertices;
  std::vector<std::vector<double>> rest;  // per level, 3 n_l doubles, metres
  int frames = 0, levels = 0;
};

// Reads the scene and builds its hierarchy once (levels and frames as the options override them).
Recording record(const Options& o);

// Shared by the serving threads and the main thread: the run's phases and which tasks were done.
struct Shared {
  std::atomic<bool> stop{false};
  std::atomic<int64_t> window_start{0}, window_end{0};  // steady clock, ns since its epoch; 0 = not yet
  std::atomic<int> welcomed{0}, busy{0};  // simulated workers with a session, and running an attempt
  // Heartbeat round trip, ms, smoothed over about 20 pings (any thread may store; a lost update is harmless).
  std::atomic<double> rtt_smoothed_ms{0};
  std::mutex mutex;
  std::map<int64_t, std::set<int64_t>> done_tasks;  // job -> tasks done by a simulated worker

  static int64_t ns(Clock::time_point t) { return t.time_since_epoch().count(); }
  bool in_window(Clock::time_point t) const {
    const int64_t s = window_start, e = window_end, n = ns(t);
    return s != 0 && n >= s && (e == 0 || n < e);
  }
  void task_done(int64_t job, int64_t task) {
    std::lock_guard<std::mutex> lock(mutex);
    done_tasks[job].insert(task);
  }
  std::size_t tasks_done_of(int64_t job) {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = done_tasks.find(job);
    return it == done_tasks.end() ? 0 : it->second.size();
  }
};

// A thread's figures; summed at the end.
struct Tally {
  int64_t frames_sent = 0, frames_in_window = 0, tasks_done = 0, hierarchies_done = 0, cancels = 0;
  int64_t leases_lost = 0, scheduler_silences = 0, refused = 0, send_blocked = 0, assigned_while_busy = 0;
  std::map<std::string, int64_t> refusals;  // reason (first 80 characters) -> count
  std::vector<double> rtt_ms;                // pings sent in the window
  std::vector<double> rtt_at;                // when each was sent, s since the window's start
  std::vector<int64_t> per_second;           // frames sent in each second of the window
  double max_turn_ms = 0;                    // longest loop turn of the thread in the window
};

struct Attempt {
  int64_t attempt = 0, task = 0, job = 0;
  int level = 0, last = 0, next = 0;  // next: the next frame to send
  std::set<int> below;                // frames of level - 1 received
  Clock::time_point last_frame;
};

struct SimWorker {
  std::size_t index = 0;  // in its thread's list
  std::unique_ptr<zmq::socket_t> socket;
  std::string name;
  int64_t id = 0;
  bool welcomed = false, hello_pending = false, busy = false, silent = false;
  bool sent = false;  // sent on during this turn (read again at its end)
  Attempt run;
  int64_t next_ping = 1;
  std::deque<std::pair<int64_t, Clock::time_point>> pings;
  std::deque<protocol::Parts> outbox;  // messages waiting for room in the socket's queue, in order
  Clock::time_point next_heartbeat, last_heard, blocked_until;
};

class Shard;

// The threads serving the simulated workers (o.threads of them, the workers shared out evenly);
// stopped and joined by stop() or the destructor (also on an exception).
class ShardSet {
 public:
  ShardSet(const Options& o, const Recording& rec, Shared& shared);
  ~ShardSet();
  void stop();
  // After stop(): the threads' figures summed, every simulated worker, and what ended a thread early.
  Tally sum() const;
  std::vector<const SimWorker*> workers() const;
  std::string errors() const;

 private:
  Shared& shared_;
  std::vector<std::unique_ptr<Shard>> shards_;
  std::vector<std::string> errors_;
  std::vector<std::thread> threads_;
};

}  // namespace pd::farm_load
