#pragma once
// pd-worker's connection to the scheduler (zguide's Paranoid Pirate worker): a DEALER that says
// Hello, gets Welcome, runs one task at a time on a TaskRunner, and streams the runner's reports.
// Heartbeats both ways every heartbeat period; when nothing has come from the scheduler for
// kLiveness periods the worker drops the socket (and any attempt it was running: the scheduler has
// given it away by then) and reconnects after a backoff that doubles from 1 s to 32 s.
#include <atomic>
#include <chrono>
#include <optional>
#include <string>

#include "farm/curve.h"

namespace pd::worker {

struct WorkerOptions {
  std::string endpoint;     // the scheduler's worker endpoint, e.g. tcp://127.0.0.1:7400
  std::string name;         // shown by pd workers; default host:pid
  std::string scratch_dir;  // scene files and hierarchy blobs; default /tmp/pd-worker-<pid>
  int heartbeat_ms = 1000;  // until the scheduler's Welcome says otherwise
  // Fault injection for the farm's tests: every task of this level fails at once (-1: none).
  int fail_level = -1;
  // Fault injection for the farm's tests: every vertical start is refused as safe upsampling refuses
  // one (no scene of ours is refused since safe upsampling projects strain limits).
  bool refuse_vertical_starts = false;
  // Fault injection: refuse only the vertical starts at frames before this one (0: no such limit).
  int refuse_vertical_starts_before = 0;
  // --max-memory: the most memory a task may need, bytes (0: only what the machine, ulimit -v and the
  // cgroup leave this process). A level task that needs more (pd simulate's estimate per vertex,
  // util/memory_budget.h) is refused before anything is built, so another worker can take it.
  double max_memory_bytes = 0.0;
  // CURVE: --server-key (the scheduler's .pub) and --key (this worker's pair), both or neither, read
  // by main() into `curve` and applied to every session's socket before it connects.
  std::string server_key_file, key_file;
  std::optional<farm::CurveClientKeys> curve;
  // Exit (code kSchedulerGoneExit) once nothing has come from the scheduler for this long, seconds,
  // counted from the last message heard (or from the start): a worker in a Slurm allocation must
  // not hold it for ever when the scheduler is gone. 0: reconnect for ever.
  double scheduler_timeout_s = 0.0;
  // The Slurm job this worker runs as ("<array job>_<task>", see protocol Hello), "" outside Slurm.
  std::string slurm_job;
};

constexpr int kSchedulerGoneExit = 3;

constexpr int kLiveness = 3;  // missed heartbeats before the peer counts as gone
constexpr std::chrono::milliseconds kMinBackoff{1000}, kMaxBackoff{32000};

// Runs until `stop` becomes true (a signal handler sets it). Returns the process exit code.
int run_worker(const WorkerOptions& options, const std::atomic<bool>& stop);

}  // namespace pd::worker
