// pd compare's vertex distance between levels that are not the finest, and its seam pop on frame
// files with known motion (client/compare_command.cpp); the command's other measures and its input
// errors are tested in pd_cli_test.cpp.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "store/frame_store.h"
#include "support/process.h"
#include "support/test_paths.h"

namespace pd {
namespace {

test::RunResult pd(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {test::pd_binary()};
  argv.insert(argv.end(), args.begin(), args.end());
  return test::run(argv, std::chrono::minutes(2));
}

// slope-friction (192 finest vertices, 3 levels), 2 frames: a preview with the lagged Galerkin
// Hessian, one with the coarse stand-in (the same equations to tolerance, other iterates: frames that
// differ a little), and a direct run of the finest mesh.
class CompareCommand : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = test::scratch_dir("compare_command");
    const std::string scene = test::source_dir() + "/scenes/slope-friction.json";
    for (const char* hessian : {"lagged", "coarse"}) {
      const test::RunResult r = pd({"simulate", scene, "--mode", "progressive", "--preview-only", "--frames", "2",
                                    "--quiet", "--hessian", hessian, "--out", dir_ + "/" + hessian + ".h5"});
      ASSERT_EQ(r.exit_code, 0) << r.describe();
    }
    const test::RunResult r = pd({"simulate", scene, "--mode", "direct", "--frames", "2", "--quiet", "--out",
                                  dir_ + "/finest.h5"});
    ASSERT_EQ(r.exit_code, 0) << r.describe();
  }
  static std::string dir_;
};
std::string CompareCommand::dir_;

TEST_F(CompareCommand, TwoPreviewsOfOneSceneGetAVertexDistanceOnTheirOwnMesh) {
  const test::RunResult r = pd({"compare", dir_ + "/lagged.h5", dir_ + "/coarse.h5", "--json", "--csv",
                                dir_ + "/previews.csv"});
  ASSERT_EQ(r.exit_code, 0) << r.describe();
  const nlohmann::json j = nlohmann::json::parse(r.out.substr(0, r.out.find('\n')), nullptr, false);
  ASSERT_TRUE(j.is_object()) << r.describe();
  EXPECT_EQ(j["reference"]["level"], 0);
  ASSERT_EQ(j["levels"].size(), 2u);
  const nlohmann::json& coarse = j["levels"][1];
  EXPECT_FALSE(coarse.contains("vertex_distance_note")) << coarse.dump();
  ASSERT_TRUE(coarse["vertex_distance_m"].is_object()) << coarse.dump();
  const double max = coarse["vertex_distance_m"]["max"].get<double>();
  // Two solves to the same tolerance: apart, but by far less than the 0.5 m sheet.
  EXPECT_GT(max, 0.0);
  EXPECT_LT(max, 1e-2);
  // The vertex distance on one mesh is at least the Hausdorff distance of the same surfaces.
  EXPECT_GE(max, coarse["hausdorff_m"]["max"].get<double>() * (1.0 - 1e-12));
}

