// The example scenes run progressively (progressive/level_task.h), as `pd simulate --mode
// progressive` runs them: every frame of every level passes the independent CGAL intersection check,
// and the levels follow the preview where direct simulation at the same resolutions does not.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <vector>

#include "progressive/consistency.h"
#include "progressive/level_task.h"
#include "store/frame_store.h"
#include "scene/scene_file.h"
#include "support/intersection_checker.h"
#include "support/test_paths.h"

namespace pd {
namespace {

struct LevelRun {
  std::map<int, Eigen::VectorXd> x;
  std::map<int, ObjectPoints> com;
  int intersecting = 0;  // frames the CGAL checker rejects
};

// Solves `level` over all frames (progressive from `below`, or direct when below is null and
// `direct` is set), checking each frame as it comes.
LevelRun solve(const Scene& scene, const SceneHierarchy& h, int level, const LevelRun* below, bool direct) {
  LevelRun run;
  LevelTaskInputs in;
  if (below) in.below = [below](int t) { return below->x.at(t); };
  LevelTaskOptions opt;
  opt.system.direct = direct;
  const Faces& F = h.levels[static_cast<std::size_t>(level)].rest.F;
  const LevelTaskReport r = solve_level_task(scene, h, {level, 0, scene.frames}, in, [&](const FrameRecord& f) {
    run.x[f.frame] = f.x;
    run.com[f.frame] = f.center_of_mass;
    if (!test::intersection_free(as_rows(f.x), F)) ++run.intersecting;
  }, opt);
  EXPECT_EQ(r.unconverged_steps, 0) << "level " << level;
  return run;
}

// max over frames of the summed distance between the simulated objects' centres of mass (m).
double max_com_deviation(const Scene& scene, const LevelRun& a, const LevelRun& b) {
  std::vector<char> obstacle;
  for (const SceneObject& o : scene.objects) obstacle.push_back(o.obstacle ? 1 : 0);
  double worst = 0.0;
  for (const auto& [t, com] : a.com) worst = std::max(worst, com_distance(com, b.com.at(t), obstacle));
  return worst;
}

// scenes/cube-trampoline.json as it is (three levels, 2 s): a stiff box dropped on a pinned rubber
// sheet. Progressive levels stay together; direct simulation of the coarsest and the finest meshes
// drift apart (the coarse sheet is stiffer: it locks).
TEST(ProgressiveScenes, CubeOnTrampolineLevelsFollowThePreviewWhereDirectSimulationDoesNot) {
  const Scene scene = load_scene(test::source_dir() + "/scenes/cube-trampoline.json");
  ASSERT_EQ(scene.hierarchy.levels, 3);
  ASSERT_GE(scene.frames * scene.time_step, 2.0 - 1e-9);
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const LevelRun p0 = solve(scene, h, 0, nullptr, false);
  const LevelRun p1 = solve(scene, h, 1, &p0, false);
  const LevelRun p2 = solve(scene, h, 2, &p1, false);
  const LevelRun d0 = solve(scene, h, 0, nullptr, true);
  const LevelRun d2 = solve(scene, h, 2, nullptr, true);
  for (const LevelRun* r : {&p0, &p1, &p2, &d0, &d2}) EXPECT_EQ(r->intersecting, 0);
  const double progressive = max_com_deviation(scene, p0, p2), direct = max_com_deviation(scene, d0, d2);
  std::printf("[cube-trampoline] max centre-of-mass deviation, coarsest vs finest: progressive %.4g m, direct "
              "%.4g m (%.1fx); progressive level 1 vs finest %.4g m\n",
              progressive, direct, direct / progressive, max_com_deviation(scene, p1, p2));
  // Measured: progressive 8.9 mm, direct 173 mm (19x).
  EXPECT_LT(5.0 * progressive, direct);
}

}  // namespace
}  // namespace pd
