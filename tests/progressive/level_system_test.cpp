// Level systems of a progressive run (progressive/level_system.h): a scene moved to a coarser level,
// the two-level special case where the coarse level is the finest mesh itself (the preview must then
// be direct simulation), and a coarse preview that feels the finest level's stiffness.
#include "progressive/level_system.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include "geometry/shapes.h"
#include "hierarchy/grid_coarsening.h"
#include "progressive/test_scenes.h"

namespace pd {
namespace {

// A 0.4 m cotton sheet hanging from its two top corners (rows of 9 vertices), in the x-y plane.
Scene hanging_sheet(int frames) {
  Scene s = test::make_scene(0.01, frames, Vec3(0, -9.81, 0));
  SceneObject sheet = test::make_object("sheet", make_rectangle(0.4, 0.4, 8, 8), test::cotton());
  PinGroup corners;
  for (int v = 0; v < sheet.rest.num_vertices(); ++v)
    if (sheet.rest.V(v, 1) > 0.199 && std::abs(sheet.rest.V(v, 0)) > 0.199) corners.vertices.push_back(v);
  EXPECT_EQ(corners.vertices.size(), 2u);
  sheet.pins.push_back(corners);
  s.objects.push_back(sheet);
  s.hierarchy.levels = 2;
  return s;
}

TEST(LevelSystem, SceneAtLevelCarriesPinsAndAPosedStartToTheLevelsVertices) {
  Scene scene = hanging_sheet(1);
  // A posed start: every vertex shifted by a position-dependent amount.
  SceneObject& obj = scene.objects[0];
  for (int v = 0; v < obj.initial.rows(); ++v) obj.initial(v, 2) += 0.1 * obj.rest.V(v, 0);
  obj.grid = lattice_of(obj.rest.V, {8, 8, 0});  // as the reader gives a rectangle; quadric coarsening
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const Scene coarse = scene_at_level(scene, h, 0);
  const Level& lv = h.objects[0].levels[0];
  ASSERT_EQ(coarse.objects[0].rest.num_vertices(), static_cast<int>(lv.to_finest.size()));
  ASSERT_LT(coarse.objects[0].rest.num_vertices(), obj.rest.num_vertices());
  for (std::size_t i = 0; i < lv.to_finest.size(); ++i) {
    const int f = lv.to_finest[i];
    const Vec3 moved = coarse.objects[0].initial.row(static_cast<Eigen::Index>(i)) - lv.mesh.V.row(static_cast<Eigen::Index>(i));
    EXPECT_EQ(moved, Vec3(obj.initial.row(f) - obj.rest.V.row(f)));
  }
  ASSERT_EQ(coarse.objects[0].pins[0].vertices.size(), 2u);
  for (int v : coarse.objects[0].pins[0].vertices)
    EXPECT_EQ(coarse.objects[0].rest.V.row(v), obj.rest.V.row(lv.to_finest[static_cast<std::size_t>(v)]));
  // The lattice describes the finest mesh only.
  EXPECT_FALSE(coarse.objects[0].grid.has_value());
  EXPECT_TRUE(scene_at_level(scene, h, 1).objects[0].grid.has_value());
  EXPECT_EQ(scene_at_level(scene, h, 1).objects[0].rest.V, obj.rest.V);  // the finest level is the scene
  EXPECT_THROW(scene_at_level(scene, h, 2), std::invalid_argument);
  EXPECT_THROW(scene_at_level(scene, h, -1), std::invalid_argument);
}

// When the coarsest level is the finest mesh itself (vertex_counts = the finest count), P is the
// identity and the preview is direct simulation (issue 5's two-level special case).
TEST(LevelSystem, PreviewOfASheetThatIsItsOwnCoarsestLevelEqualsDirectSimulation) {
  Scene scene = hanging_sheet(20);
  scene.objects[0].hierarchy.vertex_counts = {scene.objects[0].rest.num_vertices()};
  const SceneHierarchy h = build_scene_hierarchy(scene);
  ASSERT_EQ(h.levels[0].rest.V.rows(), h.levels[1].rest.V.rows());
  SceneSystem preview = build_level_system(scene, h, 0);
  ASSERT_TRUE(preview.prolongation);
  SceneSystem direct = build_scene_system(scene);
  const Eigen::VectorXd xp = test::run_scene(scene, preview), xd = test::run_scene(scene, direct);
  // The level-0 ids are the decimation's; map them to the finest mesh's to compare.
  const std::vector<int>& to_finest = h.levels[0].to_finest;
  double diff = 0.0, sag = 0.0;
  for (std::size_t i = 0; i < to_finest.size(); ++i) {
    diff = std::max(diff, (xp.segment<3>(3 * static_cast<Eigen::Index>(i)) - xd.segment<3>(3 * to_finest[i])).norm());
    sag = std::max(sag, (xd.segment<3>(3 * to_finest[i]) - direct.x0.segment<3>(3 * to_finest[i])).norm());
  }
  std::printf("[identity preview] max |preview - direct| = %.3g m after 20 steps (largest motion %.3g m)\n", diff, sag);
  EXPECT_GT(sag, 1e-3);  // it did move (measured 1.6 mm: the sheet hangs in its own plane)
  EXPECT_LT(diff, 1e-9);
}

// A coarse preview carries the finest level's elasticity: its energies at the rest state are zero
// (no ghost forces from the coarse discretisation) and the membrane and bending it reports are the
// finest mesh's.
TEST(LevelSystem, CoarsePreviewReportsTheFinestLevelsEnergiesAndStartsWithoutGhostForces) {
  Scene scene = hanging_sheet(1);
  scene.gravity = Vec3::Zero();
  const SceneHierarchy h = build_scene_hierarchy(scene);
  for (const ProlongedHessian mode : {ProlongedHessian::Galerkin, ProlongedHessian::Coarse}) {
    SceneSystem sys = build_level_system(scene, h, 0, {mode});
    LevelStepper stepper(sys, scene.solver, scene.time_step);
    Eigen::VectorXd x = sys.x0, v = sys.v0;
    const FrameRecord r = stepper.step(0, x, v);
    EXPECT_TRUE(r.newton.converged);
    EXPECT_LT((x - sys.x0).cwiseAbs().maxCoeff(), 1e-12);  // nothing moves it
    bool membrane = false, bending = false;
    for (const auto& [name, value] : r.energies) {
      membrane = membrane || name == "membrane";
      bending = bending || name == "bending";
      if (name == "membrane" || name == "bending") {
        EXPECT_LT(std::abs(value), 1e-12) << name;
      }
    }
    EXPECT_TRUE(membrane && bending);
  }
}

// "auto" (no Hessian named) is coarse-first on the preview and lagged on the levels between: the
// first assembly of a step gives, bit for bit, the matrix of the mode named explicitly, and the two
// modes' matrices differ there (so the comparison can tell them apart).
TEST(LevelSystem, AutoHessianIsCoarseFirstForThePreviewAndLaggedForTheLevelsBetween) {
  Scene scene = hanging_sheet(1);
  scene.hierarchy.levels = 3;
  const SceneHierarchy h = build_scene_hierarchy(scene);
  ASSERT_EQ(h.finest(), 2);
  // The first assembly of a step at a bent state (the rest state's Hessians are too alike).
  auto first_assembly = [&](int level, std::optional<ProlongedHessian> mode) {
    LevelSystemOptions options;
    options.hessian = mode;
    SceneSystem sys = build_level_system(scene, h, level, options);
    Eigen::VectorXd x = sys.x0;
    for (Eigen::Index i = 0; i < x.size(); i += 3) x[i + 2] += 0.05 * std::sin(7.0 * x[i]) * x[i + 1];
    StepStart start;
    start.h = scene.time_step;
    start.time_end = scene.time_step;
    start.x = &sys.x0;
    start.v = &sys.v0;
    sys.ip.begin_step(start);
    HessianAssembly H;
    sys.ip.hessian(x, HessianProjection::Clamp, H);
    return Eigen::MatrixXd(H.finish(nullptr));
  };
  EXPECT_EQ(auto_prolonged_hessian(0), ProlongedHessian::CoarseFirst);
  EXPECT_EQ(auto_prolonged_hessian(1), ProlongedHessian::Lagged);
  for (int level : {0, 1}) {
    const Eigen::MatrixXd automatic = first_assembly(level, std::nullopt);
    const Eigen::MatrixXd coarse_first = first_assembly(level, ProlongedHessian::CoarseFirst);
    const Eigen::MatrixXd lagged = first_assembly(level, ProlongedHessian::Lagged);
    EXPECT_GT((coarse_first - lagged).norm(), 1e-6 * lagged.norm()) << "level " << level;
    EXPECT_EQ(automatic, level == 0 ? coarse_first : lagged) << "level " << level;
  }
}

TEST(LevelSystem, LevelHessianNamesAreAutoOrAProlongedHessianAndAnythingElseIsRefusedNamingTheWords) {
  EXPECT_EQ(parse_level_hessian("auto"), std::nullopt);
  EXPECT_EQ(parse_level_hessian("lagged"), ProlongedHessian::Lagged);
  EXPECT_EQ(parse_level_hessian("coarse-first"), ProlongedHessian::CoarseFirst);
  // Every listed name parses (the list feeds pd's --hessian validator and the error message).
  ASSERT_EQ(level_hessian_names().size(), 5u);
  for (const std::string& name : level_hessian_names()) EXPECT_NO_THROW(parse_level_hessian(name)) << name;
  try {
    parse_level_hessian("Auto");
    ADD_FAILURE() << "\"Auto\" was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'Auto': use auto, galerkin, lagged, coarse or coarse-first"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace pd
