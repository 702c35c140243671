// Relaxations on a submesh followed in the whole mesh (hierarchy/submesh_relaxation.h): a followed
// path never passes through what it meets, stops above the ground, and a pull slides a sheet along
// another instead of stopping on it.
#include "hierarchy/submesh_relaxation.h"

#include <gtest/gtest.h>

#include <cstdio>

#include "support/intersection_checker.h"
#include "support/two_squares.h"

namespace pd {
namespace {

using test::TwoSquares;

// The upper square's vertices (object 1) moved by d.
Positions moved_upper(const TwoSquares& s, const Positions& x, const Vec3& d) {
  Positions out = x;
  for (int v = 0; v < out.rows(); ++v)
    if (s.prims.vertex_object[static_cast<std::size_t>(v)] == 1) out.row(v) += d.transpose();
  return out;
}

TEST(SubmeshRelaxation, FollowedPathStopsBeforeWhatItMeetsAndReachesItsEndWhenFree) {
  TwoSquares s;
  const Positions start = as_rows(s.x);
  const double offset = 2e-3;
  // Down through the lower square in two segments: cut short above it.
  Positions x = start;
  follow_path(s.prims, s.rest, offset, nullptr,
              {moved_upper(s, start, Vec3(0, 0, -0.1)), moved_upper(s, start, Vec3(0, 0, -0.3))}, x);
  EXPECT_TRUE(test::intersection_free(x, s.prims.faces));
  EXPECT_GT(x.bottomRows(9).col(2).minCoeff(), offset);
  EXPECT_LT(x.bottomRows(9).col(2).maxCoeff(), start.bottomRows(9).col(2).maxCoeff());  // it did move
  // Up and sideways, away from everything: exactly the path's end.
  Positions y = start;
  const Positions end = moved_upper(s, start, Vec3(0.2, 0, 0.3));
  follow_path(s.prims, s.rest, offset, nullptr, {moved_upper(s, start, Vec3(0, 0, 0.3)), end}, y);
  EXPECT_TRUE(y == end);
}

TEST(SubmeshRelaxation, FollowedPathStopsAboveTheGroundOffset) {
  TwoSquares s;
  const Positions start = as_rows(s.x);
  GroundPlane ground{Vec3(0, 0, 1), -0.05, std::vector<char>(static_cast<std::size_t>(start.rows()), 1)};
  const double offset = 1e-3;
  Positions x = start;
  Positions down = start;
  down.col(2).array() -= 1.0;  // both squares, rigidly, through the ground
  follow_path(s.prims, s.rest, offset, &ground, {down}, x);
  EXPECT_GT(x.col(2).minCoeff(), -0.05 + offset);
  EXPECT_LT(x.col(2).minCoeff(), -0.05 + 0.01);  // it came down to the ground
}

TEST(SubmeshRelaxation, PullSlidesTheFreeSquareAlongTheFixedOneTowardItsAim) {
  TwoSquares s;
  const Positions start = as_rows(s.x);
  std::vector<int> free;
  for (int v = 0; v < start.rows(); ++v)
    if (s.prims.vertex_object[static_cast<std::size_t>(v)] == 1) free.push_back(v);
  const Positions aim = moved_upper(s, start, Vec3(0.1, 0, -0.2));  // sideways, and down into the lower one
  Positions x = start;
  const RelaxationReport r = pull_toward_aims(s.prims, s.rest, free, aim, 1e-3, 0.25, nullptr, x);
  double sideways = 0.0;
  for (int v : free) sideways += (x(v, 0) - start(v, 0)) / static_cast<double>(free.size());
  std::printf("[pull] Newton %d, mean sideways %.4f m, distance to aims %.3g -> %.3g m\n", r.newton_iterations, sideways,
              r.max_target_distance_before, r.max_target_distance_after);
  EXPECT_TRUE(test::intersection_free(x, s.prims.faces));
  EXPECT_NEAR(sideways, 0.1, 5e-3);
  EXPECT_TRUE(x.topRows(9) == start.topRows(9));  // the fixed square is untouched
}

}  // namespace
}  // namespace pd