TEST_F(CompareCommand, AVertexDistanceThatCannotBeMeasuredShowsItsReasonInTheTable) {
  // The reference is the preview's level 0; the direct run's finest mesh is another mesh.
  const test::RunResult r = pd({"compare", dir_ + "/lagged.h5", dir_ + "/finest.h5", "--csv", dir_ + "/mixed.csv"});
  ASSERT_EQ(r.exit_code, 0) << r.describe();
  EXPECT_EQ(r.out.find("nan"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("n/a"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(dir_ + "/finest.h5 level 0: vertex distance: its mesh ("), std::string::npos) << r.out;
}

// ---- --seams: the seam pop (docs/progressive.md, "Error measures") ------------------------------------

// The cloth's second differences are multiples of a = 2^-10 m per frame^2 by dyadic factors, so
// that every position, m(t), peak and pop below is exact in binary.
constexpr double kA = 1.0 / 1024;

// One level, frames 0..60: a cloth triangle moving along z with second difference -f(t) a in frame t
// (f = 1, free fall, unless `f` says otherwise: m(t) = f(t) a), and an obstacle triangle that jumps
// 1 m up and down every frame (m would be 2 m per frame^2 were it not left out). `gap`: frame 45 is
// not stored (m(44), m(45), m(46) are undefined).
void write_run(const std::string& path, const std::map<int, double>& f, bool gap) {
  const char* scene = R"({"name": "seams", "time_step": 0.01, "objects": [{"name": "cloth"},
                        {"name": "post", "obstacle": true}]})";
  FrameWriter w = FrameWriter::create(path, scene, 60);
  Positions rest(6, 3);
  rest << 0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 0, 0, 3, 0, 0, 2, 1, 0;
  Faces faces(2, 3);
  faces << 0, 1, 2, 3, 4, 5;
  w.add_level(0, rest, faces, {0, 3, 6}, {"cloth", "post"});
  std::vector<double> z(61, 0.0);
  for (int t = 1; t < 60; ++t) z[t + 1] = 2.0 * z[t] - z[t - 1] - (f.count(t) ? f.at(t) : 1.0) * kA;
  for (int t = 0; t <= 60; ++t) {
    if (gap && t == 45) continue;
    Positions x = rest;
    x.topRows(3).col(2).array() += z[t];
    x.bottomRows(3).col(2).array() += t % 2;
    FrameStats stats;
    stats.center_of_mass.resize(2, 3);
    stats.center_of_mass.row(0) = x.topRows(3).colwise().mean();
    stats.center_of_mass.row(1) = x.bottomRows(3).colwise().mean();
    w.write_frame(0, t, x, stats);
  }
  w.close();
}

// one.h5: the K = 1 run, calm at frames 10 and 11 (m = a / 8); other.h5: the run with subsets, calm
// there too (3 a / 8), with a jolt at seam 30 (5 a) and a smaller one at seam 50 (5 a / 4), and
// without frame 45.
class CompareSeams : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = test::scratch_dir("compare_seams");
    write_run(dir_ + "/one.h5", {{10, 0.125}, {11, 0.125}}, false);
    write_run(dir_ + "/other.h5", {{10, 0.375}, {11, 0.375}, {30, 5.0}, {50, 1.25}}, true);
  }
  static nlohmann::json compare_json(const std::vector<std::string>& args) {
    std::vector<std::string> argv = {"compare"};
    argv.insert(argv.end(), args.begin(), args.end());
    for (const std::string& a : {std::string("--json"), std::string("--csv"), dir_ + "/c.csv"}) argv.push_back(a);
    const test::RunResult r = pd(argv);
    EXPECT_EQ(r.exit_code, 0) << r.describe();
    return nlohmann::json::parse(r.out.substr(0, r.out.find('\n')), nullptr, false);
  }
  static std::string one() { return dir_ + "/one.h5"; }
  static std::string other() { return dir_ + "/other.h5"; }
  static std::string dir_;
};
std::string CompareSeams::dir_;

// The CSV's max_second_difference_m_per_frame2 cell (its last column) of file `file`, frame t.
std::string second_difference_cell(const std::string& csv_path, const std::string& file, int t) {
  std::ifstream csv(csv_path);
  std::string line;
  while (std::getline(csv, line))
    if (line.rfind(file + ",0," + std::to_string(t) + ",", 0) == 0) return line.substr(line.rfind(',') + 1);
  return "(no row)";
}

