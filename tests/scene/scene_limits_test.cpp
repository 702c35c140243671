// Scene-file limits (docs/scene-format.md, "Limits"): hostile documents (deep nesting, huge files,
// long strings, NUL bytes), every physical number outside its range, scripted speeds, mesh sizes and
// scene files that are not regular files. Each bad input gives one InputError naming file and key.
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <random>
#include <string>
#include <thread>
#include <utility>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "geometry/obj_io.h"
#include "geometry/shapes.h"
#include "scene/scene_file.h"
#include "scene/scene_test_helpers.h"
#include "util/input_error.h"

namespace pd {
namespace {
using namespace pd::test;  // valid_scene, parse, error_of, expect_error (scene_test_helpers.h)

namespace fs = std::filesystem;
using nlohmann::json;


// ---------------------------------------------------------------------------------------------
// The document: limits checked before the JSON tree is built

std::string nested_arrays(int depth) { return std::string(depth, '[') + std::string(depth, ']'); }
std::string nested_objects(int depth) {
  std::string text;
  for (int i = 0; i < depth; ++i) text += "{\"a\":";
  return text + "1" + std::string(depth, '}');
}
// valid_scene() with `value` (raw JSON text) as the value of `key`.
std::string scene_with_raw(const std::string& key, const std::string& value) {
  json s = valid_scene();
  s[key] = "@@";
  std::string text = s.dump();
  text.replace(text.find("\"@@\""), 4, value);
  return text;
}

TEST(SceneFileLimits, NestingOf100000ArraysOrObjectsIsRefusedAtTopLevelAndInsideValues) {
  // These used to crash (stack overflow in the JSON library's recursive dump() when the error message
  // described the value). Each is refused at the line and column where nesting passes 64.
  expect_text_error(nested_arrays(100000), {kFile + ":1:65:", "nested deeper than 64 levels"});
  expect_text_error(nested_objects(100000), {kFile + ":1:", "nested deeper than 64 levels"});
  for (const char* key : {"time_step", "description", "objects"}) {
    expect_text_error(scene_with_raw(key, nested_arrays(100000)), {kFile + ":1:", "nested deeper than 64"});
    expect_text_error(scene_with_raw(key, nested_objects(100000)), {kFile + ":1:", "nested deeper than 64"});
  }
}

TEST(SceneFileLimits, NestingUpToTheLimitReachesTheKeyChecks) {
  // The root object is level 1, so a value may hold 63 levels; brackets inside strings do not count.
  expect_text_error(scene_with_raw("description", nested_arrays(63)), {": description: must be a string"});
  expect_text_error(scene_with_raw("description", nested_arrays(64)), {"nested deeper than 64"});
  json s = valid_scene();
  s["description"] = std::string(1000, '[') + std::string(500, '{');
  EXPECT_NO_THROW(parse(s));
}

TEST(SceneFileLimits, DocumentOver16MiBIsRefusedBeforeParsing) {
  json s = valid_scene();
  std::string text = s.dump();
  text.insert(1, std::size_t{16} << 20, ' ');  // whitespace: valid JSON, just too big
  expect_text_error(text, {kFile + ": the scene file has 16777", "more than the limit of 16777216"});
  TempDir dir;
  const std::string path = dir.write("big.json", text);
  const std::string message = error_of([&] { load_scene(path); });
  EXPECT_NE(message.find(path + ": the scene file has"), std::string::npos) << message;
}

TEST(SceneFileLimits, LongStringsAreRefusedWithShortMessages) {
  // Any string over 64 KiB, at its position; the message does not echo it.
  json s = valid_scene();
  s["description"] = std::string(70000, 'd');
  std::string message = error_of([&] { parse(s); });
  EXPECT_NE(message.find("string of 70000 bytes is longer than the limit of 65536"), std::string::npos) << message;
  EXPECT_LT(message.size(), 200u) << message;
  // Names over 256 bytes, paths over 4096.
  s = valid_scene();
  s["objects"][0]["name"] = std::string(300, 'n');
  expect_error(s, {"objects[0].name: is 300 bytes long, more than the limit of 256", "...\"(300 chars)"});
  s = valid_scene();
  s["name"] = std::string(257, 'n');
  expect_error(s, {": name: is 257 bytes long, more than the limit of 256"});
  s = valid_scene();
  s["objects"][0]["mesh"] = {{"type", "obj"}, {"path", std::string(5000, 'p') + ".obj"}};
  expect_error(s, {"objects[0].mesh.path: is 5004 bytes long, more than the limit of 4096"});
  // A 60 000-character unknown key is named cut, not whole.
  s = valid_scene();
  s[std::string(60000, 'k')] = 1;
  message = error_of([&] { parse(s); });
  EXPECT_NE(message.find("unknown key"), std::string::npos) << message;
  EXPECT_NE(message.find("(60000 chars)"), std::string::npos) << message;
  EXPECT_LT(message.size(), 400u) << message.substr(0, 400);
}

TEST(SceneFileLimits, NulInsideAStringIsRefusedNotCut) {
  const std::pair<const char*, const char*> cases[] = {
      {"/objects/0/name", "objects[0].name"}, {"/name", ": name"}, {"/description", ": description"}};
  for (const auto& [pointer, key] : cases) {
    json s = valid_scene();
    s[json::json_pointer(pointer)] = std::string("sheet\0.obj", 10);
    expect_error(s, {std::string(key) + ": must not contain a NUL character", "got \"sheet\\x00.obj\""});
  }
  TempDir dir;
  dir.write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  json s = valid_scene();
  s["objects"][0]["mesh"] = {{"type", "obj"}, {"path", std::string("tri.obj\0.png", 12)}};
  expect_error(s, {"objects[0].mesh.path: must not contain a NUL character"}, dir.path());
  // A key with a NUL or a newline is named escaped.
  s = valid_scene();
  s[std::string("ti\0me\nstep", 10)] = 1;
  expect_error(s, {": \"ti\\x00me\\nstep\": unknown key"});
}

// A scene that uses every key with a number in it, each at an ordinary value.
json every_number_scene() {
  json s = valid_scene();
  s["gravity"] = {0, -9.81, 0};
  s["solver"] = {{"tolerance", 1e-3}};
  s["wind"] = {{"air_velocity", {1, 0, 0}}, {"air_density", 1.2}, {"drag_coefficient", 1.0},
               {"gust_amplitude", 0.5}, {"gust_frequency", 1.0}};
  s["contact"] = {{"dhat", 1e-3}, {"offset", 0.0}, {"friction", 0.1}, {"eps_v", 1e-3}, {"stiffness", 1e3}};
  s["ground"] = {{"height", -1.0}, {"normal", {0, 1, 0}}, {"friction", 0.1}};
  s["hierarchy"] = {{"levels", 2}, {"ratio", 4}};
  json& o = s["objects"][0];
  o["transform"] = json::parse(R"({"scale": 1, "rotation": {"axis": [0, 0, 1], "angle_deg": 10}, "translation": [0, 0, 0]})");
  o["initial_velocity"] = {0, 0, 0};
  o["material"]["bending_youngs_modulus"] = 1e3;
  o["pins"] = json::parse(R"([{"region": {"min": [-1, 0.4, -1], "max": [1, 1, 1]},
    "script": {"velocity": [0, 0.1, 0], "angular_velocity": [0, 0, 0.1], "center": [0, 0, 0], "start": 0, "end": 1}}])");
  s["objects"].push_back(json::parse(R"({"name": "ball", "mesh": {"type": "icosphere", "radius": 0.2, "subdivisions": 1},
    "transform": {"translation": [0, 0, 2]}, "wind": false,
    "material": {"density": 920, "youngs_modulus": 1e5, "poisson_ratio": 0.45, "thickness": 5e-5},
    "pressure": {"model": "constant", "pressure": 100}})"));
  s["objects"].push_back(json::parse(R"({"name": "mover", "obstacle": true,
    "mesh": {"type": "box", "size": [0.1, 0.1, 0.1], "cells": 1}, "transform": {"translation": [0, 0, -2]},
    "motion": {"keyframes": [{"time": 1, "translation": [0, 0, 0.1], "rotation": {"axis": [0, 1, 0], "angle_deg": 10}}]}})"));
  return s;
}

