// Centre-of-mass consistency between levels (progressive/consistency.h) on small frame files written
// here: the deviation is the sum over simulated objects of the distance between centres, obstacles
// left out, only frames both levels hold.
#include "progressive/consistency.h"

#include <gtest/gtest.h>

#include "support/test_paths.h"
#include "util/input_error.h"

namespace pd {
namespace {

// A frame file with two levels of a two-object scene (object 1 an obstacle); level 0 holds frames
// 0..2, level 1 frames 0 and 2. Centres of mass are given, positions are zeros.
std::string two_level_file(const std::string& name) {
  const std::string path = test::scratch_dir("consistency") + "/" + name;
  const std::string scene = R"({"objects": [{"name": "cloth"}, {"name": "ball", "obstacle": true}]})";
  FrameWriter w = FrameWriter::create(path, scene, 2);
  Positions rest(6, 3);
  rest.setZero();
  Faces F(2, 3);
  F << 0, 1, 2, 3, 4, 5;
  for (int l = 0; l < 2; ++l) w.add_level(l, rest, F, {0, 3, 6}, {"cloth", "ball"});
  const auto write = [&](int level, int t, const Vec3& cloth, const Vec3& ball) {
    FrameStats s;
    s.scalars = {{"kinetic_energy", 0.5 * t}};
    s.center_of_mass.resize(2, 3);
    s.center_of_mass.row(0) = cloth.transpose();
    s.center_of_mass.row(1) = ball.transpose();
    w.write_frame(level, t, rest, s);
  };
  write(0, 0, Vec3(0, 0, 0), Vec3(5, 5, 5));
  write(0, 1, Vec3(0, -1, 0), Vec3(5, 5, 5));
  write(0, 2, Vec3(0, -2, 0), Vec3(5, 5, 5));
  write(1, 0, Vec3(0, 0, 0), Vec3(6, 6, 6));  // the obstacle's "centre" differs: not counted
  write(1, 2, Vec3(3, -6, 0), Vec3(6, 6, 6));
  w.close();
  return path;
}

TEST(Consistency, DeviationSumsSimulatedObjectsOverTheFramesBothLevelsHold) {
  const FrameReader reader(two_level_file("a.h5"));
  const std::vector<LevelSeries> series = read_level_series(reader);
  ASSERT_EQ(series.size(), 2u);
  EXPECT_EQ(series[0].frames, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(series[1].frames, (std::vector<int>{0, 2}));
  EXPECT_EQ(series[0].obstacle, (std::vector<char>{0, 1}));
  EXPECT_EQ(series[0].kinetic_energy[2], 1.0);
  const auto dev = com_deviation(series[0], series[1]);
  ASSERT_EQ(dev.size(), 2u);
  EXPECT_EQ(dev[0], std::make_pair(0, 0.0));
  EXPECT_EQ(dev[1], std::make_pair(2, 5.0));  // |(0,-2,0) - (3,-6,0)| = 5
  EXPECT_TRUE(com_deviation(series[1], series[1])[1].second == 0.0);
}

TEST(Consistency, LevelsOfDifferentScenesAreRefused) {
  const FrameReader reader(two_level_file("b.h5"));
  std::vector<LevelSeries> series = read_level_series(reader);
  series[1].object_names.pop_back();
  EXPECT_THROW(com_deviation(series[0], series[1]), InputError);
}

}  // namespace
}  // namespace pd
