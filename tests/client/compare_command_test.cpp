// pd compare's vertex distance between levels that are not the finest (client/compare_command.cpp);
// the command's other measures and its input errors are tested in pd_cli_test.cpp.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

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

}  // namespace
}  // namespace pd