TEST(SceneFileLimits, EveryPhysicalNumberOutsideItsRangeIsRefusedAtItsKey) {
  ASSERT_NO_THROW(parse(every_number_scene()));
  struct Case { const char* pointer; const char* value; const char* message; };
  const Case cases[] = {
      {"/time_step", "10", "time_step: must be from 1e-06 to 1 s, got 10"},
      {"/time_step", "1e-9", "time_step: must be from 1e-06 to 1 s"},
      {"/gravity/1", "-1e5", "gravity[1]: must be from -1000 to 1000 m/s^2"},
      {"/solver/tolerance", "1e300", "solver.tolerance: must be from 1e-12 to 1000 1/s"},
      {"/wind/air_velocity", "[1000, 0, 0]", "wind.air_velocity[0]: must be from -300 to 300 m/s"},
      {"/wind/air_velocity", "[250, 250, 0]", "wind.air_velocity: must have a length of at most 300 m/s"},
      {"/wind/air_density", "1e6", "wind.air_density: must be from 1e-06 to 2000 kg/m^3"},
      {"/wind/drag_coefficient", "100", "wind.drag_coefficient: must be from 0 to 10"},
      {"/wind/gust_amplitude", "1e3", "wind.gust_amplitude: must be from 0 to 10"},
      {"/wind/gust_frequency", "1e6", "wind.gust_frequency: must be from 0 to 1000 Hz"},
      // 250 m/s is within the limit, but gust_amplitude 0.5 swings it to 375 m/s.
      {"/wind/air_velocity", "[0, 0, 250]", "wind: gusts reach 375 m/s (|air_velocity| x (1 + gust_amplitude))"},
      {"/contact/dhat", "10", "contact.dhat: must be from 1e-08 to 1 m"},
      {"/contact/offset", "5", "contact.offset: must be from 0 to 1 m"},
      {"/contact/friction", "100", "contact.friction: a friction coefficient must be from 0 to 10"},
      {"/contact/eps_v", "1e6", "contact.eps_v: must be from 1e-09 to 100 m/s"},
      {"/contact/stiffness", "1e300", "contact.stiffness: must be from 1e-06 to 1e+25 J/m^4"},
      {"/ground/height", "1e9", "ground.height: must be from -10000 to 10000 m"},
      {"/ground/friction", "20", "ground.friction: a friction coefficient must be from 0 to 10"},
      {"/ground/normal", "[1e200, 1e200, 0]", "ground.normal[0]: must be from -1e+06 to 1e+06"},
      {"/ground/normal", "[1e-9, 0, 0]", "ground.normal: must be a non-zero vector (length >= 1e-06)"},
      {"/hierarchy/ratio", "1e6", "hierarchy.ratio: must be <= 1000"},
      {"/objects/0/transform/scale", "1e300", "objects[0].transform.scale: must be from 1e-06 to 1e+06"},
      {"/objects/0/transform/translation/0", "1e300", "objects[0].transform.translation[0]: must be from -10000 to 10000 m"},
      {"/objects/0/transform/rotation/angle_deg", "1e300", "objects[0].transform.rotation.angle_deg: must be from -36000 to 36000 degrees"},
      {"/objects/0/transform/rotation/axis", "[1e300, 0, 0]", "objects[0].transform.rotation.axis[0]: must be from -1e+06"},
      {"/objects/0/initial_velocity", "[1e4, 0, 0]", "objects[0].initial_velocity[0]: must be from -1000 to 1000 m/s"},
      {"/objects/0/initial_velocity", "[800, 800, 0]", "objects[0].initial_velocity: must have a length of at most 1000 m/s"},
      {"/objects/0/mesh/size/0", "1e300", "objects[0].mesh.size[0]: must be from 1e-06 to 10000 m"},
      {"/objects/0/material/density", "1e300", "objects[0].material.density: must be from 0.1 to 100000 kg/m^3"},
      {"/objects/0/material/youngs_modulus", "1e300", "objects[0].material.youngs_modulus: must be from 1 to 1e+13 Pa"},
      {"/objects/0/material/thickness", "10", "objects[0].material.thickness: must be from 1e-07 to 1 m"},
      {"/objects/0/material/bending_youngs_modulus", "1e300", "objects[0].material.bending_youngs_modulus: must be from 1e-06 to 1e+13 Pa"},
      {"/objects/0/pins/0/region/min/0", "-1e300", "objects[0].pins[0].region.min[0]: must be from -1e+06 to 1e+06 m"},
      {"/objects/0/pins/0/script/velocity", "[1e5, 0, 0]", "objects[0].pins[0].script.velocity[0]: must be from -1000 to 1000 m/s"},
      {"/objects/0/pins/0/script/angular_velocity", "[0, 0, 1e5]", "objects[0].pins[0].script.angular_velocity[2]: must be from -1000 to 1000 rad/s"},
      {"/objects/0/pins/0/script/center", "[1e300, 0, 0]", "objects[0].pins[0].script.center[0]: must be from -10000 to 10000 m"},
      {"/objects/0/pins/0/script/start", "1e300", "objects[0].pins[0].script.start: must be from 0 to 1e+07 s"},
      {"/objects/0/pins/0/script/end", "1e300", "objects[0].pins[0].script.end: must be from 0 to 1e+07 s"},
      {"/objects/1/mesh/radius", "1e300", "objects[1].mesh.radius: must be from 1e-06 to 10000 m"},
      {"/objects/1/pressure/pressure", "1e300", "objects[1].pressure.pressure: must be from -1e+07 to 1e+07 Pa"},
      {"/objects/2/mesh/size/1", "1e-300", "objects[2].mesh.size[1]: must be from 1e-06 to 10000 m"},
      {"/objects/2/motion/keyframes/0/time", "1e300", "objects[2].motion.keyframes[0].time: must be from 0 to 1e+07 s"},
      {"/objects/2/motion/keyframes/0/translation/2", "1e300", "objects[2].motion.keyframes[0].translation[2]: must be from -10000"},
      {"/objects/2/motion/keyframes/0/rotation/angle_deg", "-1e300", "objects[2].motion.keyframes[0].rotation.angle_deg: must be from -36000"},
  };
  for (const Case& c : cases) {
    json s = every_number_scene();
    s[json::json_pointer(c.pointer)] = json::parse(c.value);
    expect_error(s, {c.message});
  }
}

