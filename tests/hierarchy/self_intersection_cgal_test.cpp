// count_self_intersections (hierarchy/self_intersection_cgal.h): a flat sheet and a bent one have
// none; a vertex folded over its neighbours is found; two triangles crossing count one pair; faces
// that are not a polygon mesh get -1.
#include "hierarchy/self_intersection_cgal.h"

#include <gtest/gtest.h>

#include "geometry/shapes.h"

namespace pd {
namespace {

TEST(SelfIntersection, FlatAndBentSheetsHaveNoneAndCrossingTrianglesCountOnePair) {
  TriMesh sheet = make_rectangle(1.0, 1.0, 4, 4);
  EXPECT_EQ(count_self_intersections(sheet.V, sheet.F), 0);
  for (Eigen::Index v = 0; v < sheet.V.rows(); ++v) sheet.V(v, 2) = 0.3 * sheet.V(v, 0) * sheet.V(v, 0);
  EXPECT_EQ(count_self_intersections(sheet.V, sheet.F), 0);

  Positions V(6, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0,        // triangle in z = 0
      0.2, 0.2, -1, 0.2, 0.2, 1, 2, 2, 0;  // a triangle through it
  Faces F(2, 3);
  F << 0, 1, 2, 3, 4, 5;
  EXPECT_EQ(count_self_intersections(V, F), 1);
  V(3, 2) = 0.5;  // lifted clear of it
  EXPECT_EQ(count_self_intersections(V, F), 0);
}

TEST(SelfIntersection, AVertexFoldedOverItsNeighboursIsFound) {
  // 4 x 4 cells of 0.25 m; the centre vertex (12) slid 0.6 m along x in the sheet's plane, past its
  // ring: its faces fold over faces beyond it (the fold-overs safe upsampling left on drape-sphere).
  // Slid 0.1 m, within its ring, nothing folds.
  TriMesh sheet = make_rectangle(1.0, 1.0, 4, 4);
  sheet.V(12, 0) += 0.1;
  EXPECT_EQ(count_self_intersections(sheet.V, sheet.F), 0);
  sheet.V(12, 0) += 0.5;
  EXPECT_GT(count_self_intersections(sheet.V, sheet.F), 0);
}

TEST(SelfIntersection, FacesThatAreNotAPolygonMeshGetNoAnswer) {
  Positions V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0;
  Faces F(3, 3);
  F << 0, 1, 2, 0, 1, 2, 1, 3, 2;  // the first face twice
  EXPECT_EQ(count_self_intersections(V, F), -1);
}

}  // namespace
}  // namespace pd
