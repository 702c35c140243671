// Every example scene of scenes/ builds its level hierarchy as written (the scene's "hierarchy" keys,
// docs/scene-format.md) and every level's direct prolongation gives back the finest rest shape to
// round-off (HierarchyLevelReport::rest_prolongation_error < 1e-12 * the finest bounding-box
// diagonal). The scenes are listed explicitly; a scene file that is not listed fails the test, so a
// new scene has to be added here. Prints one line per scene with its level vertex counts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "hierarchy/scene_hierarchy.h"
#include "progressive/contact_control.h"
#include "progressive/level_system.h"
#include "scene/scene_file.h"
#include "support/test_paths.h"

namespace pd {
namespace {

const std::vector<std::string> kScenes = {
    "balloon",       "ball-drop", "basket",         "cube-trampoline", "drape-gear",       "drape-sphere",
    "flag",          "hanging-sheet", "self-fold",  "slope-friction",  "spin-sphere",      "strip-cantilever",
};

TEST(SceneHierarchies, EveryExampleSceneIsListed) {
  std::vector<std::string> found;
  for (const auto& e : std::filesystem::directory_iterator(test::source_dir() + "/scenes"))
    if (e.path().extension() == ".json") found.push_back(e.path().stem().string());
  std::sort(found.begin(), found.end());
  std::vector<std::string> listed = kScenes;
  std::sort(listed.begin(), listed.end());
  EXPECT_EQ(found, listed) << "scenes/*.json and kScenes differ: list every scene here";
}

TEST(SceneHierarchies, EveryExampleSceneBuildsItsHierarchyWithExactRestRecovery) {
  for (const std::string& name : kScenes) {
    SCOPED_TRACE(name);
    const Scene scene = load_scene(test::source_dir() + "/scenes/" + name + ".json");
    std::vector<HierarchyLevelReport> report;
    SceneHierarchy h;
    try {
      h = build_scene_hierarchy(scene, &report);
    } catch (const std::exception& e) {
      ADD_FAILURE() << name << ": building the hierarchy failed: " << e.what();
      continue;
    }
    ASSERT_EQ(h.num_levels(), scene.hierarchy.levels);
    ASSERT_EQ(static_cast<int>(report.size()), h.num_levels());
    const Positions& finest = h.levels.back().rest.V;
    const double diagonal = (finest.colwise().maxCoeff() - finest.colwise().minCoeff()).norm();
    std::string counts;
    for (int l = 0; l < h.num_levels(); ++l) {
      const HierarchyLevelReport& r = report[static_cast<size_t>(l)];
      EXPECT_EQ(r.vertices, h.levels[static_cast<size_t>(l)].rest.V.rows()) << "level " << l;
      EXPECT_LT(r.rest_prolongation_error, 1e-12 * diagonal) << "level " << l;
      if (l > 0) {
        EXPECT_GE(r.vertices, report[static_cast<size_t>(l) - 1].vertices) << "level " << l;
      }
      counts += (l ? " / " : "") + std::to_string(r.vertices);
    }
    std::printf("%-17s %d levels, vertices (coarsest to finest): %s\n", name.c_str(), h.num_levels(),
                counts.c_str());
    // A scene that runs progressively must start admissibly on every level (pd simulate checks the
    // same before writing anything): no level's coarse meshes may overlap or cross the offset.
    if (scene.progressive) {
      for (int l = 0; l < h.num_levels(); ++l) {
        EXPECT_NO_THROW(check_start_state(scene_at_level(scene, h, l), build_level_system(scene, h, l)))
            << name << " level " << l;
      }
    }
  }
}

// The benchmark's larger variants (bench/scenes/, too slow to simulate in CI) at least load and
// build their hierarchies, so a key renamed in the scene format cannot break them unnoticed.
TEST(SceneHierarchies, EveryBenchmarkVariantLoadsAndBuildsItsHierarchy) {
  const std::vector<std::string> variants = {"cube-trampoline-large", "cube-trampoline-large-3s", "drape-25k", "flag-large",
                                             "flag-large-10s"};
  std::vector<std::string> found;
  for (const auto& e : std::filesystem::directory_iterator(test::source_dir() + "/bench/scenes"))
    if (e.path().extension() == ".json") found.push_back(e.path().stem().string());
  std::sort(found.begin(), found.end());
  EXPECT_EQ(found, variants) << "bench/scenes/*.json and this list differ";
  for (const std::string& name : variants) {
    SCOPED_TRACE(name);
    const Scene scene = load_scene(test::source_dir() + "/bench/scenes/" + name + ".json");
    const SceneHierarchy h = build_scene_hierarchy(scene);
    EXPECT_EQ(h.num_levels(), scene.hierarchy.levels);
    EXPECT_GT(h.levels.back().rest.V.rows(), 6000);  // the point of a large variant
    std::printf("%-22s %d levels, %d to %d vertices\n", name.c_str(), h.num_levels(),
                static_cast<int>(h.levels.front().rest.V.rows()), static_cast<int>(h.levels.back().rest.V.rows()));
  }
}

}  // namespace
}  // namespace pd
