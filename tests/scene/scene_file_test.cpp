// Scene-file parsing: valid scenes give the right values, every bad input gives one InputError that
// names the file and the JSON key path.
#include "scene/scene_file.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "geometry/obj_io.h"
#include "geometry/shapes.h"
#include "geometry/topology.h"
#include "scene/scene_test_helpers.h"
#include "util/input_error.h"

namespace pd {
namespace {
using namespace pd::test;  // valid_scene, parse, error_of, expect_error (scene_test_helpers.h)

namespace fs = std::filesystem;
using nlohmann::json;

const std::string kScenesDir = std::string(PD_SOURCE_DIR) + "/scenes";  // set by tests/CMakeLists.txt


// ---------------------------------------------------------------------------------------------
// Valid scenes

TEST(SceneFile, FullSceneParsesToTheGivenValues) {
  json s = valid_scene();
  s["name"] = "full";
  s["gravity"] = {0, 0, -9.8};
  s["solver"] = {{"tolerance", 1e-4}, {"max_newton_iterations", 50}, {"hessian_projection", "abs"},
                 {"friction_stopping", "uniform"}};
  s["wind"] = {{"air_velocity", {0, 0, 4}}, {"air_density", 1.25}, {"drag_coefficient", 0.8},
               {"gust_amplitude", 0.5}, {"gust_frequency", 0.7}};
  json& o = s["objects"][0];
  o["mesh"]["cells"] = {2, 2};  // 3 x 3 vertices, vertex (i, j) has index 3 j + i
  o["transform"] = {{"scale", 2.0}, {"rotation", {{"axis", {2, 0, 0}}, {"angle_deg", -90}}}, {"translation", {0, 1, 0}}};
  o["initial_velocity"] = {0.5, 0, 0};
  o["material"]["bending_youngs_modulus"] = 1e5;
  // Transformed, the sheet lies in the plane y = 1 and its top row (j = 2) at z = -1.
  o["pins"] = json::parse(R"([
    {"indices": [3, 0, 3]},
    {"region": {"min": [-5, 0, -1.01], "max": [5, 2, -0.99]},
     "script": {"velocity": [0, 0.1, 0], "angular_velocity": [0, 0, 6.28], "center": [0, 0.5, 0], "start": 0.5, "end": 2}}
  ])");
  o["wind"] = true;
  s["objects"].push_back(json::parse(R"({
    "name": "ball", "mesh": {"type": "icosphere", "radius": 0.5, "subdivisions": 1},
    "material": {"density": 920, "youngs_modulus": 1e5, "poisson_ratio": 0.45, "thickness": 5e-5},
    "pressure": {"model": "ideal_gas", "pressure": 2000}, "wind": false})"));
  const std::string text = s.dump(2);

  Scene scene = parse_scene(text, kFile, "");
  EXPECT_EQ(scene.source_path, kFile);
  EXPECT_EQ(scene.json_text, text);
  EXPECT_EQ(scene.name, "full");
  EXPECT_DOUBLE_EQ(scene.time_step, 0.01);
  EXPECT_EQ(scene.frames, 10);
  EXPECT_TRUE(scene.gravity.isApprox(Vec3(0, 0, -9.8)));
  EXPECT_DOUBLE_EQ(scene.solver.tolerance, 1e-4);
  EXPECT_EQ(scene.solver.max_newton_iterations, 50);
  EXPECT_EQ(scene.solver.projection, HessianProjection::Abs);
  EXPECT_EQ(scene.solver.friction_stopping, FrictionStopping::Uniform);
  ASSERT_TRUE(scene.wind.has_value());
  EXPECT_TRUE(scene.wind->air_velocity.isApprox(Vec3(0, 0, 4)));
  EXPECT_DOUBLE_EQ(scene.wind->air_density, 1.25);
  EXPECT_DOUBLE_EQ(scene.wind->drag_coefficient, 0.8);
  EXPECT_DOUBLE_EQ(scene.wind->gust_amplitude, 0.5);
  EXPECT_DOUBLE_EQ(scene.wind->gust_frequency, 0.7);
  ASSERT_EQ(scene.objects.size(), 2u);

