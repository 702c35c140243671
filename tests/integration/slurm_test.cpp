// Slurm workers (docs/deploy.md, "Slurm"), against a real single-node Slurm cluster that the test
// starts (support/slurm_cluster.h: munged, slurmctld, slurmd on localhost): pd-scheduler runs sbatch
// with deploy/slurm/pd-worker.sbatch, the array tasks' pd-workers connect back, and the job's frames
// are those of hand-started workers bit for bit, also when Slurm kills a worker in the middle of a
// task. Skipped, with the reason printed, only where Slurm cannot be started at all.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "store/frame_store.h"
#include "support/farm.h"
#include "support/slurm_cluster.h"
#include "support/test_paths.h"

namespace pd {
namespace {

using json = nlohmann::json;
using namespace std::chrono_literals;
using test::Farm;
using test::FarmOptions;

constexpr int kFrames = 20;        // the two-worker job (preview and two levels, about 10 s here)
constexpr int kCancelFrames = 60;  // the scancel job: long enough to cancel a task in its middle

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// Polls `done` every `period` for at most `timeout`; false when it never held.
bool wait_for(const std::function<bool()>& done, std::chrono::milliseconds timeout,
              std::chrono::milliseconds period = 200ms) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(period);
  }
  return done();
}

json workers_json(const Farm& farm) {
  const test::RunResult r = farm.pd({"workers", "--json"});
  if (r.exit_code != 0) throw std::runtime_error("pd workers failed: " + r.describe());
  return test::parse_json(r);
}

// The Slurm entry of `id` in a pd workers --json reply (null when absent).
json slurm_entry(const json& workers, const std::string& id) {
  for (const json& s : workers.at("slurm"))
    if (s.at("slurm_job") == id) return s;
  return nullptr;
}

json worker_entry(const json& workers, const std::string& name) {
  for (const json& w : workers.at("workers"))
    if (w.at("name") == name) return w;
  return nullptr;
}

// The names of the workers that were assigned a task so far, and when the first assignment of each was.
std::map<std::string, double> assigned_workers(const Farm& farm) {
  std::map<std::string, double> first;
  for (const json& e : test::log_events(farm.scheduler_log(), "task_assigned")) {
    const std::string m = e.at("message").get<std::string>();
    const auto to = m.rfind(" to ");
    if (to == std::string::npos) continue;
    std::string name = m.substr(to + 4);
    name = name.substr(0, name.find(','));
    first.emplace(name, e.at("time").get<double>());
  }
  return first;
}

void expect_same_frames(const std::string& a_path, const std::string& b_path, int frames) {
  const FrameReader a(a_path), b(b_path);
  ASSERT_EQ(a.num_levels(), b.num_levels());
  ASSERT_EQ(a.num_frames(), frames + 1);
  for (int l = 0; l < a.num_levels(); ++l) test::expect_identical_frames(a, b, l, 0, frames);
}

class SlurmTest : public test::FarmTest {
 protected:
  // Starts the cluster and a farm whose scheduler submits Slurm workers to it.
  Farm& start_slurm_farm(const std::string& tag, int heartbeat_ms = 1000) {
    const std::string reason = test::SlurmCluster::unavailable_reason();
    if (!reason.empty()) throw Unavailable{reason};
    cluster_dir_ = test::scratch_dir(tag + "_slurm");
    cluster_ = std::make_unique<test::SlurmCluster>(cluster_dir_);
    std::printf("slurm: cluster idle %.2f s after its daemons were started\n", cluster_->startup_seconds());
    FarmOptions o;
    o.workers = 0;
    o.wait_for_workers = false;
    o.heartbeat_ms = heartbeat_ms;
    o.scheduler_env = cluster_->env();
    o.scheduler_args = {"--slurm-script", test::source_dir() + "/deploy/slurm/pd-worker.sbatch", "--slurm-worker",
                        PD_WORKER_BINARY, "--slurm-poll", "1",
                        "--slurm-scheduler-timeout", "60"};
    return start_farm(o, tag);
  }

  void TearDown() override {
    test::FarmTest::TearDown();  // the scheduler first: then nothing resubmits what the cluster cancels
    if (cluster_) {
      if (HasFailure()) std::printf("%s", cluster_->log_tails().c_str());
      cluster_->stop();
      cluster_.reset();
      if (!HasFailure()) std::filesystem::remove_all(cluster_dir_);
    }
  }

  struct Unavailable {
    std::string reason;
  };

  std::unique_ptr<test::SlurmCluster> cluster_;
  std::string cluster_dir_;
};

#define START_SLURM_FARM(var, ...)                           \
  Farm* var##_ptr = nullptr;                                 \
  try {                                                      \
    var##_ptr = &start_slurm_farm(__VA_ARGS__);              \
  } catch (const Unavailable& u) {                           \
    GTEST_SKIP() << "Slurm cannot be started here: " << u.reason; \
  }                                                          \
  Farm& var = *var##_ptr

