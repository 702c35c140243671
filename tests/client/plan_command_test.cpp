// pd plan, called in-process: plan() reads a frame file written here with chosen solve_seconds
// stats and prints to PlanArgs::out, which the tests point at a string stream.
#include "plan_command.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "store/frame_store.h"
#include "support/input_error_of.h"
#include "support/test_paths.h"

namespace pd::cli {
namespace {

using test::input_error_of;

// One triangle per level: plan reads only stats and done flags.
void add_triangle_level(FrameWriter& w, int level) {
  Positions rest(3, 3);
  rest << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  Faces faces(1, 3);
  faces << 0, 1, 2;
  w.add_level(level, rest, faces, {0, 3}, {"cloth"});
}

void write_frame(FrameWriter& w, int level, int t, double solve_seconds) {
  Positions x(3, 3);
  x << 0, 0, -0.01 * t, 1, 0, 0, 0, 1, 0;
  FrameStats stats;
  stats.scalars = {{"solve_seconds", solve_seconds}, {"newton_iterations", 3.0}};
  w.write_frame(level, t, x, stats);
}

class PlanCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::scratch_dir("plan_command");
    path_ = dir_ + "/run.h5";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // 3 levels, frames 0..10. Frame 0 (the initial state) carries a solve time of 100 s that must not
  // count. Level 0: 0.25 s per step; level 1: 0.5 and 1.5 alternating (mean 1); level 2: 4 s.
  // `solved_levels` levels get frames; the others stay empty.
  void write_run(int solved_levels) {
    FrameWriter w = FrameWriter::create(path_, "{\"name\": \"plan-test\"}", 10);
    for (int l = 0; l < 3; ++l) add_triangle_level(w, l);
    for (int l = 0; l < solved_levels; ++l) {
      write_frame(w, l, 0, 100.0);
      for (int t = 1; t <= 10; ++t) write_frame(w, l, t, l == 0 ? 0.25 : l == 1 ? (t % 2 ? 0.5 : 1.5) : 4.0);
    }
    w.close();
  }

  PlanArgs args(const std::string& workers = "1,2,8") {
    PlanArgs a;
    a.file = path_;
    a.workers = workers;
    a.json = true;
    a.out = &out_;
    return a;
  }

  nlohmann::json run_json(const PlanArgs& a) {
    out_.str("");
    EXPECT_EQ(plan(a), 0);
    return nlohmann::json::parse(out_.str());
  }

