// The single-node Slurm cluster of tests/support/slurm_cluster.h, which the farm's Slurm tests
// start pd-workers on: a job array runs on the node (both tasks at once on 2 CPUs) and writes its
// files; scancel kills a job's processes, also one in a session of its own; stop() leaves no
// daemon, slurmstepd or job process of the cluster.
//
// Needs root and Debian's munge and slurm-wlm; without them each test is skipped with the reason.
#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support/process.h"
#include "support/slurm_cluster.h"
#include "support/test_paths.h"

namespace pd {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using test::RunResult;
using test::SlurmCluster;

constexpr auto kClient = 20s;  // one sbatch/squeue/scancel/scontrol

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A live process (a zombie counts as ended: its parent, init, reaps it in a moment).
bool alive(pid_t pid) {
  const std::string stat = test::read_file_text("/proc/" + std::to_string(pid) + "/stat");
  const size_t paren = stat.rfind(')');
  return paren != std::string::npos && paren + 2 < stat.size() && stat[paren + 2] != 'Z';
}

// Polls `done` every 100 ms for at most `timeout`; whether it came true.
template <class F>
bool eventually(std::chrono::milliseconds timeout, F done) {
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    if (done()) return true;
    if (Clock::now() >= deadline) return false;
    std::this_thread::sleep_for(100ms);
  }
}

std::string processes_text(const std::vector<pid_t>& pids) {
  std::string out;
  for (pid_t pid : pids) {
    std::string cmd = test::read_file_text("/proc/" + std::to_string(pid) + "/cmdline");
    for (char& c : cmd)
      if (c == '\0') c = ' ';
    out += std::to_string(pid) + " " + cmd + "\n";
  }
  return out;
}

// The processes of `pids` that are not munged, slurmctld (or its slurmscriptd) or slurmd.
std::vector<pid_t> not_daemons(const std::vector<pid_t>& pids) {
  std::vector<pid_t> out;
  for (pid_t pid : pids) {
    const std::string daemon = SlurmCluster::daemon_name(pid);
    if (daemon != "munged" && daemon != "slurmctld" && daemon != "slurmd") out.push_back(pid);
  }
  return out;
}

class SlurmClusterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const std::string why = SlurmCluster::unavailable_reason(); !why.empty()) GTEST_SKIP() << "skipped: " << why;
    dir_ = test::scratch_dir("slurm");
    const auto t0 = Clock::now();
    try {
      cluster_ = std::make_unique<SlurmCluster>(dir_, 2);
    } catch (const std::exception& e) {
      FAIL() << "the cluster did not start after " << seconds_since(t0) << " s: " << e.what();
    }
    std::cout << "[ cluster  ] idle after " << cluster_->startup_seconds() << " s in " << dir_ << "\n";
    RecordProperty("startup_seconds", std::to_string(cluster_->startup_seconds()));
  }

  // Stops the cluster (a test may have done so), checks nothing of it is left, and removes the
  // folder, which is kept with the daemons' logs printed when the test failed.
  void TearDown() override {
    if (!cluster_) return;
    cluster_->stop();
    const std::vector<pid_t> left = SlurmCluster::cluster_processes(dir_);
    EXPECT_TRUE(left.empty()) << "left after stop():\n" << processes_text(left);
    if (HasFailure()) {
      std::printf("%s\nkept %s\n", cluster_->log_tails().c_str(), dir_.c_str());
    } else {
      std::filesystem::remove_all(dir_);
    }
  }

  // sbatch --parsable ARGS: the job id (an array's job id), or "" with a failure recorded.
  std::string submit(std::vector<std::string> args) {
    args.insert(args.begin(), {"sbatch", "--parsable", "--chdir=" + dir_});
    const RunResult r = cluster_->command(args, kClient);
    EXPECT_EQ(r.exit_code, 0) << r.describe() << cluster_->log_tails();
    if (r.exit_code != 0) return "";
    return r.out.substr(0, r.out.find_first_of(";\n"));  // "ID" or "ID;cluster"
  }

  // squeue's "%i %T" lines (job id, state) for `job`, ended jobs included, sorted (squeue lists
  // an array's tasks in no fixed order).
  std::string queue_states(const std::string& job) const {
    std::istringstream lines(cluster_->command({"squeue", "-h", "-t", "all", "-j", job, "-o", "%i %T"}, kClient).out);
    std::vector<std::string> sorted;
    for (std::string line; std::getline(lines, line);) sorted.push_back(line);
    std::sort(sorted.begin(), sorted.end());
    std::string out;
    for (const std::string& line : sorted) out += line + "\n";
    return out;
  }

  // The pid a job wrote into dir/<name>, waiting up to 20 s for it (the job may still be pending).
  std::optional<pid_t> pid_from(const std::string& name) const {
    const auto line = test::read_first_line(dir_ + "/" + name, 20s);
    if (!line || line->empty()) return std::nullopt;
    return static_cast<pid_t>(std::stol(*line));
  }

  std::string dir_;
  std::unique_ptr<SlurmCluster> cluster_;
};

