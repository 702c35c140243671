// An obstacle's "animation" key: OBJ sequences and PC2 caches read into the scene, placed by the
// object's transform, and every bad cache refused naming the scene key and the cache file.
#include "scene/scene_animation.h"

#include <cstdio>
#include <limits>

#include <gtest/gtest.h>

#include "geometry/obj_io.h"
#include "geometry/shapes.h"
#include "scene/scene_test_helpers.h"
#include "support/pc2_bytes.h"

namespace pd::test {
namespace {

// A 0.2 m box (8 vertices) rising 0.1 m per cache frame, frames `first`..`last`.
Positions box_at(long long k) {
  Positions x = make_box(Vec3(0.2, 0.2, 0.2), 1).V;
  x.col(1).array() += 0.1 * static_cast<double>(k);
  return x;
}

// A scene with one animated obstacle (the animation object given) and 10 frames of 0.01 s.
json animated_scene(const json& animation) {
  json s = valid_scene();
  s["contact"] = {{"dhat", 1e-3}};
  s["objects"].push_back({{"name", "body"},
                          {"obstacle", true},
                          {"mesh", {{"type", "obj"}, {"path", "body/rest.obj"}}},
                          {"animation", animation}});
  s["objects"][0]["transform"] = {{"translation", {0, 2, 0}}};  // the sheet well away from the box
  return s;
}

// Writes body/rest.obj and body/frame_0001.obj .. frame_<last>.obj under dir.
void write_sequence(const TempDir& dir, int first, int last) {
  const TriMesh box = make_box(Vec3(0.2, 0.2, 0.2), 1);
  dir.write("body/rest.obj", "");
  write_obj(dir.path() + "/body/rest.obj", box.V, box.F);
  for (int k = first; k <= last; ++k) {
    char name[64];
    std::snprintf(name, sizeof name, "/body/frame_%04d.obj", k);
    write_obj(dir.path() + name, box_at(k - first), box.F);
  }
}

const SceneObject& body(const Scene& s) { return s.objects[1]; }

TEST(SceneAnimation, AnObjSequenceMovesTheObstacleAtItsFrameRate) {
  TempDir dir;
  write_sequence(dir, 1, 3);
  for (const char* pattern : {"body/frame_####.obj", "body/frame_%04d.obj"}) {
    const Scene s = parse(animated_scene({{"obj_sequence", pattern}, {"frames", {1, 3}}, {"fps", 20}}), dir.path());
    ASSERT_TRUE(body(s).motion && body(s).motion->animation) << pattern;
    const VertexAnimation& a = *body(s).motion->animation;
    EXPECT_EQ(a.frames(), 3);
    EXPECT_EQ(a.step(), 0.05);
    EXPECT_EQ(body(s).initial, box_at(0));  // the pose at t = 0
    EXPECT_NEAR(a.position(0, 0.075).y() - box_at(0)(0, 1), 0.15, 1e-12);  // 1.5 cache frames up
  }
}

TEST(SceneAnimation, APc2CacheIsPlacedByTheObjectsTransformLikeItsRestMesh) {
  TempDir dir;
  const TriMesh box = make_box(Vec3(0.2, 0.2, 0.2), 1);
  dir.write("body/rest.obj", "");
  write_obj(dir.path() + "/body/rest.obj", box.V, box.F);
  // In centimetres, as Maya writes it: scaled by 0.01 with the rest mesh.
  std::vector<Positions> cm;
  for (int k = 0; k < 7; ++k) cm.push_back(100.0 * box_at(k));
  write_obj(dir.path() + "/body/rest.obj", 100.0 * box.V, box.F);
  dir.write("body/walk.pc2", pc2_bytes(cm, 1.0f, 2.0f));  // a sample every 2 frames
  json s = animated_scene({{"pc2", "body/walk.pc2"}, {"fps", 100}, {"start", -0.01}, {"interpolation", "smooth"}});
  s["objects"][1]["transform"] = {{"scale", 0.01}};
  const Scene scene = parse(s, dir.path());
  const VertexAnimation& a = *body(scene).motion->animation;
  EXPECT_EQ(a.interpolation(), AnimationInterpolation::Smooth);
  EXPECT_DOUBLE_EQ(a.step(), 0.02);
  EXPECT_DOUBLE_EQ(a.start(), -0.01);
  for (int k = 0; k < 7; ++k)
    EXPECT_LT((a.frame(k) - box_at(k)).cwiseAbs().maxCoeff(), 1e-6) << k;  // float32 centimetres
  EXPECT_LT((body(scene).rest.V - box.V).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(SceneAnimation, EveryBadSequenceNamesTheKeyAndTheCacheFile) {
  TempDir dir;
  write_sequence(dir, 1, 3);
  const auto seq = [](int last) { return json{{"obj_sequence", "body/frame_####.obj"}, {"frames", {1, last}}, {"fps", 20}}; };
  const std::string key = "objects[1].animation";
  // A missing frame.
  expect_error(animated_scene(seq(4)), {key + ".obj_sequence: frame 4: ", "body/frame_0004.obj: cannot open"}, dir.path());
  // Another vertex count, another face list.
  const TriMesh box = make_box(Vec3(0.2, 0.2, 0.2), 1);
  Faces flipped = box.F;
  std::swap(flipped(5, 1), flipped(5, 2));
  write_obj(dir.path() + "/body/frame_0002.obj", box_at(1), flipped);
  expect_error(animated_scene(seq(3)), {key + ".obj_sequence: ", "frame_0002.obj: face 6 is ", "the obstacle mesh's face 6"},
               dir.path());
  Positions more(9, 3);
  more << box_at(1), Eigen::RowVector3d(0, 0, 0);
  write_obj(dir.path() + "/body/frame_0002.obj", more, box.F);
  expect_error(animated_scene(seq(3)), {"frame_0002.obj: has 9 vertices, the obstacle's mesh has 8"}, dir.path());
  // An absurd coordinate, named by its line (vertex 3 is on line 3: write_obj starts with v lines).
  Positions far = box_at(1);
  far(2, 0) = 5e4;
  write_obj(dir.path() + "/body/frame_0002.obj", far, box.F);
  expect_error(animated_scene(seq(3)), {"frame_0002.obj:3: vertex 3: coordinate 50000 m", "outside"}, dir.path());
  // A jump no body makes: 10 m between frames at 1 000 fps.
  Positions jump = box_at(1);
  jump(0, 0) += 10.0;
  write_obj(dir.path() + "/body/frame_0002.obj", jump, box.F);
  expect_error(animated_scene({{"obj_sequence", "body/frame_####.obj"}, {"frames", {1, 3}}, {"fps", 1000}}),
               {"frame_0002.obj:1: vertex 1: moves at 10000", "is \"fps\" right?"}, dir.path());
  write_sequence(dir, 1, 3);
  // A cache that ends before the shot (10 frames of 0.01 s = 0.1 s; 3 frames at 25 fps = 0.08 s).
  expect_error(animated_scene({{"obj_sequence", "body/frame_####.obj"}, {"frames", {1, 3}}, {"fps", 25}}),
               {key + ": covers t = 0 to 0.08 s", "the shot runs to 0.1 s"}, dir.path());
  // Patterns without exactly one frame number.
  expect_error(animated_scene({{"obj_sequence", "body/frame.obj"}, {"frames", {1, 3}}, {"fps", 20}}),
               {key + ".obj_sequence: has no frame number"}, dir.path());
  expect_error(animated_scene({{"obj_sequence", "body/f_##_%d.obj"}, {"frames", {1, 3}}, {"fps", 20}}),
               {key + ".obj_sequence: must hold exactly one frame number"}, dir.path());
}

TEST(SceneAnimation, BadKeysAndCombinationsAreRefusedByName) {
  TempDir dir;
  write_sequence(dir, 1, 3);
  const json seq = {{"obj_sequence", "body/frame_####.obj"}, {"frames", {1, 3}}, {"fps", 20}};
  json both = seq;
  both["pc2"] = "body/walk.pc2";
  expect_error(animated_scene(both), {"objects[1].animation: needs exactly one of"}, dir.path());
  json no_fps = seq;
  no_fps.erase("fps");
  expect_error(animated_scene(no_fps), {"objects[1].animation.fps: required key is missing"}, dir.path());
  json bad_fps = seq;
  bad_fps["fps"] = 0;
  expect_error(animated_scene(bad_fps), {"objects[1].animation.fps"}, dir.path());
  json interp = seq;
  interp["interpolation"] = "cubic";
  expect_error(animated_scene(interp), {"objects[1].animation.interpolation"}, dir.path());
  json with_motion = animated_scene(seq);
  with_motion["objects"][1]["motion"] = {{"velocity", {1, 0, 0}}};
  expect_error(with_motion, {"objects[1].motion: does not apply to an animated obstacle"}, dir.path());
  json on_cloth = animated_scene(seq);
  on_cloth["objects"][0]["animation"] = seq;
  expect_error(on_cloth, {"objects[0].animation: applies to obstacles only"}, dir.path());
  // The PC2 reader's errors come through the key.
  dir.write("body/bad.pc2", "POINTCACHE2");
  expect_error(animated_scene({{"pc2", "body/bad.pc2"}, {"fps", 20}}),
               {"objects[1].animation.pc2: ", "bad.pc2: the file has 11 bytes"}, dir.path());
  std::vector<Positions> three = {box_at(0), box_at(1), box_at(2)};
  std::vector<Positions> seven_points = {box_at(0).topRows(7), box_at(1).topRows(7), box_at(2).topRows(7)};
  dir.write("body/seven.pc2", pc2_bytes(seven_points));
  expect_error(animated_scene({{"pc2", "body/seven.pc2"}, {"fps", 20}}),
               {"seven.pc2: has 7 points, the obstacle's mesh has 8 vertices"}, dir.path());
  dir.write("body/ok.pc2", pc2_bytes(three));
  json pc2_frames = {{"pc2", "body/ok.pc2"}, {"fps", 20}, {"frames", {1, 3}}};
  expect_error(animated_scene(pc2_frames), {"objects[1].animation.frames: applies to \"obj_sequence\" only"}, dir.path());
}

TEST(SceneAnimation, AnimationFilesListsTheSequenceInFrameOrder) {
  const json j = {{"obj_sequence", "b/f_%03d.obj"}, {"frames", {8, 11}}, {"fps", 24}};
  EXPECT_EQ(animation_files(j), (std::vector<std::string>{"b/f_008.obj", "b/f_009.obj", "b/f_010.obj", "b/f_011.obj"}));
  const json p = {{"pc2", "b/walk.pc2"}, {"fps", 24}};
  EXPECT_EQ(animation_files(p), (std::vector<std::string>{"b/walk.pc2"}));
}

}  // namespace
}  // namespace pd::test
