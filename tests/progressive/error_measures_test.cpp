// Error measures (progressive/error_measures.h) on constructed cases with known answers: translated
// copies, one displaced vertex, planes at known offsets, accelerations that differ at one frame,
// per-frame second differences with a spike at a seam.
#include "progressive/error_measures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace pd {
namespace {

// A flat grid of (cells + 1)^2 vertices in the z = z0 plane covering [0, sx] x [0, sy] (m), two
// triangles per cell.
TriMesh grid(int cells, double sx, double sy, double z0 = 0.0) {
  TriMesh m;
  const int n = cells + 1;
  m.V.resize(n * n, 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) m.V.row(j * n + i) << sx * i / cells, sy * j / cells, z0;
  m.F.resize(2 * cells * cells, 3);
  int f = 0;
  for (int j = 0; j < cells; ++j)
    for (int i = 0; i < cells; ++i) {
      const int a = j * n + i;
      m.F.row(f++) << a, a + 1, a + n + 1;
      m.F.row(f++) << a, a + n + 1, a + n;
    }
  return m;
}

Positions translated(const Positions& V, const Vec3& d) {
  Positions out = V;
  out.rowwise() += d.transpose();
  return out;
}

TEST(ErrorMeasures, TranslatedCopyHasEveryVertexAtTheTranslationDistance) {
  const TriMesh m = grid(4, 1.0, 1.0);
  const Positions b = translated(m.V, Vec3(0.03, -0.04, 0.0));  // |d| = 0.05 m
  const DistanceStats s = vertex_distance(m.V, b, std::vector<char>(m.V.rows(), 1));
  EXPECT_EQ(s.count, 25u);
  EXPECT_NEAR(s.mean, 0.05, 1e-15);
  EXPECT_NEAR(s.p95, 0.05, 1e-15);
  EXPECT_NEAR(s.max, 0.05, 1e-15);
}

TEST(ErrorMeasures, SingleDisplacedVertexSetsTheMaxAndMeanButNotTheP95) {
  const TriMesh m = grid(4, 1.0, 1.0);  // 25 vertices: one displaced is 4 %, below the 95th percentile
  Positions b = m.V;
  b(12, 2) += 0.2;
  const DistanceStats s = vertex_distance(m.V, b, std::vector<char>(25, 1));
  EXPECT_DOUBLE_EQ(s.max, 0.2);
  EXPECT_NEAR(s.mean, 0.2 / 25, 1e-15);
  EXPECT_EQ(s.p95, 0.0);
}

TEST(ErrorMeasures, P95IsTheNearestRankValue) {
  // 20 values 1..20: ceil(0.95 * 20) - 1 = 18, the 19th smallest.
  std::vector<double> d;
  for (int i = 20; i >= 1; --i) d.push_back(i);
  const DistanceStats s = distance_stats(d);
  EXPECT_EQ(s.p95, 19.0);
  EXPECT_EQ(s.max, 20.0);
  EXPECT_DOUBLE_EQ(s.mean, 10.5);
  const DistanceStats one = distance_stats({0.7});
  EXPECT_EQ(one.p95, 0.7);
  const DistanceStats none = distance_stats({});
  EXPECT_EQ(none.count, 0u);
  EXPECT_TRUE(std::isnan(none.mean) && std::isnan(none.p95) && std::isnan(none.max));
}

TEST(ErrorMeasures, VertexDistanceLeavesOutObstacleVertices) {
  // Object 0 (vertices 0..2) simulated and moved 1 cm; object 1 (3..5) an obstacle moved 1 m.
  const std::vector<char> mask = simulated_vertices({0, 3, 6}, {0, 1});
  EXPECT_EQ(mask, (std::vector<char>{1, 1, 1, 0, 0, 0}));
  Positions a = Positions::Zero(6, 3), b = a;
  b.topRows(3).col(0).setConstant(0.01);
  b.bottomRows(3).col(1).setConstant(1.0);
  const DistanceStats s = vertex_distance(a, b, mask);
  EXPECT_EQ(s.count, 3u);
  EXPECT_DOUBLE_EQ(s.max, 0.01);
  EXPECT_THROW(vertex_distance(a, Positions::Zero(5, 3), mask), std::invalid_argument);
}

TEST(ErrorMeasures, SimulatedFacesKeepOnlyTheFacesOfSimulatedObjects) {
  Faces F(3, 3);
  F << 0, 1, 2, 3, 4, 5, 2, 1, 0;
  const Faces kept = simulated_faces(F, {0, 3, 6}, {0, 1});
  ASSERT_EQ(kept.rows(), 2);
  EXPECT_EQ(kept.row(0), F.row(0));
  EXPECT_EQ(kept.row(1), F.row(2));
  EXPECT_EQ(simulated_faces(F, {0, 3, 6}, {1, 1}).rows(), 0);
}

TEST(ErrorMeasures, HausdorffOfAPlaneAndTheSamePlaneShiftedAlongItsNormalIsTheShift) {
  const TriMesh a = grid(5, 1.0, 1.0, 0.0);
  const TriMesh b = grid(3, 1.0, 1.0, 0.1);  // a different mesh of the same square, 10 cm up
  EXPECT_NEAR(hausdorff_distance(a.V, a.F, b.V, b.F), 0.1, 1e-15);
  EXPECT_NEAR(hausdorff_distance(b.V, b.F, a.V, a.F), 0.1, 1e-15);
}

TEST(ErrorMeasures, HausdorffOfDifferentMeshesOfOneSquareIsZero) {
  // Every vertex of either lies on the other surface (in its plane, inside the square).
  const TriMesh a = grid(5, 1.0, 1.0), b = grid(2, 1.0, 1.0);
  EXPECT_LT(hausdorff_distance(a.V, a.F, b.V, b.F), 1e-15);
}

TEST(ErrorMeasures, HausdorffTakesTheLargerDirectionOfAHalfSquareAgainstTheSquare) {
  // Square [0,1]^2 against its left half [0,0.5] x [0,1]: the square's corners (1, y) are 0.5 m from
  // the half, while every vertex of the half lies on the square.
  const TriMesh whole = grid(2, 1.0, 1.0), half = grid(2, 0.5, 1.0);
  const TriangleSurface t_whole(whole.V, whole.F), t_half(half.V, half.F);
  EXPECT_NEAR(t_half.max_distance_from(whole.V, whole.F), 0.5, 1e-15);
  EXPECT_LT(t_whole.max_distance_from(half.V, half.F), 1e-15);
  EXPECT_NEAR(hausdorff_distance(half.V, half.F, t_half, whole.V, whole.F, t_whole), 0.5, 1e-15);
}

TEST(ErrorMeasures, PointToSurfaceDistanceIsExactOffTheTrianglesEdges) {
  // One triangle (0,0,0), (1,0,0), (0,1,0): above its interior, beside an edge, beyond a corner.
  Positions V(3, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  Faces F(1, 3);
  F << 0, 1, 2;
  const TriangleSurface s(V, F);
  EXPECT_NEAR(s.distance(Vec3(0.2, 0.2, 0.3)), 0.3, 1e-15);
  EXPECT_NEAR(s.distance(Vec3(0.5, -0.4, 0.3)), 0.5, 1e-15);                     // nearest: edge point (0.5, 0, 0)
  EXPECT_NEAR(s.distance(Vec3(-0.3, -0.4, 0.0)), 0.5, 1e-15);                    // nearest: corner (0, 0, 0)
  EXPECT_NEAR(s.distance(Vec3(1.0, 1.0, 0.0)), std::sqrt(0.5), 1e-15);           // nearest: (0.5, 0.5, 0)
  EXPECT_THROW(TriangleSurface(V, Faces(0, 3)), std::invalid_argument);
}

TEST(ErrorMeasures, HausdorffIgnoresVerticesNoFaceUses) {
  // An obstacle's vertices far away stay out once its faces are left out (simulated_faces).
  TriMesh a = grid(2, 1.0, 1.0);
  Positions V(a.V.rows() + 3, 3);
  V << a.V, Positions::Constant(3, 3, 50.0);
  EXPECT_LT(hausdorff_distance(V, a.F, a.V, a.F), 1e-15);
}

// Positions of `n` vertices at x = p(t) for all (a rigid motion along x), t the frame.
Positions at(double p, int n = 4) {
  Positions V = Positions::Zero(n, 3);
  V.col(0).setConstant(p);
  return V;
}

TEST(ErrorMeasures, AccelerationDifferenceIsTheSecondDifferenceInMetresPerFrameSquared) {
  const std::vector<char> all(4, 1);
  // Run k: x = t^2 (a = 2 per frame^2); run one: x = 3 t (a = 0). Any frames, no h involved.
  EXPECT_NEAR(acceleration_difference(at(1), at(4), at(9), at(3), at(6), at(9), all), 2.0, 1e-15);
  // Equal motions: 0. Uniform velocity in both but different offsets: still 0.
  EXPECT_EQ(acceleration_difference(at(1), at(2), at(3), at(1), at(2), at(3), all), 0.0);
  EXPECT_NEAR(acceleration_difference(at(1), at(2), at(3), at(5), at(6), at(7), all), 0.0, 1e-15);
  // Only masked vertices count: vertex 3 jumps in run k but is left out.
  Positions jump = at(2);
  jump(3, 1) = 1.0;
  EXPECT_EQ(acceleration_difference(at(1), jump, at(3), at(1), at(2), at(3), {1, 1, 1, 0}), 0.0);
  EXPECT_NEAR(acceleration_difference(at(1), jump, at(3), at(1), at(2), at(3), all), 2.0, 1e-15);
  EXPECT_THROW(acceleration_difference(at(1), at(2, 3), at(3), at(1), at(2), at(3), all), std::invalid_argument);
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(ErrorMeasures, SeamJitterComparesSeamFramesWithTheMedianOfTheFramesAfterTheFirstSeam) {
  // Frames 0..10, d undefined at 0 and 10; seam T = 4: d(4), d(5) large; background after it.
  const std::vector<double> d = {kNaN, 0.0, 0.0, 0.0, 5e-3, 2e-3, 3e-4, 1e-4, 1e-4, 1e-4, kNaN};
  const SeamJitter j = seam_jitter(d, {4});
  EXPECT_EQ(j.seams, (std::vector<int>{4, 5}));
  EXPECT_EQ(j.seam_d, (std::vector<double>{5e-3, 2e-3}));
  EXPECT_EQ(j.max_seam_d, 5e-3);
  // Frames 6..9: sorted 1, 1, 1, 3 (e-4). Frames 1..3 (the first subset, the K = 1 run's own) are
  // left out: with them the median would be 0.5e-4 and the ratio twice as large.
  EXPECT_EQ(j.median_other, 1e-4);
  EXPECT_DOUBLE_EQ(j.ratio, 50.0);
}

TEST(ErrorMeasures, SeamJitterMedianOfAnEvenCountIsTheMeanOfTheMiddleTwoAndSeamsMerge) {
  // Seams 2 and 3 give frames 2, 3, 4 once each; the others after the first seam are 5, 6, 7, 8
  // (d = 4, 2, 3, 1).
  const std::vector<double> d = {kNaN, 1.0, 10.0, 20.0, 30.0, 4.0, 2.0, 3.0, 1.0, kNaN};
  const SeamJitter j = seam_jitter(d, {3, 2});
  EXPECT_EQ(j.seams, (std::vector<int>{2, 3, 4}));
  EXPECT_EQ(j.max_seam_d, 30.0);
  EXPECT_EQ(j.median_other, 2.5);
  EXPECT_EQ(j.ratio, 12.0);
}

TEST(ErrorMeasures, SeamJitterWithZeroBackgroundGivesInfiniteOrUndefinedRatio) {
  // Runs equal away from the seam (K = 1 and K = 2 agree bit for bit before it): median 0.
  const SeamJitter jump = seam_jitter({kNaN, 0.0, 0.0, 1e-3, 0.0, 0.0, kNaN}, {3});
  EXPECT_EQ(jump.median_other, 0.0);
  EXPECT_EQ(jump.max_seam_d, 1e-3);
  EXPECT_TRUE(std::isinf(jump.ratio) && jump.ratio > 0);
  const SeamJitter none = seam_jitter({kNaN, 0.0, 0.0, 0.0, 0.0, 0.0, kNaN}, {3});
  EXPECT_EQ(none.max_seam_d, 0.0);
  EXPECT_TRUE(std::isnan(none.ratio));
}

TEST(ErrorMeasures, SeamJitterAtTheLastDefinedFrameHasAnUndefinedSecondEntry) {
  // T = 5 of frames 0..6: d(6) needs frame 7, so it is NaN and the max comes from d(5) alone; no
  // frame after the seam is left for the background, so the ratio is undefined.
  const SeamJitter j = seam_jitter({kNaN, 1.0, 1.0, 1.0, 1.0, 8.0, kNaN}, {5});
  EXPECT_EQ(j.seams, (std::vector<int>{5, 6}));
  EXPECT_TRUE(std::isnan(j.seam_d[1]));
  EXPECT_EQ(j.max_seam_d, 8.0);
  EXPECT_TRUE(std::isnan(j.median_other));
  EXPECT_TRUE(std::isnan(j.ratio));
  EXPECT_THROW(seam_jitter({kNaN, 1.0, kNaN}, {3}), std::invalid_argument);
  EXPECT_THROW(seam_jitter({kNaN, 1.0, kNaN}, {-1}), std::invalid_argument);
  EXPECT_TRUE(std::isnan(seam_jitter({kNaN, 1.0, kNaN}, {1}).median_other));  // no other frame
}

TEST(ErrorMeasures, MaxSecondDifferenceIsTheLargestNormOfASelectedVerticesSecondDifference) {
  const std::vector<char> all(4, 1);
  // x = t^2 along x for every vertex: second difference 2 m per frame^2 (no h involved). Uniform
  // velocity: 0, not the first difference.
  EXPECT_EQ(max_second_difference(at(1), at(4), at(9), all), 2.0);
  EXPECT_EQ(max_second_difference(at(1), at(2), at(3), all), 0.0);
  // Vertex 1 jumps by (0, 0.375, 0.5) in the middle frame: |(0, -0.75, -1)| = 1.25 exactly.
  Positions jump = at(0);
  jump.row(1) << 0.0, 0.375, 0.5;
  EXPECT_EQ(max_second_difference(at(0), jump, at(0), all), 1.25);
  // The mask leaves the jumping vertex out (an obstacle), and an empty selection gives 0.
  EXPECT_EQ(max_second_difference(at(0), jump, at(0), {1, 0, 1, 1}), 0.0);
  EXPECT_EQ(max_second_difference(at(1), at(4), at(9), {0, 0, 0, 0}), 0.0);
  EXPECT_THROW(max_second_difference(at(0), at(0, 3), at(0), all), std::invalid_argument);
  EXPECT_THROW(max_second_difference(at(0), at(0), at(0), {1, 1, 1}), std::invalid_argument);
}

TEST(ErrorMeasures, SeamPopIsThePeakOverTheNearestRank95thPercentileOfTheWindowAroundTheSeam) {
  // Frames 0..60, m undefined at 0 and 60; seam 30. The window is [10, 51] without 30 and 31: 40
  // values, all 1 except 2, 3 and 4; the nearest rank ceil(0.95 * 40) - 1 = 37 is the third largest,
  // 2 (the max would be 4, rank 38 gives 3, an interpolated p95 2.05). Frames 9 and 52, just
  // outside the window, are 50: had either been counted, there would be 41 values and rank 38.
  std::vector<double> m(61, 50.0);
  m.front() = m.back() = kNaN;
  for (int t = 10; t <= 51; ++t) m[t] = 1.0;
  m[12] = 2.0, m[20] = 3.0, m[40] = 4.0;
  m[30] = 10.0, m[31] = 6.0;  // the peak is the larger of the two seam frames
  const std::vector<SeamPop> p = seam_pops(m, {30});
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0].seam, 30);
  EXPECT_EQ(p[0].peak, 10.0);
  EXPECT_EQ(p[0].background_frames, 40);
  EXPECT_EQ(p[0].background, 2.0);
  EXPECT_EQ(p[0].pop, 5.0);
}

TEST(ErrorMeasures, SeamPopLeavesEverySeamsFramesOutOfEveryBackground) {
  // Frames 0..20, seams 5 and 10 (given twice and out of order: merged, in increasing order). m = 1
  // except at the seams. Fewer than 20 values, so the background is their max: had seam 10's
  // frames (20) entered seam 5's background, its pop would be 0.4.
  std::vector<double> m(21, 1.0);
  m.front() = m.back() = kNaN;
  m[5] = 8.0, m[10] = m[11] = 20.0;
  const std::vector<SeamPop> p = seam_pops(m, {10, 5, 10});
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0].seam, 5);
  EXPECT_EQ(p[1].seam, 10);
  for (const SeamPop& s : p) {
    EXPECT_EQ(s.background_frames, 15) << s.seam;  // frames 1..19 without 5, 6, 10, 11
    EXPECT_EQ(s.background, 1.0) << s.seam;
  }
  EXPECT_EQ(p[0].peak, 8.0);
  EXPECT_EQ(p[0].pop, 8.0);
  EXPECT_EQ(p[1].pop, 20.0);
}