TEST(SceneFileLimits, ValuesAtTheEndsOfTheirRangesAreAccepted) {
  const std::pair<const char*, const char*> cases[] = {
      {"/time_step", "1"}, {"/time_step", "1e-6"}, {"/gravity/1", "-1000"},
      {"/wind/air_velocity", "[200, 0, 0]"},  // with gust_amplitude 0.5: a peak of exactly 300 m/s
      {"/contact/friction", "10"}, {"/objects/0/material/density", "1e5"}, {"/objects/0/material/youngs_modulus", "1e13"},
      {"/objects/0/initial_velocity", "[0, 0, -1000]"}, {"/objects/1/pressure/pressure", "-1e7"},
      {"/ground/normal", "[0, 1e6, 1e6]"}, {"/hierarchy/ratio", "1000"}};
  for (const auto& [pointer, value] : cases) {
    json s = every_number_scene();
    s[json::json_pointer(pointer)] = json::parse(value);
    EXPECT_NO_THROW(parse(s)) << pointer << " = " << value;
  }
  json s = every_number_scene();
  s["ground"]["normal"] = {0, 2e5, 0};
  EXPECT_TRUE(parse(s).ground->normal.isApprox(Vec3(0, 1, 0)));
}

TEST(SceneFileLimits, ScriptedVertexSpeedsAreBoundedIncludingSpinAndKeyframes) {
  // Spin about a far centre: 10 rad/s at 500 m is 5000 m/s at the pinned vertices.
  json s = every_number_scene();
  s["objects"][0]["pins"][0]["script"]["angular_velocity"] = {0, 0, 10};
  s["objects"][0]["pins"][0]["script"]["center"] = {500, 0, 0};
  expect_error(s, {"objects[0].pins[0].script: moves vertices at up to 50", "more than the limit of 1000 m/s"});
  // A keyframe 5 m away after 1 ms: 5000 m/s.
  s = every_number_scene();
  s["objects"][2]["motion"]["keyframes"] = json::parse(R"([{"time": 0.001, "translation": [5, 0, 0]}])");
  expect_error(s, {"objects[2].motion: moves vertices at up to 50", "m/s"});
  // A half turn in 1 ms: 3142 rad/s.
  s["objects"][2]["motion"]["keyframes"] =
      json::parse(R"([{"time": 0.001, "rotation": {"axis": [0, 1, 0], "angle_deg": 180}}])");
  expect_error(s, {"objects[2].motion: turns at 3141.", "rad/s between the keyframes at t = 0 and 0.001 s"});
}