  const SceneObject& sheet = scene.objects[0];
  EXPECT_EQ(sheet.name, "sheet");
  const TriMesh plain = make_rectangle(1.0, 1.0, 2, 2);
  ASSERT_EQ(sheet.rest.num_vertices(), 9);
  EXPECT_EQ(sheet.rest.F, plain.F);
  // x -> R(-90 deg about x) (2 x) + (0, 1, 0): (x, y, 0) -> (2x, 1, -2y).
  for (int i = 0; i < 9; ++i) {
    Vec3 expected(2 * plain.V(i, 0), 1.0, -2 * plain.V(i, 1));
    EXPECT_LT((sheet.rest.V.row(i).transpose() - expected).norm(), 1e-12) << "vertex " << i;
  }
  EXPECT_TRUE(sheet.rest.V.row(0).transpose().isApprox(Vec3(-1, 1, 1)));
  EXPECT_EQ(sheet.initial, sheet.rest.V);
  EXPECT_TRUE(sheet.initial_velocity.isApprox(Vec3(0.5, 0, 0)));
  EXPECT_DOUBLE_EQ(sheet.material.density, 200);
  EXPECT_DOUBLE_EQ(sheet.material.youngs_modulus, 1e6);
  EXPECT_DOUBLE_EQ(sheet.material.poisson_ratio, 0.3);
  EXPECT_DOUBLE_EQ(sheet.material.thickness, 5e-4);
  ASSERT_TRUE(sheet.material.bending_youngs_modulus.has_value());
  EXPECT_DOUBLE_EQ(*sheet.material.bending_youngs_modulus, 1e5);
  ASSERT_EQ(sheet.pins.size(), 2u);
  EXPECT_EQ(sheet.pins[0].vertices, (std::vector<int>{0, 3}));  // sorted, unique
  EXPECT_FALSE(sheet.pins[0].script.has_value());
  EXPECT_EQ(sheet.pins[1].vertices, (std::vector<int>{6, 7, 8}));  // the top row, by region
  ASSERT_TRUE(sheet.pins[1].script.has_value());
  const PinScript& script = *sheet.pins[1].script;
  EXPECT_TRUE(script.velocity.isApprox(Vec3(0, 0.1, 0)));
  EXPECT_TRUE(script.angular_velocity.isApprox(Vec3(0, 0, 6.28)));
  EXPECT_TRUE(script.center.isApprox(Vec3(0, 0.5, 0)));
  EXPECT_DOUBLE_EQ(script.start, 0.5);
  EXPECT_DOUBLE_EQ(script.end, 2.0);
  EXPECT_FALSE(sheet.pressure.has_value());
  EXPECT_TRUE(sheet.wind);