TEST(ErrorMeasures, SeamPopAtTheLevelsStartTakesThePeakFromFrame1) {
  // Seam 0: m(0) is never defined, so the peak is m(1); frames 0 and 1 are left out of the
  // background, which is frames 2..9 (max 0.5: fewer than 20 values).
  std::vector<double> m(11, 0.25);
  m.front() = m.back() = kNaN;
  m[1] = 4.0, m[5] = 0.5;
  const std::vector<SeamPop> p = seam_pops(m, {0});
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0].peak, 4.0);
  EXPECT_EQ(p[0].background_frames, 8);
  EXPECT_EQ(p[0].background, 0.5);
  EXPECT_EQ(p[0].pop, 8.0);
}

TEST(ErrorMeasures, SeamPopWithoutDefinedFramesIsNaNButKeepsWhatIsDefined) {
  // Frames 3 and 4 lack a neighbour: no peak, pop NaN; the background is still reported.
  const std::vector<SeamPop> gap = seam_pops({kNaN, 1.0, 1.0, kNaN, kNaN, 1.0, 1.0, kNaN}, {3});
  EXPECT_TRUE(std::isnan(gap[0].peak));
  EXPECT_EQ(gap[0].background, 1.0);
  EXPECT_EQ(gap[0].background_frames, 4);
  EXPECT_TRUE(std::isnan(gap[0].pop));
  // Frames 0..2: seam 0's only defined frame is its own peak; no background frame is left.
  const std::vector<SeamPop> alone = seam_pops({kNaN, 2.0, kNaN}, {0});
  EXPECT_EQ(alone[0].peak, 2.0);
  EXPECT_EQ(alone[0].background_frames, 0);
  EXPECT_TRUE(std::isnan(alone[0].background));
  EXPECT_TRUE(std::isnan(alone[0].pop));
}

