// Cloth against deforming obstacles (issue 46): an obstacle whose vertices follow an OBJ sequence is
// never penetrated, directly and on every level of a progressive run, also when it moves fast; its
// own parts may pass through each other.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>

#include "geometry/obj_io.h"
#include "geometry/shapes.h"
#include "hierarchy/scene_hierarchy.h"
#include "progressive/direct_run.h"
#include "progressive/progressive_run.h"
#include "progressive/scene_system.h"
#include "scene/scene_file.h"
#include "scene/scene_test_helpers.h"
#include "support/intersection_checker.h"
#include "support/level_runs.h"

namespace pd {
namespace {

using test::json;

using test::LevelRun;

LevelRun solve(const Scene& scene, const SceneHierarchy& h, int level, const LevelRun* below, bool direct) {
  LevelRun run = test::solve_level(scene, h, level, below, direct);
  EXPECT_EQ(run.unconverged_steps, 0) << "level " << level;
  return run;
}

// The "body": a torso (a 0.3 m box, 3 cells a side) and an arm (a 0.06 m box beside it, low, at
// x = 0.25 m), one mesh. Cache frame k (24 fps): the torso rises 5 mm a frame and widens along x by
// 1 % a frame (a deforming, not rigid, motion); the arm moves 2 cm a frame into the torso, so from
// cache frame 5 on the body's own faces cross, as a captured body's do.
TriMesh body_mesh() {
  const TriMesh torso = make_box(Vec3(0.3, 0.3, 0.3), 3);
  const TriMesh arm = make_box(Vec3(0.06, 0.06, 0.06), 1);
  TriMesh m;
  m.V.resize(torso.num_vertices() + arm.num_vertices(), 3);
  m.V << torso.V, arm.V.rowwise() + Eigen::RowVector3d(0.25, -0.1, 0.0);
  m.F.resize(torso.num_faces() + arm.num_faces(), 3);
  m.F << torso.F, arm.F.array() + torso.num_vertices();
  return m;
}
constexpr int kTorsoVertices = 56;  // a 3-cell box: 6 x 16 - 12 x 4 + 8

Positions body_at(const TriMesh& body, int k) {
  Positions x = body.V;
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    if (i < kTorsoVertices) {
      x(i, 0) *= 1.0 + 0.01 * k;
      x(i, 1) += 0.005 * k;
    } else {
      x(i, 0) -= 0.02 * k;
    }
  }
  return x;
}

// The scene: a 0.5 m sheet (10 x 10 cells) 2 cm above the body, contact with friction, `frames`
// frames of 1/100 s, two levels. The body's frames are written under dir.
Scene body_scene(const test::TempDir& dir, int frames, double fps) {
  const TriMesh box = body_mesh();
  dir.write("body/.keep", "");
  write_obj(dir.path() + "/body/rest.obj", box.V, box.F);
  const int cache_frames = static_cast<int>(std::ceil(frames * 0.01 * fps)) + 1;
  for (int k = 0; k < cache_frames; ++k) {
    char name[64];
    std::snprintf(name, sizeof name, "/body/f%03d.obj", k);
    write_obj(dir.path() + name, body_at(box, k), box.F);
  }
  json s = {{"format_version", 1}, {"time_step", 0.01}, {"frames", frames},
            {"contact", {{"dhat", 1e-3}, {"friction", 0.3}}},
            {"hierarchy", {{"levels", 2}}},
            {"objects",
             {{{"name", "sheet"},
               {"mesh", {{"type", "rectangle"}, {"size", {0.5, 0.5}}, {"cells", {10, 10}}}},
               {"transform", {{"rotation", {{"axis", {1, 0, 0}}, {"angle_deg", -90}}}, {"translation", {0, 0.17, 0}}}},
               {"material", {{"preset", "cotton"}}},
               {"self_contact", true}},
              {{"name", "body"},
               {"obstacle", true},
               {"mesh", {{"type", "obj"}, {"path", "body/rest.obj"}}},
               {"animation", {{"obj_sequence", "body/f###.obj"}, {"frames", {0, cache_frames - 1}}, {"fps", fps}}}}}}};
  return parse_scene(s.dump(), "body-scene.json", dir.path());
}

double lowest_sheet_y(const Eigen::VectorXd& x, int sheet_vertices) {
  double low = 1e9;
  for (int i = 0; i < sheet_vertices; ++i) low = std::min(low, x[3 * i + 1]);
  return low;
}

TEST(AnimatedObstacle, TheBodysVerticesFollowTheCacheOnEveryLevelBetweenCacheFrames) {
  test::TempDir dir;
  const Scene scene = body_scene(dir, 6, 24.0);
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const TriMesh box = body_mesh();
  ASSERT_EQ(make_box(Vec3(0.3, 0.3, 0.3), 3).num_vertices(), kTorsoVertices);
  const int body_vertices = box.num_vertices();
  for (int level = 0; level < h.num_levels(); ++level) {
    const SceneLevel& lv = h.levels[static_cast<std::size_t>(level)];
    // Kept whole on every level, in the cache's vertex order.
    EXPECT_EQ(lv.vertex_offsets[2] - lv.vertex_offsets[1], body_vertices) << level;
    const LevelRun run = solve(scene, h, level, nullptr, true);
    const double t = 0.05;  // frame 5, 1.2 cache frames: between cache frames 1 and 2
    const Positions expected = 0.8 * body_at(box, 1) + 0.2 * body_at(box, 2);
    const Eigen::VectorXd& x = run.x.at(5);
    double worst = 0.0;
    for (int i = 0; i < body_vertices; ++i)
      worst = std::max(worst, (x.segment<3>(3 * (lv.vertex_offsets[1] + i)) - expected.row(i).transpose()).norm());
    EXPECT_LT(worst, 1e-12) << "level " << level << " at t = " << t;
  }
}

TEST(AnimatedObstacle, ASheetOnARisingWideningBodyIsNeverPenetratedDirectlyOrProgressively) {
  test::TempDir dir;
  const Scene scene = body_scene(dir, 40, 24.0);
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const LevelRun direct = solve(scene, h, 1, nullptr, true);
  const LevelRun preview = solve(scene, h, 0, nullptr, false);
  const LevelRun refined = solve(scene, h, 1, &preview, false);
  EXPECT_EQ(direct.intersecting, 0);
  EXPECT_EQ(preview.intersecting, 0);
  EXPECT_EQ(refined.intersecting, 0);
  // The arm is inside the torso by then: the body's own crossings were there and were let pass.
  EXPECT_GT(test::find_intersections(as_rows(direct.x.at(40)), h.levels.back().rest.F).intersecting_pairs, 0);
  // The body rose 0.005 m x 24 fps x 0.4 s = 4.8 cm and carried the sheet's middle up with it.
  const int sheet = 121;
  const double top = 0.15 + 0.005 * 24.0 * 0.4;
  for (const LevelRun* r : {&direct, &refined}) EXPECT_GT(r->x.at(40)[3 * 60 + 1], top) << "the sheet's centre vertex";
  std::printf("[animated body] the sheet's lowest point at frame 40: direct %.4f m, refined %.4f m; body top %.4f m\n",
              lowest_sheet_y(direct.x.at(40), sheet), lowest_sheet_y(refined.x.at(40), sheet), top);
}

// A fast body: a 0.1 m box sweeping at 4 m/s (4 cm a step, almost a cell of the curtain) through a
// hanging curtain pinned along its top. Kinematic targets move the body and the curtain together, so
// nothing tunnels.
TEST(AnimatedObstacle, AFastSweepingBodyPushesAHangingCurtainWithoutPassingThroughIt) {
  test::TempDir dir;
  const TriMesh box = make_box(Vec3(0.1, 0.1, 0.1), 2);
  dir.write("bar/.keep", "");
  write_obj(dir.path() + "/bar/rest.obj", box.V, box.F);
  const int frames = 10;
  for (int k = 0; k <= frames; ++k) {
    Positions x = box.V;
    x.col(2).array() += -0.12 + 0.04 * k;  // centre from z = -0.12 to +0.28 m, through the curtain at z = 0
    char name[64];
    std::snprintf(name, sizeof name, "/bar/b%02d.obj", k);
    write_obj(dir.path() + name, x, box.F);
  }
  json s = {{"format_version", 1}, {"time_step", 0.01}, {"frames", frames},
            {"contact", {{"dhat", 1e-3}}},
            {"hierarchy", {{"levels", 1}}},
            {"objects",
             {{{"name", "curtain"},
               {"mesh", {{"type", "rectangle"}, {"size", {0.6, 0.6}}, {"cells", {12, 12}}}},
               {"material", {{"preset", "cotton"}}},
               {"self_contact", true},
               {"pins", {{{"region", {{"min", {-1, 0.29, -1}}, {"max", {1, 1, 1}}}}}}}},
              {{"name", "bar"},
               {"obstacle", true},
               {"mesh", {{"type", "obj"}, {"path", "bar/rest.obj"}}},
               {"animation", {{"obj_sequence", "bar/b##.obj"}, {"frames", {0, frames}}, {"fps", 100}}}}}}};
  const Scene scene = parse_scene(s.dump(), "sweep.json", dir.path());
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const LevelRun run = solve(scene, h, 0, nullptr, true);
  EXPECT_EQ(run.intersecting, 0);
  double pushed = 0.0;
  for (int i = 0; i < 169; ++i) pushed = std::max(pushed, run.x.at(frames)[3 * i + 2]);
  // The bar's near face ends at z = 0.28 - 0.05: the curtain's middle went with it.
  EXPECT_GT(pushed, 0.2);
  std::printf("[fast body] the curtain bulges %.3f m along the bar's path\n", pushed);
}

// A run longer than its body's cache (pd simulate --frames, either mode) is refused before anything is
// written, naming the object's key and both times, instead of holding the body still.
TEST(AnimatedObstacle, ARunLongerThanTheBodysCacheIsRefusedInEitherMode) {
  test::TempDir dir;
  const Scene scene = body_scene(dir, 6, 24.0);  // the cache covers 0.0833 s: 3 cache frames
  const std::string out = dir.path() + "/out.h5";
  for (const bool direct : {true, false}) {
    const std::string message = test::error_of([&] {
      if (direct) {
        DirectRunOptions o;
        o.out_path = out;
        o.frames = 50;
        run_direct(scene, o);
      } else {
        ProgressiveRunOptions o;
        o.out_path = out;
        o.frames = 50;
        run_progressive(scene, o);
      }
    });
    EXPECT_NE(message.find("body-scene.json: objects[1].animation: covers t = 0 to 0.0833"), std::string::npos)
        << message;
    EXPECT_NE(message.find("but the job runs to 0.5 s (50 frames x 0.01 s)"), std::string::npos) << message;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}

}  // namespace
}  // namespace pd