TEST(SceneFileLimits, VerticesBeyondTenKilometresAfterTheTransformAreRefused) {
  json s = valid_scene();
  s["objects"][0]["transform"] = {{"scale", 1e5}};  // the 1 m sheet becomes 100 km wide
  expect_error(s, {"objects[0].mesh: rest vertex 0 is at [-50000, -50000, 0] m after the transform", "-10000 to 10000"});
  TempDir dir;
  TriMesh rest = make_rectangle(1.0, 1.0, 1, 1);
  Positions posed = rest.V;
  posed(3, 2) = 2e4;  // one corner 20 km up
  write_obj(dir.path() + "/posed.obj", posed, rest.F);
  s = valid_scene();
  s["objects"][0]["mesh"]["cells"] = {1, 1};
  s["objects"][0]["initial_positions"] = {{"obj", "posed.obj"}};
  expect_error(s, {"objects[0].initial_positions.obj: initial vertex 3 is at"}, dir.path());
}

TEST(SceneFileLimits, APosedShapeCollapsedToAPointIsRefusedAsDegenerate) {
  TempDir dir;
  TriMesh rest = make_rectangle(1.0, 1.0, 1, 1);
  Positions posed = Positions::Constant(rest.V.rows(), 3, 1e-160);  // within range, every face crushed
  write_obj(dir.path() + "/posed.obj", posed, rest.F);
  json s = valid_scene();
  s["objects"][0]["mesh"]["cells"] = {1, 1};
  s["objects"][0]["initial_positions"] = {{"obj", "posed.obj"}};
  expect_error(s, {kFile + ": objects[0].initial_positions.obj: face 0 has zero area in the posed shape"}, dir.path());
  posed = rest.V;
  posed.row(1) = posed.row(0);  // the boundary edge 0-1 shrunk to nothing: its face is crushed
  write_obj(dir.path() + "/posed.obj", posed, rest.F);
  expect_error(s, {"objects[0].initial_positions.obj: face ", "has zero area in the posed shape"}, dir.path());
}

