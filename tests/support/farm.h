#pragma once
// A farm for the integration tests (tests/integration/): one pd-scheduler on port-0 loopback
// endpoints (or the endpoints of an earlier run, for a restart) and pd-workers w1..wN, real
// processes started with support/process.h and driven with the pd client as a user drives them.
// Every wait is bounded; everything started is stopped by stop() or the destructor.
#include <chrono>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "store/frame_store.h"
#include "support/process.h"

namespace pd::test {

using Args = std::vector<std::string>;

constexpr auto kCommand = std::chrono::seconds(30);    // any client command but a --wait
constexpr auto kLongJob = std::chrono::seconds(300);   // a 200-frame job (about 25 s measured)
constexpr auto kShortJob = std::chrono::seconds(120);  // a job of 20-110 frames (at most 16 s measured)

std::string scene_path(const std::string& name);  // SOURCE/scenes/<name>

nlohmann::json parse_json(const RunResult& r);  // r.out as JSON; runtime_error naming r otherwise

struct FarmOptions {
  int workers = 2;
  int heartbeat_ms = 1000;
  Args scheduler_args;  // added to pd-scheduler's command line
  EnvAdditions scheduler_env;  // added to pd-scheduler's environment (e.g. SLURM_CONF for its sbatch calls)
  Args worker_args;     // added to every pd-worker's
  Args client_args;     // added to every pd command (after --farm)
  bool wait_for_workers = true;  // the constructor returns once every worker is idle
};

class Farm {
 public:
  Farm(const std::string& dir, const FarmOptions& options);
  ~Farm() { stop(); }
  Farm(const Farm&) = delete;
  Farm& operator=(const Farm&) = delete;

  const std::string& dir() const { return dir_; }
  const std::string& clients() const { return clients_; }
  const std::string& workers_endpoint() const { return workers_endpoint_; }
  // The current scheduler run's stderr (one JSON event per line), and every run's, oldest first.
  const std::string& scheduler_log() const { return logs_.back(); }
  const std::vector<std::string>& scheduler_logs() const { return logs_; }
  Process& scheduler() { return scheduler_; }
  Process& worker(int k) { return workers_.at(static_cast<std::size_t>(k - 1)); }  // w<k>, 1-based

  // pd ARGS --farm <clients>, bounded by `timeout`.
  RunResult pd(Args args, std::chrono::milliseconds timeout = kCommand) const;

  // Kills worker w<k> (1-based) with SIGKILL, as a machine that dies does, and reaps it.
  void kill_worker(int k);
  // Kills the scheduler with SIGKILL and reaps it; the workers keep running.
  void kill_scheduler();
  // Starts the scheduler again on the same directory and endpoints, logging to scheduler.<k>.log;
  // returns once it prints its listening line.
  void start_scheduler();

  // Starts one more worker w<k> (k = workers so far + 1) with `args` added and `env` added to its
  // environment (e.g. the SLURM_* variables of a worker started in a Slurm job by hand); returns k.
  int add_worker(const Args& args = {}, const EnvAdditions& env = {});

  // Waits until `pd workers --json` lists n workers idle; runtime_error after `timeout`.
  void wait_for_idle_workers(int n, std::chrono::milliseconds timeout) const;

  // The scheduler's exit code (it must exit 0 on SIGTERM); workers are stopped first.
  int stop();

  // The scheduler's log without its frame_stored lines (one per frame), and the workers' logs.
  std::string log_tails() const;

 private:
  std::string dir_, workers_endpoint_, clients_;
  std::vector<std::string> logs_;
  FarmOptions options_;
  Process scheduler_;
  std::vector<Process> workers_;
  std::vector<std::string> worker_logs_;
};

// A test fixture that starts farms in scratch folders, stops them in TearDown (expecting exit 0),
// prints their logs when the test failed and removes the folders when it passed.
class FarmTest : public ::testing::Test {
 protected:
  Farm& start_farm(int workers, const std::string& tag);
  Farm& start_farm(const FarmOptions& options, const std::string& tag);
  void TearDown() override;

  std::vector<std::string> dirs_;
  std::vector<std::unique_ptr<Farm>> farms_;
};

// pd submit ARGS --json: the job id; runtime_error when it fails.
int64_t submit(const Farm& farm, Args args);
// `pd status JOB --json`: the job's object.
nlohmann::json job_status(const Farm& farm, int64_t job);
// pd status JOB --wait; runtime_error when it does not end done within timeout.
void wait_until_done(const Farm& farm, int64_t job, std::chrono::milliseconds timeout);
// pd fetch JOB --out OUT.
void fetch(const Farm& farm, int64_t job, const std::string& out);

// `pd simulate SCENE --mode progressive --frames N --out OUT`, started now to run beside the farm;
// finish_reference waits for it (runtime_error with its log when it fails or times out).
Process start_reference(const std::string& scene, const std::string& out, int frames);
void finish_reference(Process& p, const std::string& out, std::chrono::milliseconds timeout);

bool same_bits(const Positions& a, const Positions& b);
// Frames first..last of `level` equal bit for bit in both files (and the level's mesh too).
void expect_identical_frames(const FrameReader& a, const FrameReader& b, int level, int first, int last);

// Largest vertex distance (m) between the files over frames first..last of `level`.
double max_vertex_deviation(const FrameReader& a, const FrameReader& b, int level, int first, int last);
// Every frame of every level stored, and none intersecting (independent CGAL check); expectations.
void expect_complete_and_intersection_free(const FrameReader& r);
// `pd status --json`'s job object: done, every level with all N + 1 frames; expectations.
void expect_every_level_complete(const nlohmann::json& job, int frames);
// The names of the workers that ran the job's tasks (`pd status --json`'s job object).
std::set<std::string> task_workers(const nlohmann::json& job);
// Submits `scene` for `frames` frames in `subsets` time subsets with its reference pd simulate
// (progressive, one process) running beside it, waits for both, and fetches the job's frames:
// DIR/job.h5 and DIR/ref.h5, DIR the farm's folder. Returns the job id.
int64_t run_beside_reference(Farm& farm, const std::string& scene, int frames, int subsets);

// The scheduler log's JSON lines whose "event" is `kind`.
std::vector<nlohmann::json> log_events(const std::string& log_path, const std::string& kind);

}  // namespace pd::test