TEST(ErrorMeasures, SeamPopWithZeroBackgroundIsInfiniteOrUndefined) {
  // A still scene that jolts at the seam's second frame: infinite; no jolt either: 0 / 0, NaN.
  const std::vector<SeamPop> jolt = seam_pops({kNaN, 0.0, 0.0, 0.0, 3.0, 0.0, 0.0, kNaN}, {3});
  EXPECT_EQ(jolt[0].peak, 3.0);
  EXPECT_EQ(jolt[0].background, 0.0);
  EXPECT_TRUE(std::isinf(jolt[0].pop) && jolt[0].pop > 0);
  const std::vector<SeamPop> still = seam_pops({kNaN, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, kNaN}, {3});
  EXPECT_EQ(still[0].peak, 0.0);
  EXPECT_TRUE(std::isnan(still[0].pop));
}

TEST(ErrorMeasures, SeamPopRefusesASeamWithoutTheFrameAfterIt) {
  const std::vector<double> m = {kNaN, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, kNaN};  // frames 0..7
  EXPECT_EQ(seam_pops(m, {6}).size(), 1u);  // s + 1 = 7 is the last frame
  EXPECT_THROW(seam_pops(m, {7}), std::invalid_argument);
  EXPECT_THROW(seam_pops(m, {-1}), std::invalid_argument);
  EXPECT_THROW(seam_pops({}, {0}), std::invalid_argument);
}

}  // namespace
}  // namespace pd
