// A job of 15 000 frames on one worker: the farm's flow control of the frames of the level below.
//
// With one worker the preview chain runs first (lowest level first), so the refinement task is
// assigned when all 15 001 preview frames are stored. It once got them all in one burst: past
// ZeroMQ's high-water mark (1 000 messages) the sends failed, the scheduler took its own full queue
// for the worker's silence and dropped the worker, re-assigned the task and burst again (3 drops in
// 4 s). Now it is sent a window of frames that each frame report moves on (scheduler.h,
// kFeedWindow). Checked: the job ends done with every frame of both levels stored; no worker is
// lost, no send fails and no task is attempted twice; the refinement task was assigned after the
// last preview frame was stored (so the test reached the case it is for).
//
// The scene is a 7 x 7 sheet pinned at two corners, swinging in gravity: a solve costs little, so
// the time is the farm's own per-frame work (about 1-3 ms of scheduler CPU per stored frame).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "support/farm.h"

namespace pd {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

constexpr int kFrames = 15000;

std::string write_scene(const std::string& dir) {
  const json scene = {
      {"format_version", 1},
      {"name", "long-swing"},
      {"time_step", 0.01},
      {"frames", kFrames},
      {"mode", "progressive"},
      {"hierarchy", {{"levels", 2}}},
      {"objects",
       {{{"name", "sheet"},
         {"mesh", {{"type", "rectangle"}, {"size", {0.3, 0.3}}, {"cells", {6, 6}}}},
         {"material", {{"preset", "cotton"}}},
         {"pins",
          {{{"region", {{"min", {-0.16, 0.14, -0.01}}, {"max", {-0.14, 0.16, 0.01}}}}},
           {{"region", {{"min", {0.14, 0.14, -0.01}}, {"max", {0.16, 0.16, 0.01}}}}}}}}}}};
  const std::string path = dir + "/long-swing.json";
  std::ofstream(path) << scene.dump(2);
  return path;
}

class LongJob : public test::FarmTest {};

TEST_F(LongJob, AFifteenThousandFrameRefinementIsFedWithFlowControlAndNoWorkerIsDropped) {
  test::Farm& farm = start_farm(1, "long_job");
  const int64_t job = test::submit(farm, {write_scene(farm.dir()), "--levels", "2"});
  test::wait_until_done(farm, job, 600s);

  const json status = test::job_status(farm, job);
  EXPECT_EQ(status.at("state"), "done");
  ASSERT_EQ(status.at("levels").size(), 2u) << status.dump();
  for (const json& l : status.at("levels")) {
    EXPECT_EQ(l.at("frames_total"), kFrames + 1) << l.dump();
    EXPECT_EQ(l.at("frames_done"), kFrames + 1) << l.dump();
  }
  int refinement_task = 0;
  for (const json& t : status.at("tasks")) {
    EXPECT_EQ(t.at("attempts"), 1) << t.dump();
    if (t.at("kind") == "level" && t.at("level") == 1) refinement_task = t.at("id").get<int>();
  }
  ASSERT_NE(refinement_task, 0) << status.dump();

  const std::string log = farm.scheduler_log();
  EXPECT_TRUE(test::log_events(log, "worker_lost").empty());
  EXPECT_TRUE(test::log_events(log, "send_failed").empty());
  EXPECT_TRUE(test::log_events(log, "task_released").empty());

  // The case under test: the refinement task was assigned once the preview's last frame was stored.
  double last_preview_frame = 0.0, refinement_assigned = 0.0;
  int preview_frames_logged = 0;
  for (const json& e : test::log_events(log, "frame_stored")) {
    if (e.at("message").get<std::string>().rfind("level 0 frame ", 0) != 0) continue;
    ++preview_frames_logged;
    last_preview_frame = std::max(last_preview_frame, e.at("time").get<double>());
  }
  for (const json& e : test::log_events(log, "task_assigned"))
    if (e.at("task") == refinement_task) refinement_assigned = e.at("time").get<double>();
  EXPECT_EQ(preview_frames_logged, kFrames + 1);
  EXPECT_GT(refinement_assigned, last_preview_frame) << "the refinement started before the preview ended";
}

}  // namespace
}  // namespace pd
