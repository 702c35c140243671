// VertexAnimation: where a vertex is between cache frames, linear and smooth, and outside the cache.
#include "scene/vertex_animation.h"

#include <gtest/gtest.h>

namespace pd {
namespace {

// One vertex on a parabola x = k^2 at cache frames k = 0..4, frames 0.5 s apart from t = 1 s.
VertexAnimation parabola(AnimationInterpolation interpolation) {
  std::vector<Positions> frames;
  for (int k = 0; k < 5; ++k) {
    Positions x(1, 3);
    x << k * k, 1.0, -k;
    frames.push_back(x);
  }
  return VertexAnimation(frames, 1.0, 0.5, interpolation);
}

TEST(VertexAnimation, BothInterpolationsPassThroughEveryCacheFrameAndHoldOutsideTheCache) {
  for (auto mode : {AnimationInterpolation::Linear, AnimationInterpolation::Smooth}) {
    const VertexAnimation a = parabola(mode);
    EXPECT_EQ(a.end(), 3.0);
    for (int k = 0; k < 5; ++k) EXPECT_EQ(a.position(0, 1.0 + 0.5 * k), Vec3(k * k, 1.0, -k)) << k;
    EXPECT_EQ(a.position(0, -7.0), Vec3(0, 1, 0));   // before: the first pose
    EXPECT_EQ(a.position(0, 99.0), Vec3(16, 1, -4));  // after: the last pose
  }
}

TEST(VertexAnimation, LinearIsTheChordAndSmoothFollowsTheCurveBetweenFrames) {
  const VertexAnimation lin = parabola(AnimationInterpolation::Linear);
  const VertexAnimation smooth = parabola(AnimationInterpolation::Smooth);
  // Halfway between frames 1 and 2 (t = 1.75 s): the chord gives 2.5, the curve 2.25; uniform
  // Catmull-Rom reproduces a quadratic exactly away from the repeated ends.
  EXPECT_DOUBLE_EQ(lin.position(0, 1.75).x(), 2.5);
  EXPECT_DOUBLE_EQ(smooth.position(0, 1.75).x(), 2.25);
  EXPECT_DOUBLE_EQ(smooth.position(0, 1.75).z(), -1.5);  // linear data stays linear
}

TEST(VertexAnimation, SmoothHasNoVelocityJumpAtACacheFrame) {
  const VertexAnimation lin = parabola(AnimationInterpolation::Linear);
  const VertexAnimation smooth = parabola(AnimationInterpolation::Smooth);
  const double t = 2.0, d = 1e-6;  // cache frame 2
  const auto jump = [&](const VertexAnimation& a) {
    const Vec3 before = (a.position(0, t) - a.position(0, t - d)) / d;
    const Vec3 after = (a.position(0, t + d) - a.position(0, t)) / d;
    return (after - before).norm();
  };
  EXPECT_GT(jump(lin), 3.0);    // slopes 2 * (2 - 1) / 0.5 ... : 6 then 10 per second
  EXPECT_LT(jump(smooth), 1e-3);
}

TEST(VertexAnimation, RefusesNoFramesRaggedFramesAndABadStep) {
  Positions one(1, 3), two(2, 3);
  one.setZero();
  two.setZero();
  EXPECT_THROW(VertexAnimation({}, 0.0, 1.0, AnimationInterpolation::Linear), std::invalid_argument);
  EXPECT_THROW(VertexAnimation({one, two}, 0.0, 1.0, AnimationInterpolation::Linear), std::invalid_argument);
  EXPECT_THROW(VertexAnimation({one}, 0.0, 0.0, AnimationInterpolation::Linear), std::invalid_argument);
}

}  // namespace
}  // namespace pd
