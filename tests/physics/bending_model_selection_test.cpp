// The material key "bending_model" (docs/scene-format.md): parsed and checked, and the shell forces of
// a scene, direct and prolonged to a coarse level, use the model it names (physics/
// bending_midedge_fit.h by default, physics/bending_hinge.h on request).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "geometry/shapes.h"
#include "hierarchy/scene_hierarchy.h"
#include "physics/bending_hinge.h"
#include "physics/bending_midedge_fit.h"
#include "progressive/level_task.h"
#include "progressive/scene_system.h"
#include "progressive/test_scenes.h"
#include "scene/scene_test_helpers.h"

namespace pd {
namespace {

TEST(BendingModelKey, DefaultsToMidedgeFitAndParsesBothNames) {
  nlohmann::json s = test::valid_scene();
  EXPECT_EQ(test::parse(s).objects[0].material.bending_model, BendingModel::MidedgeFit);
  s["objects"][0]["material"]["bending_model"] = "hinge";
  EXPECT_EQ(test::parse(s).objects[0].material.bending_model, BendingModel::Hinge);
  s["objects"][0]["material"]["bending_model"] = "midedge_fit";
  EXPECT_EQ(test::parse(s).objects[0].material.bending_model, BendingModel::MidedgeFit);
}

TEST(BendingModelKey, UnknownOrNonStringModelIsAnInputErrorNamingFileAndKey) {
  nlohmann::json s = test::valid_scene();
  s["objects"][0]["material"]["bending_model"] = "hinges";
  test::expect_error(s, {test::kFile, "objects[0].material.bending_model", "unknown bending model",
                         "did you mean 'hinge'?", "\"midedge_fit\""});
  s["objects"][0]["material"]["bending_model"] = 1;
  test::expect_error(s, {test::kFile, "objects[0].material.bending_model", "must be a string"});
}

// The bending term add_shell_forces builds for a sheet whose material asks for `model`.
std::unique_ptr<EnergyTerm> bending_term(BendingModel model) {
  Material mat = test::cotton();
  mat.bending_model = model;
  const SceneObject sheet = test::make_object("sheet", make_rectangle(1.0, 1.0, 4, 4), mat);
  Faces F = sheet.rest.F;
  F.array() += 2;  // the sheet as the second object, after two other vertices
  Positions rest(sheet.rest.num_vertices() + 2, 3);
  rest.topRows(2).setZero();
  rest.bottomRows(sheet.rest.num_vertices()) = sheet.rest.V;
  std::vector<std::unique_ptr<EnergyTerm>> terms;
  add_shell_forces(sheet, F, 2, rest, stacked(rest), terms);
  for (auto& t : terms)
    if (t->name() == "bending") return std::move(t);
  return nullptr;
}

TEST(BendingModelKey, ShellForcesBuildTheMaterialsModelUnderTheSameStatsKey) {
  const auto fit = bending_term(BendingModel::MidedgeFit), hinge = bending_term(BendingModel::Hinge);
  ASSERT_NE(fit, nullptr);
  ASSERT_NE(hinge, nullptr);
  EXPECT_NE(dynamic_cast<const MidedgeFitBending*>(fit.get()), nullptr);
  EXPECT_NE(dynamic_cast<const HingeBending*>(hinge.get()), nullptr);
  // Both read the sheet at its global vertex ids: a bump there costs energy, the two extra vertices
  // before it are not part of it.
  const TriMesh m = make_rectangle(1.0, 1.0, 4, 4);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(3 * (m.num_vertices() + 2));
  x.tail(3 * m.num_vertices()) = stacked(m.V);
  EXPECT_EQ(fit->value(x), 0.0);
  x[3 * (2 + 12) + 2] = 0.05;  // the centre vertex up
  EXPECT_GT(fit->value(x), 0.0);
  EXPECT_GT(hinge->value(x), 0.0);
}

// A two-level run of a hanging sheet: the preview (level 0) steps with the finest level's shell
// terms prolonged onto the coarse mesh, the refinement with them directly; both converge and both
// report the bending energy.
TEST(BendingModelKey, ProlongedPreviewAndRefinementStepWithTheDefaultBending) {
  Scene scene = test::make_scene(0.01, 5, Vec3(0, -9.81, 0));
  SceneObject sheet = test::make_object("sheet", make_rectangle(0.4, 0.4, 12, 12), test::cotton());
  PinGroup top;
  for (int i = 0; i <= 12; ++i) top.vertices.push_back(12 * 13 + i);  // the top row (y = 0.2)
  sheet.pins = {top};
  // Start bent out of its plane so that bending works from the first step.
  for (int v = 0; v < sheet.rest.num_vertices(); ++v) sheet.initial(v, 2) = 0.05 * std::sin(8.0 * sheet.rest.V(v, 0));
  scene.objects.push_back(sheet);
  scene.hierarchy.levels = 2;
  ASSERT_EQ(scene.objects[0].material.bending_model, BendingModel::MidedgeFit);
  const SceneHierarchy h = build_scene_hierarchy(scene);
  std::vector<Eigen::VectorXd> preview;
  int bending_reports = 0;
  const auto record = [&](std::vector<Eigen::VectorXd>& out) {
    return [&](const FrameRecord& r) {
      out.push_back(r.x);
      for (const auto& [key, value] : r.energies) bending_reports += key == "bending" && value > 0.0;
    };
  };
  const LevelTaskReport coarse = solve_level_task(scene, h, {0, 0, 5}, {}, record(preview));
  EXPECT_EQ(coarse.unconverged_steps, 0);
  std::vector<Eigen::VectorXd> fine;
  LevelTaskInputs inputs;
  inputs.below = [&](int t) { return preview.at(static_cast<size_t>(t)); };
  const LevelTaskReport refined = solve_level_task(scene, h, {1, 0, 5}, inputs, record(fine));
  EXPECT_EQ(refined.unconverged_steps, 0);
  ASSERT_EQ(preview.size(), 6u);
  ASSERT_EQ(fine.size(), 6u);
  EXPECT_GE(bending_reports, 10);  // frames 1-5 of both levels
}

}  // namespace
}  // namespace pd