TEST(SceneFileLimits, ObjectAndPinGroupCountsAreBounded) {
  json s = valid_scene();
  json sheet = s["objects"][0];
  sheet.erase("name");
  s["objects"] = json::array();
  for (int i = 0; i < 1001; ++i) s["objects"].push_back(sheet);
  expect_error(s, {": objects: lists more than 1000 objects"});
  s = valid_scene();
  s["objects"][0]["pins"] = json::array();
  for (int i = 0; i < 1001; ++i) s["objects"][0]["pins"].push_back({{"indices", {i % 25}}});
  expect_error(s, {"objects[0].pins: lists more than 1000 pin groups"});
}

TEST(SceneFileLimits, GeneratedMeshOverTheVertexLimitIsRefusedBeforeBuilding) {
  // c = 1 mm, rows = round(100 / 0.866e-3) = 115470: (rows + 1) * 1002 vertices, far over the limit.
  json s = valid_scene();
  s["objects"][0]["mesh"] = {{"type", "rectangle_equilateral"}, {"size", {1.0, 100.0}}, {"cells_x", 1000}};
  expect_error(s, {"objects[0].mesh.cells_x: gives 115", "vertices, more than the limit of 2000000"});
}

TEST(SceneFileLimits, ObjMeshOverTheFaceLimitIsRefusedWhileReading) {
  // Generated shapes have fewer than 2 faces per vertex, so only an OBJ can pass the face limit
  // (4 000 000) first: here 3 vertices and 4 000 001 faces, stopped at the face that crosses it.
  TempDir dir;
  std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  text.reserve(text.size() + 8 * 4000001);
  for (int i = 0; i < 4000001; ++i) text += "f 1 2 3\n";
  dir.write("many.obj", text);
  json s = valid_scene();
  s["objects"][0]["mesh"] = {{"type", "obj"}, {"path", "many.obj"}};
  expect_error(s, {"objects[0].mesh.path: ", "many.obj:4000004: more than 4000000 faces"}, dir.path());
}

TEST(SceneFileLimits, SceneWideVertexTotalIsBounded) {
  json s = valid_scene();
  json sheet = s["objects"][0];
  sheet["mesh"]["cells"] = {1000, 1400};  // 1 402 401 vertices each, 3 of them over 4 000 000
  s["objects"] = json::array();
  for (const char* name : {"a", "b", "c"}) {
    sheet["name"] = name;
    s["objects"].push_back(sheet);
  }
  // Refused at the third mesh's resolution, before that mesh is built.
  expect_error(s, {"objects[2].mesh.cells: gives 1402401 vertices, which brings the scene to 4207203, more than the "
                   "limit of 4000000 for all objects together"});
}

TEST(SceneFileLimits, SceneFileThatIsAFifoIsRefusedWithoutBlocking) {
  TempDir dir;
  const std::string fifo = dir.path() + "/scene.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0) << std::strerror(errno);
  // The load runs in a thread; if it blocked in open(), opening the write end releases it, so the
  // test fails instead of hanging.
  std::promise<std::string> result;
  std::future<std::string> done = result.get_future();
  std::thread loader([&] { result.set_value(error_of([&] { load_scene(fifo); })); });
  const bool in_time = done.wait_for(std::chrono::seconds(5)) == std::future_status::ready;
  if (!in_time) {
    const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (fd >= 0) ::close(fd);
  }
  loader.join();
  ASSERT_TRUE(in_time) << "load_scene blocked on a FIFO";
  EXPECT_EQ(done.get(), fifo + ": is not a regular file (a FIFO, socket or device), not a scene file");
}

}  // namespace
}  // namespace pd
