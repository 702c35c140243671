// The farm under faults, with real processes and SIGKILL / SIGSTOP, not polite shutdowns: a worker
// killed or frozen in the middle of a refinement task or of a seam's stitch, the scheduler killed and
// restarted (at once, or after 20 s down), and a refinement task that fails on every worker. Each job's frames must be
// those of an undisturbed `pd simulate --mode progressive` run bit for bit, and no frame may be
// stored twice (counted in the scheduler's log).
//
// Frames: cube-trampoline with 60 frames (three levels; the finest level's task runs long enough
// to be interrupted with a few frames stored).
#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "store/frame_store.h"
#include "support/farm.h"
#include "support/process.h"

namespace pd {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using test::Farm;
using test::FarmTest;

constexpr int kFrames = 60;

// Polls `pd status JOB --json` until a refinement task (level >= 1; a seam's stitch task when
// `stitch`) runs with at least `frames` of its frames stored and not all; returns that task's status
// object.
json wait_for_running_refinement(const Farm& farm, int64_t job, int frames, bool stitch = false,
                                 std::chrono::seconds timeout = 180s) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    const json status = test::job_status(farm, job);  // kept: a loop over a temporary's member would dangle
    for (const json& t : status.at("tasks")) {
      if (t.at("kind") != "level" || t.at("level") < 1 || t.at("state") != "running") continue;
      if (stitch && !t.at("stitch").get<bool>()) continue;
      const int done = t.at("frames_done"), total = t.at("last").get<int>() - t.at("first").get<int>();
      if (done >= frames && done < total) return t;
    }
    std::this_thread::sleep_for(50ms);
  }
  throw std::runtime_error("no refinement task of job " + std::to_string(job) + " ran with " +
                           std::to_string(frames) + " frames stored in time");
}

int worker_number(const json& task) { return std::stoi(task.at("worker").get<std::string>().substr(1)); }

// frame_stored events per (level, frame) over the given scheduler logs.
std::map<std::pair<int, int>, int> stored_counts(const std::vector<std::string>& logs) {
  std::map<std::pair<int, int>, int> counts;
  for (const std::string& log : logs)
    for (const json& e : test::log_events(log, "frame_stored")) {
      int level = -1, frame = -1;
      if (std::sscanf(e.at("message").get<std::string>().c_str(), "level %d frame %d", &level, &frame) == 2)
        ++counts[{level, frame}];
    }
  return counts;
}

// No (level, frame) stored twice; returns the frames counted.
int expect_no_frame_stored_twice(const std::vector<std::string>& logs) {
  int frames = 0;
  for (const auto& [key, n] : stored_counts(logs)) {
    EXPECT_EQ(n, 1) << "level " << key.first << " frame " << key.second << " stored " << n << " times";
    ++frames;
  }
  return frames;
}

bool log_has(const std::string& log, const std::string& kind, const std::string& text) {
  for (const json& e : test::log_events(log, kind))
    if (e.value("message", "").find(text) != std::string::npos) return true;
  return false;
}

// The job's file equals the reference bit for bit on every level and frame.
void expect_reference_frames(const Farm& farm, int64_t job, test::Process& ref, const std::string& ref_path) {
  test::wait_until_done(farm, job, test::kLongJob);
  test::fetch(farm, job, farm.dir() + "/job.h5");
  test::finish_reference(ref, ref_path, test::kLongJob);
  const FrameReader got(farm.dir() + "/job.h5"), want(ref_path);
  ASSERT_EQ(got.num_levels(), 3);
  ASSERT_EQ(got.num_levels(), want.num_levels());
  ASSERT_EQ(got.num_frames(), kFrames + 1);
  for (int l = 0; l < got.num_levels(); ++l) test::expect_identical_frames(got, want, l, 0, kFrames);
}

struct Started {
  int64_t job = 0;
  test::Process ref;
  std::string ref_path;
};

Started start_job_and_reference(const Farm& farm) {
  Started s;
  const std::string scene = test::scene_path("cube-trampoline.json");
  s.job = test::submit(farm, {scene, "--frames", std::to_string(kFrames), "--subsets", "1"});
  s.ref_path = farm.dir() + "/ref.h5";
  s.ref = test::start_reference(scene, s.ref_path, kFrames);
  return s;
}