  const SceneObject& ball = scene.objects[1];
  EXPECT_EQ(ball.rest.num_vertices(), 42);
  for (int i = 0; i < 42; ++i) EXPECT_NEAR(ball.rest.V.row(i).norm(), 0.5, 1e-12);
  ASSERT_TRUE(ball.pressure.has_value());
  EXPECT_EQ(ball.pressure->model, Pressure::Model::IdealGas);
  EXPECT_DOUBLE_EQ(ball.pressure->pressure, 2000);
  EXPECT_FALSE(ball.wind);
}

TEST(SceneFile, OmittedOptionalKeysGetTheirDocumentedDefaults) {
  json s = valid_scene();
  s["objects"][0].erase("name");
  Scene scene = parse(s);
  EXPECT_EQ(scene.name, "test-scene");  // the file name without folder and extension
  EXPECT_TRUE(scene.gravity.isApprox(Vec3(0, -9.81, 0)));
  EXPECT_FALSE(scene.wind.has_value());
  EXPECT_DOUBLE_EQ(scene.solver.tolerance, 1e-3);
  EXPECT_EQ(scene.solver.max_newton_iterations, 200);
  EXPECT_EQ(scene.solver.friction_stopping, FrictionStopping::Contacts);
  EXPECT_EQ(scene.solver.projection, HessianProjection::ExactFirst);
  const SceneObject& o = scene.objects.at(0);
  EXPECT_EQ(o.name, "object_0");
  EXPECT_EQ(o.rest.V, make_rectangle(1.0, 1.0, 4, 4).V);  // identity transform
  EXPECT_EQ(o.initial, o.rest.V);
  EXPECT_EQ(o.initial_velocity, Vec3::Zero());
  EXPECT_FALSE(o.material.bending_youngs_modulus.has_value());
  EXPECT_TRUE(o.pins.empty());
  EXPECT_FALSE(o.pressure.has_value());
  EXPECT_TRUE(o.wind);

  s["wind"] = {{"air_velocity", {1, 0, 0}}};
  Scene windy = parse(s);
  ASSERT_TRUE(windy.wind.has_value());
  EXPECT_DOUBLE_EQ(windy.wind->air_density, 1.2);
  EXPECT_DOUBLE_EQ(windy.wind->drag_coefficient, 1.0);
  EXPECT_DOUBLE_EQ(windy.wind->gust_amplitude, 0.0);
  EXPECT_DOUBLE_EQ(windy.wind->gust_frequency, 0.0);
}

TEST(SceneFile, MaterialPresetFillsCoreKeysAndExplicitKeysOverrideIt) {
  json s = valid_scene();
  s["objects"][0]["material"] = {{"preset", "cotton"}, {"thickness", 1e-3}};
  const Material m = parse(s).objects.at(0).material;
  EXPECT_DOUBLE_EQ(m.density, 472.6);
  EXPECT_DOUBLE_EQ(m.youngs_modulus, 8.21e5);
  EXPECT_DOUBLE_EQ(m.poisson_ratio, 0.243);
  EXPECT_DOUBLE_EQ(m.thickness, 1e-3);
  EXPECT_FALSE(m.bending_youngs_modulus.has_value());
}

TEST(SceneFile, BendingRigidityUsesBendingModulusWhenGivenElseYoungsModulus) {
  Material m;
  m.youngs_modulus = 1e6;
  m.poisson_ratio = 0.3;
  m.thickness = 2e-3;
  EXPECT_NEAR(m.bending_rigidity(), 1e6 * 8e-9 / (12 * 0.91), 1e-15);
  m.bending_youngs_modulus = 1e4;
  EXPECT_NEAR(m.bending_rigidity(), 1e4 * 8e-9 / (12 * 0.91), 1e-17);
}

TEST(SceneFile, EveryMeshTypeBuildsAValidMesh) {
  const char* meshes[] = {
      R"({"type": "rectangle_equilateral", "size": [1.0, 0.5], "cells_x": 4})",
      R"({"type": "box", "size": [1, 2, 3], "cells": 2})",
      R"({"type": "cylinder", "radius": 0.2, "height": 1, "segments": 12, "rings": 3, "capped": true})",
      R"({"type": "cylinder", "radius": 0.2, "height": 1, "segments": 12, "rings": 3})"};
  const int vertices[] = {16, 26, 50, 48};
  for (int k = 0; k < 4; ++k) {
    json s = valid_scene();
    s["objects"][0]["mesh"] = json::parse(meshes[k]);
    Scene scene = parse(s);
    EXPECT_EQ(scene.objects.at(0).rest.num_vertices(), vertices[k]) << meshes[k];
  }
}

TEST(SceneFile, GearAndCupObstaclesParseAndBadKeysAreNamed) {
  // The sheet drapes over a gear and falls into a cup: both fixed obstacles.
  json s = valid_scene();
  s["contact"] = {{"dhat", 1e-3}};
  s["objects"].push_back(json::parse(R"({"name": "gear", "obstacle": true,
    "mesh": {"type": "gear", "radius": 0.3, "root_radius": 0.25, "teeth": 10, "thickness": 0.05},
    "transform": {"translation": [0, -2, 0]}})"));
  s["objects"].push_back(json::parse(R"({"name": "cup", "obstacle": true,
    "mesh": {"type": "cup", "radius": 0.4, "height": 0.3, "segments": 16, "rings": 2},
    "transform": {"translation": [0, -3, 0]}})"));
  const Scene scene = parse(s);
  ASSERT_EQ(scene.objects.size(), 3u);
  EXPECT_TRUE(scene.objects[1].obstacle);
  EXPECT_EQ(scene.objects[1].rest.num_vertices(), 8 * 10 + 2);
  EXPECT_EQ(scene.objects[1].rest.num_faces(), 16 * 10);
  EXPECT_TRUE(build_topology(scene.objects[1].rest).closed());
  EXPECT_TRUE(scene.objects[2].obstacle);
  EXPECT_EQ(scene.objects[2].rest.num_vertices(), 16 * 3 + 1);
  EXPECT_EQ(scene.objects[2].rest.num_faces(), 2 * 16 * 2 + 16);

  // Each bad value is reported at its own key path.
  struct Case { const char* pointer; const char* value; const char* message; };
  const Case cases[] = {
      {"/objects/1/mesh/root_radius", "0.3", "objects[1].mesh.root_radius: must be < radius (0.3), got 0.3"},
      {"/objects/1/mesh/root_radius", "0.5", "objects[1].mesh.root_radius: must be < radius (0.3), got 0.5"},
      {"/objects/1/mesh/teeth", "2", "objects[1].mesh.teeth: must be an integer from 3"},
      {"/objects/1/mesh/segments", "8", "objects[1].mesh.segments: unknown key"},
      {"/objects/2/mesh/capped", "true", "objects[2].mesh.capped: unknown key"},
      {"/objects/2/mesh/rings", "0", "objects[2].mesh.rings: must be an integer from 1"}};
  for (const Case& c : cases) {
    json bad = s;
    bad[json::json_pointer(c.pointer)] = json::parse(c.value);
    expect_error(bad, {c.message});
  }
  json missing = s;
  missing["objects"][1]["mesh"].erase("root_radius");
  expect_error(missing, {"objects[1].mesh.root_radius: required key is missing"});
}

TEST(SceneFile, RectangleDiagonalPatternIsReadAndUnknownPatternsAreRejected) {
  json s = valid_scene();
  s["objects"][0]["mesh"]["diagonals"] = "rows";
  const TriMesh rows = parse(s).objects.at(0).rest;
  const TriMesh expected = make_rectangle(1.0, 1.0, 4, 4, GridDiagonals::Rows);
  EXPECT_EQ(rows.F, expected.F);
  EXPECT_NE(parse(valid_scene()).objects.at(0).rest.F, expected.F) << "default stays checkerboard";
  s["objects"][0]["mesh"]["diagonals"] = "diagonal";
  const std::string msg = error_of([&] { parse(s); });
  EXPECT_EQ(msg.rfind(kFile + ":", 0), 0u) << msg;
  EXPECT_NE(msg.find("objects[0].mesh.diagonals"), std::string::npos) << msg;
  EXPECT_NE(msg.find("\"rows\""), std::string::npos) << msg;
}

TEST(SceneFile, InitialPositionsAreReadFromObjAndTransformedLikeTheRestMesh) {
  TempDir dir;
  TriMesh rest = make_rectangle(1.0, 1.0, 1, 1);
  Positions posed = rest.V;
  posed(3, 2) = 0.25;  // lift one corner
  write_obj(dir.path() + "/posed.obj", posed, rest.F);
  json s = valid_scene();
  s["objects"][0]["mesh"]["cells"] = {1, 1};
  s["objects"][0]["initial_positions"] = {{"obj", "posed.obj"}};
  s["objects"][0]["transform"] = {{"translation", {0, 0, 1}}};
  const SceneObject o = parse(s, dir.path()).objects.at(0);
  EXPECT_NEAR(o.rest.V(3, 2), 1.0, 1e-12);
  EXPECT_NEAR(o.initial(3, 2), 1.25, 1e-12);
  EXPECT_NEAR(o.initial(0, 2), 1.0, 1e-12);
}

TEST(SceneFile, LoadSceneResolvesObjPathsAgainstTheSceneFolder) {
  TempDir dir;
  dir.write("meshes/tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  json s = valid_scene();
  s["objects"][0]["mesh"] = {{"type", "obj"}, {"path", "meshes/tri.obj"}};
  const std::string path = dir.write("shot.json", s.dump(2));
  Scene scene = load_scene(path);
  EXPECT_EQ(scene.source_path, path);
  EXPECT_EQ(scene.objects.at(0).rest.num_faces(), 1);
}

TEST(SceneFile, LoadSceneReportsAMissingSceneFile) {
  const std::string message = error_of([] { load_scene("/nonexistent/shot.json"); });
  EXPECT_NE(message.find("/nonexistent/shot.json: cannot open"), std::string::npos) << message;
}

// ---------------------------------------------------------------------------------------------
// Example scenes in scenes/

TEST(ExampleScenes, HangingSheetLoadsPinnedAtItsTwoTopCornersWithWind) {
  Scene scene = load_scene(kScenesDir + "/hanging-sheet.json");
  ASSERT_EQ(scene.objects.size(), 1u);
  const SceneObject& sheet = scene.objects[0];
  EXPECT_EQ(sheet.rest.num_vertices(), 21 * 21);
  EXPECT_TRUE(scene.wind.has_value());
  EXPECT_NEAR(scene.time_step * scene.frames, 2.0, 1e-9);
  std::vector<int> pinned;
  for (const PinGroup& g : sheet.pins) pinned.insert(pinned.end(), g.vertices.begin(), g.vertices.end());
  std::sort(pinned.begin(), pinned.end());
  EXPECT_EQ(pinned, (std::vector<int>{420, 440}));  // top-left and top-right corners
}

TEST(ExampleScenes, StripCantileverIsInTheSmallDeflectionRegime) {
  Scene scene = load_scene(kScenesDir + "/strip-cantilever.json");
  ASSERT_EQ(scene.objects.size(), 1u);
  const SceneObject& strip = scene.objects[0];
  const Material& m = strip.material;
  // Clamped: two columns of vertices pinned at the minimum-x end; free length from the second column.
  const double x_min = strip.rest.V.col(0).minCoeff(), x_max = strip.rest.V.col(0).maxCoeff();
  ASSERT_EQ(strip.pins.size(), 1u);
  double x_clamp = x_min;
  for (int v : strip.pins[0].vertices) x_clamp = std::max(x_clamp, strip.rest.V(v, 0));
  const double L = x_max - x_clamp;
  EXPECT_NEAR(L, 0.2, 1e-9);
  // Uniform load q = rho t g; tip deflection q L^4 / (8 D) with D = E t^3 / 12 (nu = 0).
  EXPECT_EQ(m.poisson_ratio, 0.0);
  const double q = m.density * m.thickness * scene.gravity.norm();
  const double tip = q * std::pow(L, 4) / (8.0 * m.bending_rigidity());
  EXPECT_GT(tip / L, 0.005);
  EXPECT_LT(tip / L, 0.02);
}

TEST(ExampleScenes, BalloonIsAClosedRubberShellWithIdealGasAndNoGravity) {
  Scene scene = load_scene(kScenesDir + "/balloon.json");
  ASSERT_EQ(scene.objects.size(), 1u);
  const SceneObject& balloon = scene.objects[0];
  EXPECT_EQ(scene.gravity, Vec3::Zero());
  EXPECT_TRUE(build_topology(balloon.rest).closed());
  ASSERT_TRUE(balloon.pressure.has_value());
  EXPECT_EQ(balloon.pressure->model, Pressure::Model::IdealGas);
  EXPECT_GT(balloon.pressure->pressure, 0.0);
}

TEST(ExampleScenes, EverySceneOfTheRepositoryLoadsWithinTheLimits) {
  // scenes/ and bench/scenes/, every folder below them: the limits of docs/scene-format.md must
  // leave every shipped scene valid.
  int loaded = 0;
  for (const char* folder : {"/scenes", "/bench/scenes"}) {
    for (const auto& e : fs::recursive_directory_iterator(std::string(PD_SOURCE_DIR) + folder)) {
      if (e.path().extension() != ".json") continue;
      EXPECT_NO_THROW(load_scene(e.path().string())) << e.path();
      ++loaded;
    }
  }
  EXPECT_GE(loaded, 20);
}

// ---------------------------------------------------------------------------------------------
// Bad inputs: one InputError naming the file and the key path

TEST(SceneFileErrors, MalformedJsonReportsLineAndColumn) {
  const std::string text = "{\n  \"format_version\": 1,\n  \"time_step\": 0.01,\n  \"frames\": ,\n  \"objects\": []\n}\n";
  expect_text_error(text, {kFile + ":4:13:", "invalid JSON", "unexpected ','"});
}

TEST(SceneFileErrors, AValidSceneFollowedByANulByteAndGarbageIsRefusedWhereTheNulIs) {
  const std::string scene = valid_scene().dump();  // one line
  std::string text = scene;
  text += std::string(1, '\0') + "{garbage";
  expect_text_error(text, {kFile + ":1:" + std::to_string(scene.size() + 1) + ":", "a NUL byte"});
}

TEST(SceneFileErrors, NumberTooLargeForADoubleReportsLineAndColumn) {
  expect_text_error("{\"format_version\": 1,\n \"time_step\": 1e400}", {kFile + ":2:15:", "1e400"});
}

TEST(SceneFileErrors, DuplicateJsonKeyIsReportedAtItsPath) {
  json s = valid_scene();
  std::string text = s.dump(2);
  text.replace(text.find("\"thickness\""), 0, "\"thickness\": 1e-3, ");
  expect_text_error(text, {"objects[0].material.thickness", "duplicate key"});
}

TEST(SceneFileErrors, UnknownKeySuggestsTheNearestKnownKey) {
  json s = valid_scene();
  s["objects"][0]["material"]["thicknes"] = 1e-3;
  expect_error(s, {"objects[0].material.thicknes", "unknown key", "did you mean 'thickness'?"});
}

TEST(SceneFileErrors, UnknownKeyFarFromAnyKnownKeyListsTheAllowedKeys) {
  json s = valid_scene();
  s["colour"] = "red";
  expect_error(s, {": colour: unknown key", "time_step", "objects"});
}

TEST(SceneFileErrors, MissingRequiredKeyIsNamed) {
  json s = valid_scene();
  s.erase("time_step");
  expect_error(s, {": time_step: required key is missing"});
  s = valid_scene();
  s["objects"][0]["material"].erase("density");
  expect_error(s, {"objects[0].material.density: required key is missing"});
}

TEST(SceneFileErrors, WrongTypeIsNamedWithTheValue) {
  json s = valid_scene();
  s["time_step"] = "fast";
  expect_error(s, {"time_step: must be a number", "got \"fast\""});
  s = valid_scene();
  s["gravity"] = {0, -9.81};
  expect_error(s, {"gravity: must be an array of 3 numbers", "got [0,-9.81]"});
}

TEST(SceneFileErrors, FormatVersionMissingOrUnsupported) {
  json s = valid_scene();
  s.erase("format_version");
  expect_error(s, {"format_version: required key is missing", "format_version 1"});
  s["format_version"] = 2;
  expect_error(s, {"format_version: unsupported value", "got 2"});
}

TEST(SceneFileErrors, NegativeThicknessIsRejected) {
  json s = valid_scene();
  s["objects"][0]["material"]["thickness"] = -0.001;
  expect_error(s, {"objects[0].material.thickness: must be from 1e-07 to 1 m, got -0.001"});
}

TEST(SceneFileErrors, PoissonRatioOfOneHalfIsRejected) {
  json s = valid_scene();
  s["objects"][0]["material"]["poisson_ratio"] = 0.5;
  expect_error(s, {"objects[0].material.poisson_ratio: must be >= 0 and < 0.5, got 0.5"});
}

TEST(SceneFileErrors, FractionalFramesAreRejected) {
  json s = valid_scene();
  s["frames"] = 2.5;
  expect_error(s, {"frames: must be an integer", "got 2.5"});
  s["frames"] = 0;
  expect_error(s, {"frames: must be an integer from 1", "got 0"});
}

TEST(SceneFileErrors, OutOfRangeSettingsAreRejected) {
  struct Case { const char* pointer; const char* value; const char* key_path; };
  const Case cases[] = {{"/time_step", "0", "time_step"},
                        {"/solver/tolerance", "-1", "solver.tolerance"},
                        {"/solver/max_newton_iterations", "0", "solver.max_newton_iterations"},
                        {"/objects/0/mesh/cells/0", "0", "objects[0].mesh.cells[0]"},
                        {"/objects/0/transform/scale", "0", "objects[0].transform.scale"},
                        {"/objects/0/material/density", "0", "objects[0].material.density"},
                        {"/objects/0/material/youngs_modulus", "-5", "objects[0].material.youngs_modulus"}};
  for (const Case& c : cases) {
    json s = valid_scene();
    s[json::json_pointer(c.pointer)] = json::parse(c.value);
    expect_error(s, {std::string(c.key_path) + ": must be", std::string("got ") + c.value});
  }
}

TEST(SceneFileErrors, MeshResolutionBeyondTheVertexLimitIsRejected) {
  json s = valid_scene();
  s["objects"][0]["mesh"]["cells"] = {5000, 5000};
  expect_error(s, {"objects[0].mesh.cells: gives 25010001 vertices", "limit"});
}

TEST(SceneFileErrors, UnknownChoicesListTheAllowedValues) {
  json s = valid_scene();
  s["objects"][0]["mesh"]["type"] = "rectangel";
  expect_error(s, {"objects[0].mesh.type: unknown mesh type, did you mean 'rectangle'?", "\"icosphere\"",
                   "\"cup\"", "\"gear\"", "\"obj\""});
  s = valid_scene();
  s["solver"] = {{"hessian_projection", "project"}};
  expect_error(s, {"solver.hessian_projection: unknown Hessian projection", "\"none\", \"clamp\", \"abs\""});
  s = valid_scene();
  s["solver"] = {{"friction_stopping", "everywhere"}};
  expect_error(s, {"solver.friction_stopping: unknown friction stopping rule", "\"contacts\", \"uniform\""});
  s = valid_scene();
  s["objects"][0]["pressure"] = {{"model", "van_der_waals"}, {"pressure", 10}};
  expect_error(s, {"objects[0].pressure.model: unknown pressure model", "\"constant\", \"ideal_gas\""});
}

TEST(SceneFileErrors, ZeroRotationAxisIsRejected) {
  json s = valid_scene();
  s["objects"][0]["transform"] = {{"rotation", {{"axis", {0, 0, 0}}, {"angle_deg", 30}}}};
  expect_error(s, {"objects[0].transform.rotation.axis: must be a non-zero vector"});
}

TEST(SceneFileErrors, DuplicateObjectNamesAreRejected) {
  json s = valid_scene();
  s["objects"].push_back(s["objects"][0]);
  expect_error(s, {"objects[1].name: duplicate object name \"sheet\"", "objects[0]"});
}

TEST(SceneFileErrors, MissingObjFileIsReportedWithTheKeyPath) {
  TempDir dir;
  json s = valid_scene();
  s["objects"][0]["mesh"] = {{"type", "obj"}, {"path", "meshes/missing.obj"}};
  expect_error(s, {"objects[0].mesh.path: ", "missing.obj", "cannot open"}, dir.path());
}

TEST(SceneFileErrors, DegenerateObjFaceIsRejected) {
  TempDir dir;
  // Face 2 1 4 has collinear corners: zero area.
  dir.write("flat.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.5 0 0\nf 1 2 3\nf 2 1 4\n");
  json s = valid_scene();
  s["objects"][0]["mesh"] = {{"type", "obj"}, {"path", "flat.obj"}};
  expect_error(s, {kFile + ": objects[0].mesh: ", "zero area"}, dir.path());
}

TEST(SceneFileErrors, NonManifoldObjIsRejected) {
  TempDir dir;
  // Edge 1-2 is shared by three triangles.
  dir.write("fin.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n");
  json s = valid_scene();
  s["objects"][0]["mesh"] = {{"type", "obj"}, {"path", "fin.obj"}};
  expect_error(s, {kFile + ": objects[0].mesh: ", "manifold"}, dir.path());
}

TEST(SceneFileErrors, InitialPositionsWithWrongVertexCountAreRejected) {
  TempDir dir;
  dir.write("posed.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  json s = valid_scene();
  s["objects"][0]["initial_positions"] = {{"obj", "posed.obj"}};
  expect_error(s, {"objects[0].initial_positions.obj: has 3 vertices but the rest mesh has 25", "same connectivity"},
               dir.path());
}

TEST(SceneFileErrors, PressureOnAnOpenRectangleIsRejected) {
  json s = valid_scene();
  s["objects"][0]["pressure"] = {{"model", "constant"}, {"pressure", 100}};
  expect_error(s, {"objects[0].pressure: needs a closed mesh", "16 boundary edges"});
}

TEST(SceneFileErrors, PressureOnAnInwardOrientedShellIsRejected) {
  // An octahedron whose faces all wind inward: closed and manifold, but its volume is negative.
  TempDir dir;
  dir.write("inward.obj",
            "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n"
            "f 1 5 3\nf 3 5 2\nf 2 5 4\nf 4 5 1\nf 3 6 1\nf 2 6 3\nf 4 6 2\nf 1 6 4\n");
  json s = valid_scene();
  s["objects"][0]["mesh"] = {{"type", "obj"}, {"path", "inward.obj"}};
  s["objects"][0]["pressure"] = {{"model", "ideal_gas"}, {"pressure", 100}};
  expect_error(s, {"objects[0].pressure: needs outward-oriented faces", "-1.333333333 m^3"}, dir.path());
}

TEST(SceneFileErrors, EmptyPinRegionIsRejected) {
  json s = valid_scene();
  s["objects"][0]["pins"] = json::parse(R"([{"region": {"min": [2, 2, 2], "max": [3, 3, 3]}}])");
  expect_error(s, {"objects[0].pins[0].region: selects no vertex", "[-0.5, -0.5, 0] to [0.5, 0.5, 0]"});
}

TEST(SceneFileErrors, BadPinsAreRejected) {
  const std::pair<const char*, const char*> cases[] = {
      {R"([{"indices": [0, 25]}])", "objects[0].pins[0].indices[1]: vertex index out of range: the mesh has 25 vertices"},
      {R"([{"indices": []}])", "objects[0].pins[0].indices: must list at least one vertex index"},
      {R"([{"region": {"min": [0, 1, 0], "max": [1, 0, 1]}}])", "objects[0].pins[0].region: min must be <= max"},
      {R"([{"indices": [0], "script": {"start": 2, "end": 1}}])", "objects[0].pins[0].script.end: must be > start (2), got 1"},
      {R"([{"indices": [0, 1]}, {"indices": [1]}])", "objects[0].pins[1]: vertex 1 is already pinned by objects[0].pins[0]"},
      {R"([{"script": {}}])", "objects[0].pins[0]: needs \"indices\" or \"region\""}};
  for (const auto& [pins, expected] : cases) {
    json s = valid_scene();
    s["objects"][0]["pins"] = json::parse(pins);
    expect_error(s, {expected});
  }
}

TEST(SceneFileErrors, ObjectWindWithoutSceneWindIsRejected) {
  json s = valid_scene();
  s["objects"][0]["wind"] = true;
  expect_error(s, {"objects[0].wind: is true but the scene has no top-level \"wind\" section"});
}

}  // namespace
}  // namespace pd