TEST_F(SlurmTest, TwoSlurmWorkersRunAJobWithTheFramesOfHandStartedWorkersAndAreDrainedOnRemove) {
  START_SLURM_FARM(farm, "slurm_two");
  const double added = unix_now();
  const test::RunResult add = farm.pd({"workers", "add", "--slurm", "2", "--cpus", "1", "--mem", "1G", "--time", "30", "--json"});
  ASSERT_EQ(add.exit_code, 0) << add.describe();
  const std::string array = test::parse_json(add).at("slurm_job").get<std::string>();
  const std::string ids[2] = {array + "_0", array + "_1"};

  const std::string scene = test::scene_path("cube-trampoline.json");
  const int64_t job = test::submit(farm, {scene, "--frames", std::to_string(kFrames), "--subsets", "2"});
  std::map<std::string, double> assigned;
  ASSERT_TRUE(wait_for(
      [&] {
        assigned = assigned_workers(farm);
        return assigned.count("slurm-" + ids[0]) && assigned.count("slurm-" + ids[1]);
      },
      90s))
      << "both Slurm workers did not take a task within 90 s";
  const double both = std::max(assigned["slurm-" + ids[0]], assigned["slurm-" + ids[1]]);
  std::printf("slurm: both workers took tasks %.2f s after `pd workers add --slurm 2` (first %.2f s)\n",
              both - added, std::min(assigned["slurm-" + ids[0]], assigned["slurm-" + ids[1]]) - added);
  RecordProperty("add_to_both_taking_tasks_seconds", std::to_string(both - added));
  test::wait_until_done(farm, job, test::kShortJob);

  // Only the Slurm workers ran it, and pd workers --json names their Slurm jobs.
  for (const auto& [name, time] : assigned) EXPECT_EQ(name.rfind("slurm-" + array + "_", 0), 0u) << name;
  const json workers = workers_json(farm);
  ASSERT_EQ(workers.at("workers").size(), 2u) << workers.dump();
  for (const std::string& id : ids) {
    const json w = worker_entry(workers, "slurm-" + id);
    ASSERT_FALSE(w.is_null()) << workers.dump();
    EXPECT_EQ(w.at("slurm_job"), id);
    const json s = slurm_entry(workers, id);
    ASSERT_FALSE(s.is_null()) << workers.dump();
    EXPECT_EQ(s.at("state"), "RUNNING");
    EXPECT_EQ(s.at("worker"), "slurm-" + id);
  }
  const std::string slurm_file = farm.dir() + "/slurm.h5";
  test::fetch(farm, job, slurm_file);

  // A worker started by hand in a Slurm job of its own joins, and its job is not this scheduler's to
  // cancel: pd workers remove refuses it by id and by array, and it keeps running.
  const int hand_worker = farm.add_worker({}, {{"SLURM_ARRAY_JOB_ID", "987654321"}, {"SLURM_ARRAY_TASK_ID", "7"}});
  farm.wait_for_idle_workers(3, 30s);
  for (const std::string& id : {std::string("987654321_7"), std::string("987654321")}) {
    const test::RunResult refused = farm.pd({"workers", "remove", "--slurm", id});
    EXPECT_EQ(refused.exit_code, 2) << refused.describe();
    EXPECT_NE(refused.err.find("was not submitted by this scheduler"), std::string::npos) << refused.describe();
  }
  EXPECT_EQ(test::read_file_text(farm.scheduler_log()).find("987654321_7: "), std::string::npos) << "a slurm_remove event";
  farm.kill_worker(hand_worker);

  // The same job on two hand-started workers.
  Farm& hand = start_farm(2, "slurm_two_hand");
  const int64_t hand_job = test::submit(hand, {scene, "--frames", std::to_string(kFrames), "--subsets", "2"});
  test::wait_until_done(hand, hand_job, test::kShortJob);
  const std::string hand_file = hand.dir() + "/hand.h5";
  test::fetch(hand, hand_job, hand_file);
  expect_same_frames(slurm_file, hand_file, kFrames);

  // pd workers remove drains the array: both idle, so both are cancelled at once.
  const test::RunResult remove = farm.pd({"workers", "remove", "--slurm", array});
  ASSERT_EQ(remove.exit_code, 0) << remove.describe();
  EXPECT_NE(remove.out.find("2 cancelled"), std::string::npos) << remove.out;
  json after;
  EXPECT_TRUE(wait_for(
      [&] {
        after = workers_json(farm);
        for (const std::string& id : ids) {
          const json s = slurm_entry(after, id), w = worker_entry(after, "slurm-" + id);
          if (s.is_null() || w.is_null() || w.at("state") != "lost") return false;
          if (s.at("state") != "CANCELLED" && s.at("state") != "GONE") return false;
        }
        return true;
      },
      30s))
      << after.dump(2);
  const test::RunResult squeue = cluster_->command({"squeue", "--noheader", "--states=RUNNING,PENDING"}, 10s);
  EXPECT_EQ(squeue.out, "") << "Slurm still runs jobs after pd workers remove: " << squeue.describe();
}