TEST_F(CompareSeams, OneFileGivesItsLevelsPopsWithoutABaselineOrJitter) {
  const nlohmann::json j = compare_json({other(), "--seams", "30"});
  ASSERT_TRUE(j.is_object());
  EXPECT_TRUE(j["seam_jitter"].is_null()) << j["seam_jitter"];
  ASSERT_TRUE(j["seam_pop"].is_array()) << j.dump();
  ASSERT_EQ(j["seam_pop"].size(), 1u);
  const nlohmann::json& level = j["seam_pop"][0];
  EXPECT_EQ(level["file"], other());
  EXPECT_EQ(level["level"], 0);
  EXPECT_EQ(level["units"], "m per frame^2 (no division by h^2)");
  EXPECT_EQ(level["visible_seams"], 0);
  ASSERT_EQ(level["seams"].size(), 1u);
  const nlohmann::json& s = level["seams"][0];
  EXPECT_EQ(s["seam"], 30);
  EXPECT_EQ(s["peak_m"], 5 * kA);  // the cloth's; the obstacle's 2 m per frame^2 is left out
  // [10, 51] without 30, 31 and 44, 45, 46 (frame 45 missing): 35 values a and two 3 a / 8 (frames
  // 10, 11); the nearest rank ceil(0.95 * 37) - 1 = 35 is an a.
  EXPECT_EQ(s["background_m"], kA);
  EXPECT_EQ(s["background_frames"], 37);
  EXPECT_EQ(s["pop"], 5.0);
  EXPECT_TRUE(s["baseline_pop"].is_null());
  EXPECT_EQ(s["visible"], false);
  ASSERT_EQ(j["seam_pop_notes"].size(), 1u) << j["seam_pop_notes"];
  EXPECT_NE(j["seam_pop_notes"][0].get<std::string>().find("no K = 1 baseline"), std::string::npos);
  // The CSV column: m(t) where frames t - 1, t and t + 1 are stored, empty elsewhere.
  std::ifstream csv(dir_ + "/c.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header.substr(header.rfind(',') + 1), "max_second_difference_m_per_frame2") << header;
  EXPECT_EQ(std::stod(second_difference_cell(dir_ + "/c.csv", other(), 30)), 5 * kA);
  EXPECT_EQ(std::stod(second_difference_cell(dir_ + "/c.csv", other(), 31)), kA);
  for (const int t : {0, 44, 46, 60}) EXPECT_EQ(second_difference_cell(dir_ + "/c.csv", other(), t), "") << t;
  // Without --seams: no seam_pop, an empty column.
  const nlohmann::json plain = compare_json({other()});
  EXPECT_TRUE(plain.contains("seam_pop") && plain["seam_pop"].is_null()) << plain.dump();
  EXPECT_EQ(second_difference_cell(dir_ + "/c.csv", other(), 30), "");
}

TEST_F(CompareSeams, TwoFilesJudgeEachSeamOfOtherAgainstTheK1RunsPop) {
  const nlohmann::json j = compare_json({one(), other(), "--seams", "0,10,30,50"});
  ASSERT_TRUE(j.is_object());
  ASSERT_EQ(j["seam_pop"].size(), 1u) << j["seam_pop"];  // OTHER's levels only
  const nlohmann::json& level = j["seam_pop"][0];
  EXPECT_EQ(level["file"], other());
  ASSERT_EQ(level["seams"].size(), 4u);
  const nlohmann::json &s0 = level["seams"][0], &s10 = level["seams"][1], &s30 = level["seams"][2],
                       &s50 = level["seams"][3];
  // Every seam's frames (0, 1, 10, 11, 30, 31, 50, 51) are left out of every background, and each
  // run's background counts its own stored frames (other.h5 lacks 44..46).
  // Seam 0: the peak is m(1) = a; the background frames 2..21 without 10, 11.
  EXPECT_EQ(s0["seam"], 0);
  EXPECT_EQ(s0["peak_m"], kA);
  EXPECT_EQ(s0["background_frames"], 18);
  EXPECT_EQ(s0["pop"], 1.0);
  EXPECT_EQ(s0["visible"], false);
  // Seam 10: 3/8 is above 1.5 times the K = 1 run's 1/8, but not above 0.5: not visible.
  EXPECT_EQ(s10["pop"], 0.375);
  EXPECT_EQ(s10["baseline_pop"], 0.125);
  EXPECT_EQ(s10["visible"], false);
  // Seam 30 pops: 5 against the K = 1 run's 1, over [10, 51].
  EXPECT_EQ(s30["peak_m"], 5 * kA);
  EXPECT_EQ(s30["background_m"], kA);
  EXPECT_EQ(s30["pop"], 5.0);
  EXPECT_EQ(s30["baseline_pop"], 1.0);
  EXPECT_EQ(s30["background_frames"], 33);
  EXPECT_EQ(s30["visible"], true);
  // Seam 50: 1.25 is above 0.5 and above the baseline, but not above 1.5 times it: not visible.
  EXPECT_EQ(s50["pop"], 1.25);
  EXPECT_EQ(s50["baseline_pop"], 1.0);
  EXPECT_EQ(s50["background_frames"], 23);  // [30, 59] without 30, 31, 50, 51 and 44..46
  EXPECT_EQ(s50["visible"], false);
  EXPECT_EQ(level["visible_seams"], 1);
  for (const nlohmann::json& s : level["seams"]) EXPECT_FALSE(s.contains("visible_note")) << s;
  EXPECT_TRUE(j["seam_pop_notes"].empty()) << j["seam_pop_notes"];
  // The jitter keeps its seams 1..N-1: seam 0 is left out with a note.
  ASSERT_EQ(j["seam_jitter"].size(), 1u) << j["seam_jitter"];
  EXPECT_EQ(j["seam_jitter"][0]["seams"], nlohmann::json::array({10, 11, 30, 31, 50, 51}));
  ASSERT_EQ(j["seam_jitter_notes"].size(), 1u);
  EXPECT_NE(j["seam_jitter_notes"][0].get<std::string>().find("seam 0"), std::string::npos);

  const test::RunResult text = pd({"compare", one(), other(), "--seams", "0,30", "--csv", dir_ + "/c.csv"});
  ASSERT_EQ(text.exit_code, 0) << text.describe();
  EXPECT_NE(text.out.find("seam pop level 0 (" + other() + "): seam 0 pop 1 (K=1 1), seam 30 pop 5 (K=1 1) "
                          "VISIBLE; 1 of 2 visible\n"),
            std::string::npos) << text.out;
}

TEST_F(CompareSeams, ASeamWhosePopIsUndefinedOnEitherSideIsNotVisibleAndSaysWhy) {
  // Seam 44, with other.h5 (no frame 45: m(44) and m(45) undefined, no peak) as the K = 1 run, then
  // as the run judged.
  const nlohmann::json j = compare_json({other(), one(), "--seams", "44"});
  ASSERT_TRUE(j.is_object());
  const nlohmann::json& s = j["seam_pop"][0]["seams"][0];
  EXPECT_EQ(s["pop"], 1.0);
  EXPECT_TRUE(s["baseline_pop"].is_null());
  EXPECT_EQ(s["baseline_pop_note"], "undefined: m is not defined at s or s + 1");
  EXPECT_EQ(s["visible"], false);
  EXPECT_EQ(s["visible_note"], "not judged: the K = 1 pop is undefined");
  const nlohmann::json k = compare_json({one(), other(), "--seams", "44"});
  ASSERT_TRUE(k.is_object());
  const nlohmann::json& t = k["seam_pop"][0]["seams"][0];
  EXPECT_TRUE(t["pop"].is_null());
  EXPECT_EQ(t["pop_note"], "undefined: m is not defined at s or s + 1");
  EXPECT_EQ(t["baseline_pop"], 1.0);
  EXPECT_EQ(t["visible"], false);
  EXPECT_EQ(t["visible_note"], "not judged: the pop is undefined");
}

TEST_F(CompareSeams, BadSeamsExitWith2NamingTheFileAndOption) {
  for (const auto& [args, file] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{one(), "--seams", "60"}, one()},              // s + 1 = 61 is not a frame
           {{one(), other(), "--seams", "30,x"}, other()},  // not a number
           {{one(), other(), "--seams", "30,60"}, other()}}) {
    std::vector<std::string> argv = {"compare"};
    argv.insert(argv.end(), args.begin(), args.end());
    argv.insert(argv.end(), {"--csv", dir_ + "/bad.csv"});
    const test::RunResult r = pd(argv);
    EXPECT_EQ(r.exit_code, 2) << r.describe();
    EXPECT_EQ(r.err.rfind("pd: error: " + file + ": --seams: ", 0), 0u) << r.describe();
  }
}

}  // namespace
}  // namespace pd
