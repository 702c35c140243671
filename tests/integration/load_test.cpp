// The farm's load program (bench/farm_load.cpp, pd_bench_farm_load) against a real pd-scheduler,
// briefly: 100 simulated workers for a 10 s window at 100 frames/s, with refinement jobs (so frames
// of the level below are forwarded too). Checked: the program exits 0; every simulated worker is
// still connected at the end and none lost its lease (by the program's count, the scheduler's
// worker list and the scheduler's log); nothing was refused; every job it submitted ended done with
// every frame stored (by the program's check and by `pd status`). No timing is asserted: the
// figures are measured with bench/farm_load.sh and reported in docs/performance.md.
#include <gtest/gtest.h>

#include <chrono>
#include <string>

#include <nlohmann/json.hpp>

#include "support/farm.h"
#include "support/process.h"

namespace pd {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

constexpr int kWorkers = 100;
constexpr int kFrames = 30;  // per job: frames 0..30 of each of the scene's 3 levels
constexpr int kLevels = 3;   // scenes/slope-friction.json's hierarchy.levels

class LoadTest : public test::FarmTest {};

double wall_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

TEST_F(LoadTest, HundredSimulatedWorkersStayConnectedAndEveryJobEndsDone) {
  test::FarmOptions options;
  options.workers = 0;  // the load program brings its own
  test::Farm& farm = start_farm(options, "load");
  // 12 unfinished jobs of 11 tasks (hierarchy, 6 preview chunks, 2 x 2 refinement subsets) and 93
  // frames each: a few hundred tasks over the run, drained in seconds at 100 frames/s.
  const test::RunResult r = test::run({PD_LOAD_BINARY, "--workers-endpoint", farm.workers_endpoint(),
                                       "--clients-endpoint", farm.clients(), "--workers", std::to_string(kWorkers),
                                       "--threads", "1", "--seconds", "10", "--warmup", "3", "--rate", "100",
                                       "--scene", test::scene_path("slope-friction.json"), "--frames",
                                       std::to_string(kFrames), "--subsets", "2", "--preview-chunk", "5", "--jobs",
                                       "12", "--submit-rate", "10", "--drain-seconds", "120", "--scheduler-pid",
                                       std::to_string(farm.scheduler().pid()), "--scheduler-log",
                                       farm.scheduler_log()},
                                      300s);
  // The simulated workers' sockets are closed now: the scheduler drops them 3 heartbeats later.
  const double ended = wall_now();
  ASSERT_EQ(r.exit_code, 0) << r.describe();
  const json j = test::parse_json(r);

  EXPECT_EQ(j.at("connected_at_end"), kWorkers) << r.out;
  EXPECT_EQ(j.at("leases_lost"), 0) << r.out;
  EXPECT_EQ(j.at("scheduler_silences"), 0) << r.out;
  EXPECT_EQ(j.at("workers_listed_lost"), 0) << r.out;
  EXPECT_EQ(j.at("log_worker_lost"), 0) << r.out;
  EXPECT_EQ(j.at("refused"), 0) << r.out;
  const int64_t submitted = j.at("jobs_submitted").get<int64_t>();
  EXPECT_GE(submitted, 12) << r.out;
  EXPECT_EQ(j.at("jobs_done"), submitted) << r.out;
  EXPECT_EQ(j.at("frames_expected"), submitted * kLevels * (kFrames + 1)) << r.out;
  EXPECT_EQ(j.at("frames_stored"), j.at("frames_expected")) << r.out;
  EXPECT_GE(j.at("frames_sent").get<int64_t>(), j.at("frames_stored").get<int64_t>()) << r.out;
  EXPECT_GT(j.at("rtt_ms").at("samples").get<int64_t>(), 0) << r.out;

  // The scheduler's own view, apart from the program's: every job done, every level complete.
  const json status = test::parse_json(farm.pd({"status", "--json"}));
  int64_t jobs = 0, levels_checked = 0;
  for (const json& job : status.at("jobs")) {
    ++jobs;
    EXPECT_EQ(job.at("state"), "done") << "job " << job.at("id");
    ASSERT_EQ(job.at("levels").size(), static_cast<std::size_t>(kLevels)) << "job " << job.at("id");
    for (const json& level : job.at("levels")) {
      EXPECT_EQ(level.at("frames_done"), kFrames + 1) << "job " << job.at("id") << " level " << level.at("level");
      EXPECT_EQ(level.at("frames_total"), kFrames + 1);
      ++levels_checked;
    }
  }
  EXPECT_EQ(jobs, submitted);
  EXPECT_EQ(levels_checked, submitted * kLevels);

  // Every simulated worker joined once, and none was lost before the program ended.
  EXPECT_EQ(test::log_events(farm.scheduler_log(), "worker_joined").size(), static_cast<std::size_t>(kWorkers));
  int lost_during_run = 0;
  for (const json& e : test::log_events(farm.scheduler_log(), "worker_lost"))
    lost_during_run += e.at("time").get<double>() < ended;
  EXPECT_EQ(lost_during_run, 0);
}

}  // namespace
}  // namespace pd