TEST_F(SlurmTest, ScancelOfABusySlurmWorkerReleasesItsTaskAKeptReplacementJoinsAndTheFramesStayTheSame) {
  START_SLURM_FARM(farm, "slurm_scancel");
  const test::RunResult add = farm.pd({"workers", "add", "--slurm", "2", "--keep", "2", "--json"});
  ASSERT_EQ(add.exit_code, 0) << add.describe();
  const std::string array = test::parse_json(add).at("slurm_job").get<std::string>();
  const std::string scene = test::scene_path("cube-trampoline.json");
  const int64_t job = test::submit(farm, {scene, "--frames", std::to_string(kCancelFrames), "--subsets", "1"});
  const std::string ref_path = farm.dir() + "/ref.h5";
  test::Process ref = test::start_reference(scene, ref_path, kCancelFrames);

  // A refinement task in its middle, on a Slurm worker.
  json victim;
  ASSERT_TRUE(wait_for(
      [&] {
        const json status = test::job_status(farm, job);  // kept: a loop over a temporary's member would dangle
        for (const json& t : status.at("tasks"))
          if (t.at("state") == "running" && t.at("kind") == "level" && t.at("level").get<int>() >= 1 &&
              t.at("frames_done").get<int>() >= 3 &&
              t.at("frames_done").get<int>() < t.at("last").get<int>() - t.at("first").get<int>() - 3 &&
              t.at("worker").get<std::string>().rfind("slurm-", 0) == 0) {
            victim = t;
            return true;
          }
        return false;
      },
      180s, 50ms))
      << "no refinement task reached 3 frames on a Slurm worker";
  const std::string name = victim.at("worker").get<std::string>();
  const std::string id = name.substr(6);
  const double cancelled = unix_now();
  const test::RunResult scancel = cluster_->command({"scancel", id}, 10s);
  ASSERT_EQ(scancel.exit_code, 0) << scancel.describe();
  std::printf("slurm: scancel %s while it ran task %lld at %d frames\n", id.c_str(),
              static_cast<long long>(victim.at("id").get<int64_t>()), victim.at("frames_done").get<int>());

  test::wait_until_done(farm, job, test::kLongJob);
  test::finish_reference(ref, ref_path, test::kLongJob);
  const std::string got = farm.dir() + "/job.h5";
  test::fetch(farm, job, got);
  expect_same_frames(got, ref_path, kCancelFrames);

  // The cancelled worker is a lost worker whose task was released; Slurm's state says why.
  bool released = false;
  for (const json& e : test::log_events(farm.scheduler_log(), "task_released"))
    released = released || e.value("task", int64_t{0}) == victim.at("id").get<int64_t>();
  EXPECT_TRUE(released) << "the cancelled worker's task was not released";
  // With the worker's goodbye (SIGTERM from slurmstepd) the task moves at once, not after 3 heartbeats.
  for (const json& e : test::log_events(farm.scheduler_log(), "task_assigned"))
    if (e.value("task", int64_t{0}) == victim.at("id").get<int64_t>() && e.at("time").get<double>() > cancelled) {
      const double seconds = e.at("time").get<double>() - cancelled;
      std::printf("slurm: task %lld assigned again %.2f s after the scancel\n",
                  static_cast<long long>(victim.at("id").get<int64_t>()), seconds);
      RecordProperty("scancel_to_reassigned_seconds", std::to_string(seconds));
      break;
    }
  bool goodbye = false;
  for (const json& e : test::log_events(farm.scheduler_log(), "worker_lost"))
    goodbye = goodbye || e.value("message", std::string()).find(name + ": said goodbye") == 0;
  EXPECT_TRUE(goodbye) << "the cancelled worker did not say goodbye (lost by liveness instead)";
  json workers;
  EXPECT_TRUE(wait_for(
      [&] {
        workers = workers_json(farm);
        const json w = worker_entry(workers, name), s = slurm_entry(workers, id);
        return !w.is_null() && w.at("state") == "lost" && !s.is_null() && s.at("state") == "CANCELLED";
      },
      20s))
      << workers.dump(2);
  // The keep target replaced it while the job still had work, and the replacement became a worker.
  std::string replacement;
  for (const json& s : workers.at("slurm"))
    if (s.at("replacement").get<bool>()) replacement = s.at("slurm_job").get<std::string>();
  ASSERT_FALSE(replacement.empty()) << "no replacement was submitted for the keep target: " << workers.dump(2);
  EXPECT_NE(replacement.rfind(array + "_", 0), 0u) << "the replacement is a new sbatch call, not a task of the array";
  EXPECT_TRUE(wait_for(
      [&] {
        workers = workers_json(farm);
        const json w = worker_entry(workers, "slurm-" + replacement);
        return !w.is_null() && w.at("state") != "lost" && w.at("slurm_job") == replacement;
      },
      30s))
      << workers.dump(2);
  for (const char* kind : {"worker_lost", "task_released", "slurm_submitted", "slurm_state"})
    for (const json& e : test::log_events(farm.scheduler_log(), kind))
      std::printf("slurm: event %s: %s\n", kind, e.value("message", std::string()).c_str());
  EXPECT_EQ(workers.at("slurm_keep"), 2);
}