  std::string dir_, path_;
  std::ostringstream out_;
};

TEST_F(PlanCommandTest, JsonHasTheMeasuredPerLevelStepCostsOverFramesAfterZero) {
  write_run(3);
  const nlohmann::json j = run_json(args());
  EXPECT_EQ(j["file"], path_);
  EXPECT_EQ(j["frames"], 10);
  EXPECT_EQ(j["levels"], 3);
  EXPECT_EQ(j["subsets"], 1);
  EXPECT_EQ(j["preview_chunk"], 10);
  ASSERT_EQ(j["step_seconds"].size(), 3u);
  EXPECT_DOUBLE_EQ(j["step_seconds"][0].get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(j["step_seconds"][1].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(j["step_seconds"][2].get<double>(), 4.0);
  EXPECT_EQ(j["measured_frames"], nlohmann::json::array({10, 10, 10}));
  EXPECT_EQ(j["vertical_start_assumed"], true);
  EXPECT_DOUBLE_EQ(j["vertical_start_seconds"][1].get<double>(), 2.0);  // 2 x level 1's step
  EXPECT_DOUBLE_EQ(j["vertical_start_seconds"][2].get<double>(), 8.0);
  ASSERT_EQ(j["plans"].size(), 3u);
  // One worker runs everything in turn: 10 x (0.25 + 1 + 4) s, no hierarchy or dispatch cost.
  const nlohmann::json& one = j["plans"][0];
  EXPECT_EQ(one["workers"], 1);
  EXPECT_DOUBLE_EQ(one["makespan_seconds"].get<double>(), 52.5);
  EXPECT_DOUBLE_EQ(one["speedup"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(one["preview_seconds"].get<double>(), 2.5);
  EXPECT_DOUBLE_EQ(one["first_preview_frame_seconds"].get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(one["busy_fraction"].get<double>(), 1.0);
  // Eight workers pipeline the levels (K = 1): level 2 is bound by its own chain of 4 s steps, from
  // level 1's frame 0 at time 0: 40 s.
  const nlohmann::json& eight = j["plans"][2];
  EXPECT_EQ(eight["workers"], 8);
  EXPECT_DOUBLE_EQ(eight["makespan_seconds"].get<double>(), 40.0);
  EXPECT_DOUBLE_EQ(eight["speedup"].get<double>(), 52.5 / 40.0);
  EXPECT_EQ(eight["level_finish_seconds"].size(), 3u);
}

TEST_F(PlanCommandTest, SubsetsAndGivenVerticalStartChangeThePlan) {
  write_run(3);
  PlanArgs a = args("8");
  a.subsets = 5;
  a.vertical_start_seconds = 0.5;
  a.hierarchy_seconds = 1.0;
  a.dispatch_seconds = 0.125;
  const nlohmann::json j = run_json(a);
  EXPECT_EQ(j["subsets"], 5);
  EXPECT_EQ(j["vertical_start_assumed"], false);
  EXPECT_DOUBLE_EQ(j["vertical_start_seconds"][2].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(j["hierarchy_seconds"].get<double>(), 1.0);
  const double split = j["plans"][0]["makespan_seconds"].get<double>();
  a.subsets = 1;
  const double single = run_json(a)["plans"][0]["makespan_seconds"].get<double>();
  EXPECT_LT(split, single);
}

// 40 frames, 2 levels; level 0 jolts at frame 20 (vertex 0 lifted 0.5 m in that frame alone: motion at
// frames 19..21). K = 2: the even split 20 is on the jolt; the seam goes to 23, the nearest frame whose
// s - 1..s + 2 miss it (16 is one farther), as the scheduler would place it.
TEST_F(PlanCommandTest, WithSubsetsTheLevelsAreCutAtTheSeamsPlacedFromTheFilesPreview) {
  {
    FrameWriter w = FrameWriter::create(path_, "{\"name\": \"plan-test\"}", 40);
    for (int l = 0; l < 2; ++l) {
      add_triangle_level(w, l);
      for (int t = 0; t <= 40; ++t) write_frame(w, l, t, 1.0);
    }
    Positions x(3, 3);
    x << 0, 0, -0.01 * 20 + 0.5, 1, 0, 0, 0, 1, 0;
    FrameStats stats;
    stats.scalars = {{"solve_seconds", 1.0}, {"newton_iterations", 3.0}};
    w.write_frame(0, 20, x, stats);
    w.close();
  }
  PlanArgs a = args("2");
  a.subsets = 2;
  const nlohmann::json j = run_json(a);
  ASSERT_EQ(j["seams"].size(), 1u) << j.dump();
  EXPECT_EQ(j["seams"][0]["frame"], 23);
  EXPECT_EQ(j["seams"][0]["even"], 20);
  EXPECT_NE(j["seams"][0]["reason"].get<std::string>().find("moved from the even split 20"), std::string::npos);
  a.subsets = 1;
  EXPECT_TRUE(run_json(a)["seams"].empty());
  a.subsets = 2;
  a.json = false;
  out_.str("");
  ASSERT_EQ(plan(a), 0);
  EXPECT_NE(out_.str().find("seams (placed from the file's level 0"), std::string::npos) << out_.str();
}

TEST_F(PlanCommandTest, OnlyLevelsWithSolvedFramesArePlanned) {
  write_run(2);  // a run whose finest level never ran: level 2 has no frames
  const nlohmann::json j = run_json(args("1"));
  EXPECT_EQ(j["levels"], 2);
  EXPECT_EQ(j["step_seconds"].size(), 2u);
  EXPECT_DOUBLE_EQ(j["plans"][0]["makespan_seconds"].get<double>(), 12.5);
}

TEST_F(PlanCommandTest, TableShowsEveryWorkerCountCostsAndAssumptions) {
  write_run(3);
  PlanArgs a = args("1,32");
  a.json = false;
  ASSERT_EQ(plan(a), 0);
  const std::string text = out_.str();
  EXPECT_NE(text.find("N = 10 frames, 3 level(s)"), std::string::npos) << text;
  EXPECT_NE(text.find("level 1: 1 s (10 frames)"), std::string::npos) << text;
  EXPECT_NE(text.find("ASSUMED 2 x the level's step cost"), std::string::npos) << text;
  EXPECT_NE(text.find("speed-up"), std::string::npos) << text;
  EXPECT_NE(text.find("       1        52.5000      1.00            2.5000"), std::string::npos) << text;
  EXPECT_NE(text.find("      32        40.0000      1.31"), std::string::npos) << text;
}

TEST_F(PlanCommandTest, CommandLineOptionsReachTheArgs) {
  CLI::App app;
  PlanArgs a;
  CLI::App* cmd = add_plan_subcommand(app, a);
  ASSERT_NE(cmd, nullptr);
  app.parse("plan run.h5 --workers 4,16 --vertical-start-seconds 2.5 --subsets 3 --json", false);
  EXPECT_TRUE(*cmd);
  EXPECT_EQ(a.file, "run.h5");
  EXPECT_EQ(a.workers, "4,16");
  ASSERT_TRUE(a.vertical_start_seconds.has_value());
  EXPECT_EQ(*a.vertical_start_seconds, 2.5);
  EXPECT_EQ(a.subsets, 3);
  EXPECT_TRUE(a.json);
}

TEST_F(PlanCommandTest, BadInputIsRefusedNamingTheOptionOrFile) {
  write_run(3);
  PlanArgs a = args();
  a.subsets = 0;
  EXPECT_EQ(input_error_of([&] { plan(a); }), "plan: --subsets: must be >= 1, got 0");
  a = args();
  a.preview_chunk = -1;
  EXPECT_NE(input_error_of([&] { plan(a); }).find("plan: --preview-chunk: must be >= 0"), std::string::npos);
  for (const char* list : {"", "1,x", "0", "2,,4", "8,", "-1", "99999999999"}) {
    a = args(list);
    EXPECT_NE(input_error_of([&] { plan(a); }).find("plan: --workers: "), std::string::npos) << "'" << list << "'";
  }
  a = args();
  a.vertical_start_seconds = -1.0;
  EXPECT_EQ(input_error_of([&] { plan(a); }), "plan: --vertical-start-seconds: must be a finite number >= 0, got -1");
  a = args();
  a.dispatch_seconds = -0.5;
  EXPECT_NE(input_error_of([&] { plan(a); }).find("plan: --dispatch-seconds"), std::string::npos);
  a = args();
  a.file = dir_ + "/missing.h5";
  EXPECT_NE(input_error_of([&] { plan(a); }).find(a.file), std::string::npos);
}

TEST_F(PlanCommandTest, AFileWithoutSolvedFramesIsRefused) {
  write_run(0);
  EXPECT_NE(input_error_of([&] { plan(args()); }).find(path_ + ": plan: no level has a solved frame"),
            std::string::npos);
  FrameWriter w = FrameWriter::create(path_, "{}", 0);  // frame 0 only
  add_triangle_level(w, 0);
  write_frame(w, 0, 0, 1.0);
  w.close();
  EXPECT_NE(input_error_of([&] { plan(args()); }).find("no frame beyond frame 0"), std::string::npos);
}

TEST_F(PlanCommandTest, ALevelWithFramesAboveAnEmptyLevelIsRefused) {
  {
    FrameWriter w = FrameWriter::create(path_, "{}", 4);
    for (int l = 0; l < 3; ++l) add_triangle_level(w, l);
    for (int t = 1; t <= 4; ++t) {
      write_frame(w, 0, t, 1.0);
      write_frame(w, 2, t, 1.0);
    }
    w.close();
  }
  EXPECT_NE(input_error_of([&] { plan(args()); }).find("level 2 has solved frames but level 1 has none"),
            std::string::npos);
}

}  // namespace
}  // namespace pd::cli
