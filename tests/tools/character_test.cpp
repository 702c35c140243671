// The generated character (tools/character.h): scenes/skirt-walk/ is exactly what the generator
// writes, the body starts at rest and moves, and a small skirt on it is never penetrated, directly
// and progressively, stays on the hips and turns with them.
#include "tools/character.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "hierarchy/scene_hierarchy.h"
#include "scene/scene_file.h"
#include "support/level_runs.h"
#include "support/test_paths.h"

namespace pd::tools {
namespace {

namespace fs = std::filesystem;

std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The options and shot of scenes/skirt-walk/ (tools/README.md).
constexpr int kShotFrames = 150, kShotLevels = 3;

TEST(Character, TheCommittedSkirtWalkShotIsWhatTheGeneratorWrites) {
  const std::string dir = test::scratch_dir("skirt_walk");
  const CharacterOptions o;
  write_shot(make_character(o), o, dir, "skirt-walk", kShotFrames, kShotLevels);
  const fs::path committed = fs::path(test::source_dir()) / "scenes/skirt-walk";
  int compared = 0;
  for (const char* file : {"skirt-walk.json", "body_rest.obj", "body.pc2", "skirt.obj"}) {
    EXPECT_TRUE(bytes_of(committed / file) == bytes_of(fs::path(dir) / file))
        << file << " differs: regenerate with pd_make_character --out scenes/skirt-walk";
    ++compared;
  }
  EXPECT_EQ(compared, 4);
  const Scene scene = load_scene((committed / "skirt-walk.json").string());
  EXPECT_GT(scene.objects[0].rest.num_vertices(), 2000);  // a few thousand cloth vertices
  fs::remove_all(dir);
}

TEST(Character, TheBodyStartsAtRestWithNoSpeedAndThenMoves) {
  CharacterOptions o;
  o.segments = 6;
  const Character c = make_character(o);
  EXPECT_EQ(c.frames.front(), c.body.V);
  const double dt = 1e-4;
  EXPECT_LT((body_at(o, c.body, dt) - c.body.V).cwiseAbs().maxCoeff() / dt, 1e-3);  // m/s, eased in
  double moved = 0.0;
  for (const Positions& x : c.frames) moved = std::max(moved, (x - c.body.V).rowwise().norm().maxCoeff());
  EXPECT_GT(moved, 0.2);  // the step alone is 0.2 m
  EXPECT_EQ(c.frames.size(), 61u);  // 2 s at 30 fps, both ends
}

// The mean angle (rad) about the vertical axis of the skirt's waist ring, from its rest direction.
double waist_turn(const Eigen::VectorXd& x, const TriMesh& skirt, int around) {
  double sum = 0.0;
  for (int i = 0; i < around; ++i) {
    const double rest = std::atan2(skirt.V(i, 0), skirt.V(i, 2));
    const double now = std::atan2(x[3 * i], x[3 * i + 2]);
    sum += std::remainder(now - rest, 2.0 * M_PI);
  }
  return sum / around;
}

// A small skirt (264 vertices) on a coarse body for 0.4 s: the hips turn about 7.6 degrees.
TEST(Character, ASmallSkirtOnTheWalkingBodyIsNeverPenetratedStaysOnAndTurnsWithTheHips) {
  const std::string dir = test::scratch_dir("skirt_small");
  CharacterOptions o;
  o.segments = 8;
  o.skirt_around = 24;
  o.skirt_down = 10;
  o.seconds = 1.0;
  const Character c = make_character(o);
  write_shot(c, o, dir, "small", 40, 2);
  const Scene scene = load_scene(dir + "/small.json");
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const test::LevelRun direct = test::solve_level(scene, h, 1, nullptr, true);
  const test::LevelRun preview = test::solve_level(scene, h, 0, nullptr, false);
  const test::LevelRun refined = test::solve_level(scene, h, 1, &preview, false);
  EXPECT_EQ(direct.intersecting, 0);
  EXPECT_EQ(preview.intersecting, 0);
  EXPECT_EQ(refined.intersecting, 0);
  for (const test::LevelRun* r : {&direct, &refined}) {
    double waist = 0.0;
    for (int i = 0; i < o.skirt_around; ++i) waist += r->x.at(40)[3 * i + 1] / o.skirt_around;
    const double turn = waist_turn(r->x.at(40), c.skirt, o.skirt_around) * 180.0 / M_PI;
    std::printf("[skirt] frame 40: waist ring at %.4f m (rest 1.07), turned %.2f deg\n", waist, turn);
    EXPECT_GT(waist, 0.95);  // held by the hips, 5 cm below where it started at most
    EXPECT_GT(turn, 2.0);    // carried round by friction with the hips
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace pd::tools