TEST_F(SlurmClusterTest, JobArrayRunsBothTasksAtOnceOnTheNodeAndWritesTheirOutput) {
  const auto t0 = Clock::now();
  const std::string job = submit({"--array=0-1", "--ntasks=1", "--cpus-per-task=1", "--output=" + dir_ + "/out_%A_%a.txt",
                                  "--wrap",
                                  "echo task $SLURM_ARRAY_TASK_ID of $SLURM_ARRAY_JOB_ID; "
                                  "echo $SLURM_ARRAY_JOB_ID $SLURM_ARRAY_TASK_ID > task_$SLURM_ARRAY_TASK_ID; sleep 2"});
  ASSERT_FALSE(job.empty());
  // Both 1-CPU tasks run at once on the 2-CPU node (cons_tres, CR_Core), each under its own id.
  const std::string both_running = job + "_0 RUNNING\n" + job + "_1 RUNNING\n";
  std::string states;
  EXPECT_TRUE(eventually(10s, [&] { return (states = queue_states(job)) == both_running; }))
      << "squeue never showed both tasks running; last:\n" << states << cluster_->log_tails();
  for (int task = 0; task < 2; ++task) {
    const std::string expected = job + " " + std::to_string(task);
    const auto line = test::read_first_line(dir_ + "/task_" + std::to_string(task), 20s);
    EXPECT_EQ(line.value_or("(no file)"), expected) << "task " << task;
    const std::string out_path = dir_ + "/out_" + job + "_" + std::to_string(task) + ".txt";
    const std::string expected_out = "task " + std::to_string(task) + " of " + job;
    EXPECT_EQ(test::read_first_line(out_path, 20s).value_or("(no output file)"), expected_out) << out_path;
  }
  // The ended tasks stay listed (MinJobAge) as COMPLETED.
  const std::string both_completed = job + "_0 COMPLETED\n" + job + "_1 COMPLETED\n";
  EXPECT_TRUE(eventually(20s, [&] { return (states = queue_states(job)) == both_completed; }))
      << "last squeue:\n" << states << cluster_->log_tails();
  std::cout << "[ job array] submitted to completed in " << seconds_since(t0) << " s\n";
}

TEST_F(SlurmClusterTest, ScancelKillsTheJobsProcessesAlsoOneInItsOwnSession) {
  const std::string job = submit({"--output=" + dir_ + "/sleep.out", "--wrap",
                                  "sleep 300 & echo $! > sleep.pid; "
                                  "setsid sleep 301 & echo $! > setsid.pid; wait"});
  ASSERT_FALSE(job.empty());
  const auto sleep_pid = pid_from("sleep.pid"), setsid_pid = pid_from("setsid.pid");
  ASSERT_TRUE(sleep_pid && setsid_pid) << "the job never wrote its pids\n" << queue_states(job) << cluster_->log_tails();
  EXPECT_TRUE(eventually(5s, [&] { return alive(*setsid_pid); })) << "setsid's sleep never ran";
  ASSERT_TRUE(alive(*sleep_pid));

  const auto t0 = Clock::now();
  const RunResult cancel = cluster_->command({"scancel", job}, kClient);
  ASSERT_EQ(cancel.exit_code, 0) << cancel.describe();
  EXPECT_TRUE(eventually(10s, [&] { return !alive(*sleep_pid) && !alive(*setsid_pid); }))
      << "after scancel, still alive:\n" << processes_text({*sleep_pid, *setsid_pid}) << cluster_->log_tails();
  const double kill_seconds = seconds_since(t0);
  std::cout << "[ scancel  ] job processes gone " << kill_seconds << " s after scancel\n";
  RecordProperty("scancel_to_gone_seconds", std::to_string(kill_seconds));

  std::string states;
  EXPECT_TRUE(eventually(10s, [&] { return (states = queue_states(job)) == job + " CANCELLED\n"; }))
      << "last squeue:\n" << states;
  const RunResult show = cluster_->command({"scontrol", "show", "job", job}, kClient);
  EXPECT_NE(show.out.find("JobState=CANCELLED"), std::string::npos) << show.describe();
  // Its slurmstepd ends too: only the daemons are left.
  std::vector<pid_t> left;
  EXPECT_TRUE(eventually(10s, [&] { return (left = not_daemons(SlurmCluster::cluster_processes(dir_))).empty(); }))
      << "the cluster's processes besides its daemons:\n" << processes_text(left);
}

TEST_F(SlurmClusterTest, StopLeavesNoDaemonOrJobProcess) {
  const std::string job = submit({"--output=" + dir_ + "/sleep.out", "--wrap", "sleep 300 & echo $! > sleep.pid; wait"});
  ASSERT_FALSE(job.empty());
  const auto sleep_pid = pid_from("sleep.pid");
  ASSERT_TRUE(sleep_pid) << queue_states(job) << cluster_->log_tails();
  // munged, slurmctld (and its slurmscriptd), slurmd, the job's slurmstepd, shell and sleep.
  const std::vector<pid_t> before = SlurmCluster::cluster_processes(dir_);
  EXPECT_GE(before.size(), 6u) << processes_text(before);

  const auto t0 = Clock::now();
  cluster_->stop();
  const double stop_seconds = seconds_since(t0);
  std::cout << "[ stop     ] " << stop_seconds << " s\n";
  EXPECT_LT(stop_seconds, 30.0);
  EXPECT_TRUE(SlurmCluster::cluster_processes(dir_).empty()) << processes_text(SlurmCluster::cluster_processes(dir_));
  std::vector<pid_t> still;
  for (pid_t pid : before)
    if (alive(pid)) still.push_back(pid);
  EXPECT_TRUE(still.empty()) << "alive after stop():\n" << processes_text(still);
  EXPECT_FALSE(alive(*sleep_pid));
  // stop() cancelled the job through Slurm: nothing was left for its SIGKILL sweep.
  std::string killed;
  for (const std::string& k : cluster_->killed_at_stop()) killed += k + "\n";
  EXPECT_TRUE(killed.empty()) << "stop() had to kill:\n" << killed;

  const auto t1 = Clock::now();
  cluster_->stop();  // idempotent, and quick the second time
  EXPECT_LT(seconds_since(t1), 1.0);
}

}  // namespace
}  // namespace pd