TEST_F(FarmTest, AWorkerKilledMidRefinementLosesNoFrameAndTheNextAttemptContinuesFromItsStoredFrames) {
  Farm& farm = start_farm(2, "faults_kill_worker");
  Started job = start_job_and_reference(farm);
  const json task = wait_for_running_refinement(farm, job.job, 3);
  const double killed = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  farm.kill_worker(worker_number(task));
  expect_reference_frames(farm, job.job, job.ref, job.ref_path);
  EXPECT_TRUE(log_has(farm.scheduler_log(), "worker_lost", task.at("worker").get<std::string>() + ":"));
  // Recovery time: from the SIGKILL to the task's next attempt (the liveness time, 3 heartbeats).
  for (const json& e : test::log_events(farm.scheduler_log(), "task_assigned"))
    if (e.value("task", int64_t{0}) == task.at("id").get<int64_t>() && e.at("time").get<double>() > killed) {
      const double seconds = e.at("time").get<double>() - killed;
      std::printf("recovery: task %lld re-assigned %.2f s after its worker was killed\n",
                  static_cast<long long>(task.at("id").get<int64_t>()), seconds);
      RecordProperty("recovery_seconds", std::to_string(seconds));
      EXPECT_LT(seconds, 30.0);
      break;
    }
  EXPECT_TRUE(log_has(farm.scheduler_log(), "task_assigned", "continuing from frame"))
      << "the killed task's next attempt did not continue from its stored frames";
  EXPECT_EQ(expect_no_frame_stored_twice(farm.scheduler_logs()), 3 * (kFrames + 1));
}

// A seam's stitch task whose worker is killed with some stitched frames stored: its next attempt
// continues from them with the seam's ramp (AssignTask.guides carries every guide frame), and the
// job's frames are, bit for bit, those of the same job run again undisturbed on the same farm. The
// flag, 100 frames, K = 2, a 40-frame stitch (so that it runs long enough to be interrupted).
TEST_F(FarmTest, AWorkerKilledDuringASeamsStitchLosesNothingAndTheFramesAreThoseOfTheUndisturbedJob) {
  constexpr int kStitchFrames = 100;
  Farm& farm = start_farm(2, "faults_kill_stitch");
  const std::vector<std::string> args = {test::scene_path("flag.json"), "--frames", std::to_string(kStitchFrames),
                                         "--subsets", "2", "--stitch", "40"};
  const int64_t first = test::submit(farm, args);
  const json task = wait_for_running_refinement(farm, first, 3, true);
  farm.kill_worker(worker_number(task));
  test::wait_until_done(farm, first, test::kLongJob);
  EXPECT_TRUE(log_has(farm.scheduler_log(), "task_assigned", "stitch frames (" + std::to_string(task.at("first").get<int>())))
      << "no stitch task was assigned";
  bool resumed = false;
  for (const json& e : test::log_events(farm.scheduler_log(), "task_assigned"))
    resumed = resumed || (e.value("task", int64_t{0}) == task.at("id").get<int64_t>() &&
                          e.at("message").get<std::string>().find("continuing from frame") != std::string::npos);
  EXPECT_TRUE(resumed) << "the stitch's next attempt did not continue from its stored frames";
  const int64_t again = test::submit(farm, args);
  test::wait_until_done(farm, again, test::kLongJob);
  test::fetch(farm, first, farm.dir() + "/first.h5");
  test::fetch(farm, again, farm.dir() + "/again.h5");
  const FrameReader a(farm.dir() + "/first.h5"), b(farm.dir() + "/again.h5");
  ASSERT_EQ(a.num_levels(), b.num_levels());
  for (int l = 0; l < a.num_levels(); ++l) test::expect_identical_frames(a, b, l, 0, kStitchFrames);
}