// Without Slurm: a worker whose scheduler has gone exits by itself after --scheduler-timeout.
TEST_F(SlurmTest, AWorkerExitsWithCode3WhenItsSchedulerIsGoneLongerThanItsTimeout) {
  FarmOptions o;
  o.workers = 1;
  o.worker_args = {"--scheduler-timeout", "3"};
  Farm& farm = start_farm(o, "slurm_scheduler_timeout");
  const auto killed = std::chrono::steady_clock::now();
  farm.kill_scheduler();
  const std::optional<int> code = farm.worker(1).wait_for_exit(20s);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  ASSERT_TRUE(code.has_value()) << "the worker still runs 20 s after its scheduler was killed";
  EXPECT_EQ(*code, 3);
  // Counted from the last message heard, a heartbeat up to 1 s (heartbeat_ms) before the kill.
  EXPECT_GE(seconds, 2.0);
  EXPECT_LT(seconds, 8.0);
  std::printf("worker exited %.2f s after its scheduler was killed (--scheduler-timeout 3)\n", seconds);
  farm.start_scheduler();  // TearDown expects a scheduler to stop
}

// Without Slurm: Slurm requests to a scheduler that has no --slurm-script, and bad values.
TEST_F(SlurmTest, SlurmRequestsAreRefusedClearlyWithoutAScriptAndForBadValues) {
  Farm& farm = start_farm(0, "slurm_refused");
  test::RunResult r = farm.pd({"workers", "add", "--slurm", "2"});
  EXPECT_EQ(r.exit_code, 2) << r.describe();
  EXPECT_NE(r.err.find("started without --slurm-script"), std::string::npos) << r.describe();
  r = farm.pd({"workers", "add", "--slurm", "2", "--time", "1h"});
  EXPECT_EQ(r.exit_code, 2) << r.describe();
  EXPECT_NE(r.err.find("--time: expected minutes"), std::string::npos) << r.describe();
  r = farm.pd({"workers", "remove", "--slurm", "12;rm"});
  EXPECT_EQ(r.exit_code, 2) << r.describe();
  EXPECT_NE(r.err.find("--slurm: expected a Slurm job id"), std::string::npos) << r.describe();
  r = farm.pd({"workers", "remove", "--slurm", "12"});
  EXPECT_EQ(r.exit_code, 2) << r.describe();
  EXPECT_NE(r.err.find("started without --slurm-script"), std::string::npos) << r.describe();
  // A worker claiming a Slurm job it was never given (any peer can say so in its hello): removing
  // that job is refused and runs no scancel (this scheduler ran `scancel 987654321_7` before).
  farm.add_worker({}, {{"SLURM_ARRAY_JOB_ID", "987654321"}, {"SLURM_ARRAY_TASK_ID", "7"}});
  farm.wait_for_idle_workers(1, 30s);
  r = farm.pd({"workers", "remove", "--slurm", "987654321_7"});
  EXPECT_EQ(r.exit_code, 2) << r.describe();
  EXPECT_NE(r.err.find("started without --slurm-script"), std::string::npos) << r.describe();
  const std::string log = test::read_file_text(farm.scheduler_log());
  EXPECT_NE(log.find("Slurm job 987654321_7"), std::string::npos) << "the worker's hello was not logged";
  EXPECT_EQ(log.find("slurm_cancelled"), std::string::npos) << log;
  EXPECT_EQ(log.find("slurm_error"), std::string::npos) << log;
  const test::RunResult bare = test::run({PD_SCHEDULER_BINARY, "--dir", farm.dir() + "/other", "--slurm-connect",
                                          "tcp://head:7400"},
                                         10s);
  EXPECT_EQ(bare.exit_code, 2) << bare.describe();
  EXPECT_NE(bare.err.find("--slurm-connect: needs --slurm-script"), std::string::npos) << bare.describe();
  EXPECT_FALSE(std::filesystem::exists(farm.dir() + "/other")) << "a refused start left a farm folder";
}

}  // namespace
}  // namespace pd
