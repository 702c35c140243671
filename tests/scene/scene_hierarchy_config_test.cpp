// The hierarchy keys of a scene file (scene/scene_hierarchy_config.h): values and defaults, and one
// clear error per bad input, naming the file, the key path, the object and the level.
#include "scene/scene_hierarchy_config.h"

#include <gtest/gtest.h>

#include <array>

#include "scene/scene_test_helpers.h"

namespace pd {
namespace {

using namespace pd::test;  // valid_scene, parse, expect_error (scene_test_helpers.h)

// valid_scene() (a 25-vertex sheet) with a second object, a fixed 8-vertex box obstacle.
json two_objects() {
  json s = valid_scene();
  s["contact"] = {{"dhat", 1e-3}};
  s["objects"].push_back(json::parse(R"({
    "name": "crate", "mesh": {"type": "box", "size": [0.2, 0.2, 0.2], "cells": 1},
    "transform": {"translation": [0, -0.5, 0]}, "obstacle": true})"));
  return s;
}

TEST(SceneHierarchyConfig, OmittedKeysGetTheirDocumentedDefaults) {
  const Scene scene = parse(two_objects());
  EXPECT_EQ(scene.hierarchy.levels, 4);
  EXPECT_EQ(scene.hierarchy.ratio, 4.0);
  for (const SceneObject& obj : scene.objects) {
    EXPECT_TRUE(obj.hierarchy.vertex_counts.empty());
    EXPECT_FALSE(obj.hierarchy.keep_boundary.has_value());
  }
  json s = two_objects();
  s["hierarchy"] = json::object();
  s["objects"][0]["hierarchy"] = json::object();
  const Scene empty_sections = parse(s);
  EXPECT_EQ(empty_sections.hierarchy.levels, 4);
  EXPECT_EQ(empty_sections.hierarchy.ratio, 4.0);
  EXPECT_TRUE(empty_sections.objects[0].hierarchy.vertex_counts.empty());
}

TEST(SceneHierarchyConfig, GivenKeysAreReadForClothAndObstacles) {
  json s = two_objects();
  s["hierarchy"] = json::parse(R"({"levels": 3, "ratio": 2.5})");
  s["objects"][0]["hierarchy"] = json::parse(R"({"vertex_counts": [12, 12], "keep_boundary": true})");
  s["objects"][1]["hierarchy"] = json::parse(R"({"vertex_counts": [8, 8], "keep_boundary": false})");
  const Scene scene = parse(s);
  EXPECT_EQ(scene.hierarchy.levels, 3);
  EXPECT_EQ(scene.hierarchy.ratio, 2.5);
  EXPECT_EQ(scene.objects[0].hierarchy.vertex_counts, (std::vector<int>{12, 12}));
  EXPECT_EQ(scene.objects[0].hierarchy.keep_boundary, std::optional<bool>(true));
  EXPECT_EQ(scene.objects[1].hierarchy.vertex_counts, (std::vector<int>{8, 8}));
  EXPECT_EQ(scene.objects[1].hierarchy.keep_boundary, std::optional<bool>(false));

  // One level: no coarser counts (an empty list is the only valid one).
  s["hierarchy"] = json::parse(R"({"levels": 1})");
  s["objects"][0]["hierarchy"] = json::parse(R"({"vertex_counts": []})");
  s["objects"][1].erase("hierarchy");
  const Scene single = parse(s);
  EXPECT_EQ(single.hierarchy.levels, 1);
  EXPECT_TRUE(single.objects[0].hierarchy.vertex_counts.empty());
}

TEST(SceneHierarchyConfig, BadTopLevelValuesNameTheKey) {
  json s = two_objects();
  s["hierarchy"] = {{"levels", 0}};
  expect_error(s, {"hierarchy.levels", "got 0"});
  s["hierarchy"] = {{"levels", 2.5}};
  expect_error(s, {"hierarchy.levels", "2.5"});
  s["hierarchy"] = {{"levels", 21}};
  expect_error(s, {"hierarchy.levels", "21"});
  s["hierarchy"] = {{"ratio", 1.0}};
  expect_error(s, {"hierarchy.ratio", "must be > 1"});
  s["hierarchy"] = {{"ratio", "four"}};
  expect_error(s, {"hierarchy.ratio"});
  s["hierarchy"] = {{"level", 3}};  // unknown key, with a suggestion
  expect_error(s, {"hierarchy.level", "levels"});
  s["hierarchy"] = 4;
  expect_error(s, {"hierarchy"});
}

TEST(SceneHierarchyConfig, BadObjectValuesNameTheKeyObjectAndLevel) {
  json s = two_objects();
  s["objects"][1]["hierarchy"] = {{"keep_boundary", 1}};
  expect_error(s, {"objects[1].hierarchy.keep_boundary"});
  s["objects"][1]["hierarchy"] = {{"vertex_count", {8, 8, 8}}};
  expect_error(s, {"objects[1].hierarchy.vertex_count", "vertex_counts"});

  // Wrong length: the default 4 levels need 3 counts.
  s["objects"][1]["hierarchy"] = {{"vertex_counts", {8, 8}}};
  expect_error(s, {"objects[1].hierarchy.vertex_counts", "crate", "3 for the scene's 4 levels", "got 2"});
  // Increasing toward the coarsest level.
  s["objects"][0]["hierarchy"] = {{"vertex_counts", {10, 12, 4}}};
  s["objects"][1].erase("hierarchy");
  expect_error(s, {"objects[0].hierarchy.vertex_counts[1]", "level 1", "\"sheet\"", "level 2 (10)", "got 12"});
  // Above the finest count (25).
  s["objects"][0]["hierarchy"] = {{"vertex_counts", {26, 12, 4}}};
  expect_error(s, {"objects[0].hierarchy.vertex_counts[0]", "level 2", "\"sheet\"", "finest mesh (25)", "got 26"});
  // Below 3.
  s["objects"][0]["hierarchy"] = {{"vertex_counts", {20, 12, 2}}};
  expect_error(s, {"objects[0].hierarchy.vertex_counts[2]", "level 0 (coarsest)", "\"sheet\"", "at least 3", "got 2"});
  // Not an integer.
  s["objects"][0]["hierarchy"] = {{"vertex_counts", {20, 12.5, 4}}};
  expect_error(s, {"objects[0].hierarchy.vertex_counts[1]"});
  // Counts checked against the scene's level count when "hierarchy" is given after the objects too.
  s["hierarchy"] = {{"levels", 2}};
  s["objects"][0]["hierarchy"] = {{"vertex_counts", {20, 12}}};
  expect_error(s, {"objects[0].hierarchy.vertex_counts", "1 for the scene's 2 levels"});
}

TEST(SceneHierarchyConfig, GridCoarseningIsReadForRectanglesAndBoxesWithTheirLattices) {
  json s = two_objects();
  s["objects"][0]["hierarchy"] = {{"coarsening", "grid"}};
  s["objects"][1]["hierarchy"] = {{"coarsening", "grid"}};
  s["objects"][0]["transform"] = json::parse(R"({"rotation": {"axis": [1, 0, 0], "angle_deg": -90}})");
  const Scene scene = parse(s);
  EXPECT_TRUE(scene.objects[0].hierarchy.grid_coarsening);
  EXPECT_TRUE(scene.objects[1].hierarchy.grid_coarsening);
  // The lattice comes from the mesh before its transform: vertex (i, j) of the 4 x 4 sheet.
  ASSERT_TRUE(scene.objects[0].grid.has_value());
  EXPECT_EQ(scene.objects[0].grid->cells, (std::array<int, 3>{4, 4, 0}));
  EXPECT_EQ(scene.objects[0].grid->coords[7], (std::array<int, 3>{2, 1, 0}));
  ASSERT_TRUE(scene.objects[1].grid.has_value());
  EXPECT_EQ(scene.objects[1].grid->cells, (std::array<int, 3>{1, 1, 1}));
  EXPECT_EQ(scene.objects[1].grid->coords.size(), 8u);
  s["objects"][0]["hierarchy"] = {{"coarsening", "quadric"}};
  EXPECT_FALSE(parse(s).objects[0].hierarchy.grid_coarsening);
}

TEST(SceneHierarchyConfig, GridCoarseningOfOtherMeshesOrWithCountsNamesTheKeyAndObject) {
  json s = two_objects();
  s["objects"][0]["mesh"] = json::parse(R"({"type": "icosphere", "radius": 0.5, "subdivisions": 1})");
  s["objects"][0]["hierarchy"] = {{"coarsening", "grid"}};
  expect_error(s, {"objects[0].hierarchy.coarsening", "\"rectangle\" or \"box\"", "\"sheet\""});
  s = two_objects();
  s["objects"][0]["hierarchy"] = {{"coarsening", "grid"}, {"vertex_counts", {12, 8, 4}}};
  expect_error(s, {"objects[0].hierarchy.vertex_counts", "left out", "coarsening \"grid\"", "\"sheet\""});
  s["objects"][0]["hierarchy"] = {{"coarsening", "regular"}};
  expect_error(s, {"objects[0].hierarchy.coarsening", "regular"});
}

}  // namespace
}  // namespace pd