TEST_F(FarmTest, ASchedulerKilledMidJobAndRestartedOnItsDirectoryFinishesTheJobWithTheSameFrames) {
  Farm& farm = start_farm(2, "faults_kill_scheduler");
  Started job = start_job_and_reference(farm);
  wait_for_running_refinement(farm, job.job, 3);
  const pid_t w1 = farm.worker(1).pid(), w2 = farm.worker(2).pid();
  farm.kill_scheduler();
  farm.start_scheduler();
  expect_reference_frames(farm, job.job, job.ref, job.ref_path);
  // The same worker processes, reconnected by themselves.
  EXPECT_TRUE(farm.worker(1).running() && farm.worker(2).running());
  EXPECT_EQ(farm.worker(1).pid(), w1);
  EXPECT_EQ(farm.worker(2).pid(), w2);
  farm.wait_for_idle_workers(2, 30s);
  EXPECT_EQ(test::log_events(farm.scheduler_log(), "job_file_rebuilt").size(), 1u);
  EXPECT_EQ(test::log_events(farm.scheduler_log(), "worker_joined").size(), 2u);
  // A frame stored by the killed scheduler may miss its log line (killed between the two), so the
  // count is at most the job's frames; none may be stored twice.
  EXPECT_LE(expect_no_frame_stored_twice(farm.scheduler_logs()), 3 * (kFrames + 1));
}

TEST_F(FarmTest, AFrozenWorkerLosesItsLeaseAndItsLateReportsAreRefusedWhenItWakes) {
  Farm& farm = start_farm(2, "faults_sigstop");
  Started job = start_job_and_reference(farm);
  const json task = wait_for_running_refinement(farm, job.job, 2);
  const int frozen = worker_number(task);
  const std::string name = task.at("worker");
  ::kill(farm.worker(frozen).pid(), SIGSTOP);
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (!log_has(farm.scheduler_log(), "worker_lost", name + ":") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(100ms);
  const bool lost = log_has(farm.scheduler_log(), "worker_lost", name + ":");
  const std::size_t refused_before = test::log_events(farm.scheduler_log(), "report_refused").size();
  ::kill(farm.worker(frozen).pid(), SIGCONT);
  ASSERT_TRUE(lost) << name << " was not given up within 30 s of SIGSTOP";
  expect_reference_frames(farm, job.job, job.ref, job.ref_path);
  // Woken, it sent what it had queued (a frame or a heartbeat of the old session): refused.
  EXPECT_GT(test::log_events(farm.scheduler_log(), "report_refused").size(), refused_before);
  EXPECT_EQ(expect_no_frame_stored_twice(farm.scheduler_logs()), 3 * (kFrames + 1));
}

TEST_F(FarmTest, WorkersBackOffWhileTheSchedulerIsDownForTwentySecondsAndTheJobCompletes) {
  Farm& farm = start_farm(2, "faults_scheduler_down");
  Started job = start_job_and_reference(farm);
  wait_for_running_refinement(farm, job.job, 2);
  farm.kill_scheduler();
  std::this_thread::sleep_for(20s);
  farm.start_scheduler();
  expect_reference_frames(farm, job.job, job.ref, job.ref_path);
  // Each worker backed off 1, 2, 4, 8 s... while it was down (worker log lines "reconnecting: in N ms").
  for (int k = 1; k <= 2; ++k) {
    const std::string log = test::read_file_text(farm.dir() + "/worker-w" + std::to_string(k) + ".log");
    for (const char* wait : {"in 1000 ms", "in 2000 ms", "in 4000 ms"})
      EXPECT_NE(log.find(wait), std::string::npos) << "w" << k << " never waited " << wait << ":\n" << log;
  }
  EXPECT_LE(expect_no_frame_stored_twice(farm.scheduler_logs()), 3 * (kFrames + 1));
}

TEST_F(FarmTest, ATaskFailingOnThreeWorkersFailsTheJobBlocksItsDependentsAndRequeueRunsItAgain) {
  test::FarmOptions o;
  o.workers = 3;
  o.worker_args = {"--fail-level", "1"};  // every level-1 task fails at once on these workers
  Farm& farm = start_farm(o, "faults_fail_everywhere");
  const int64_t job = test::submit(farm, {test::scene_path("cube-trampoline.json"), "--frames", "10"});
  const test::RunResult wait = farm.pd({"status", std::to_string(job), "--wait", "--interval", "0.2"}, test::kShortJob);
  EXPECT_FALSE(wait.timed_out) << wait.describe();
  EXPECT_EQ(wait.exit_code, 1) << wait.describe();
  EXPECT_NE(wait.err.find("injected failure"), std::string::npos) << wait.describe();

  const json status = test::job_status(farm, job);
  EXPECT_EQ(status.at("state"), "failed");
  EXPECT_NE(status.at("reason").get<std::string>().find("(failed on 3 workers)"), std::string::npos) << status.dump();
  int64_t failed_task = 0;
  int failed = 0, blocked = 0;
  for (const json& t : status.at("tasks")) {
    if (t.at("kind") != "level") continue;
    if (t.at("level") == 1) {
      EXPECT_EQ(t.at("state"), "failed") << t.dump();
      EXPECT_EQ(t.at("attempts"), 3) << t.dump();
      failed_task = t.at("id");
      ++failed;
    } else if (t.at("level") == 2) {
      EXPECT_EQ(t.at("state"), "blocked") << t.dump();
      EXPECT_NE(t.at("reason").get<std::string>().find("needs frames of task"), std::string::npos) << t.dump();
      ++blocked;
    }
  }
  EXPECT_EQ(failed, 1);
  EXPECT_EQ(blocked, 1);
  std::set<int64_t> workers;
  for (const json& e : test::log_events(farm.scheduler_log(), "attempt_failed"))
    if (e.value("task", int64_t{0}) == failed_task) workers.insert(e.at("worker").get<int64_t>());
  EXPECT_EQ(workers.size(), 3u) << "the failing task was not tried on three different workers";

  // The failing workers are replaced by one that does not fail; requeued, the job completes.
  for (int k = 1; k <= 3; ++k) farm.worker(k).terminate();
  farm.add_worker();
  farm.wait_for_idle_workers(1, 30s);
  const test::RunResult requeue = farm.pd({"requeue", std::to_string(job)});
  EXPECT_EQ(requeue.exit_code, 0) << requeue.describe();
  EXPECT_NE(requeue.out.find("requeued 2 tasks"), std::string::npos) << requeue.describe();
  test::wait_until_done(farm, job, test::kShortJob);
  const test::RunResult again = farm.pd({"requeue", std::to_string(job)});
  EXPECT_NE(again.exit_code, 0) << again.describe();
  EXPECT_NE(again.err.find("only a failed job can be requeued"), std::string::npos) << again.describe();
}

// A worker that cannot hold a task refuses it before building anything (--max-memory here; the
// machine's available memory, ulimit -v and the cgroup otherwise), naming what it needs and what it
// may take; the task goes to a worker that can, and the job ends done.
TEST_F(FarmTest, ATaskTooLargeForAWorkersMemoryIsRefusedThereNamingTheFiguresAndRunsOnAnother) {
  Farm& farm = start_farm(1, "faults_memory");
  farm.add_worker({"--max-memory", "0.001"});  // w2: 1 MiB, less than any level of the scene needs
  const int64_t job = test::submit(farm, {test::scene_path("cube-trampoline.json"), "--frames", "10"});
  test::wait_until_done(farm, job, test::kShortJob);
  int refused = 0;
  for (const json& e : test::log_events(farm.scheduler_log(), "attempt_failed")) {
    const std::string message = e.at("message").get<std::string>();
    EXPECT_NE(message.find("vertices) needs about"), std::string::npos) << message;
    EXPECT_NE(message.find("KiB a vertex); this worker may take 0.0 GiB (limited by --max-memory)"), std::string::npos)
        << message;
    EXPECT_EQ(e.at("worker").get<int64_t>(), 2) << message;
    ++refused;
  }
  EXPECT_GE(refused, 1) << "w2 was never given a level task";
  const json status = test::job_status(farm, job);  // kept: a loop over a temporary's member would dangle
  for (const json& t : status.at("tasks")) {
    if (t.at("kind") == "level") {
      EXPECT_EQ(t.at("worker"), "w1") << t.dump();
    }
  }
}

}  // namespace
}  // namespace pd
