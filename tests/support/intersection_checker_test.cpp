// Tests of the CGAL-based intersection checker: separated, crossing, folded and closed shapes, the
// adjacency rules (shared edges and vertices), degenerate faces, non-manifold soups, and agreement of
// the Surface_mesh and triangle-soup paths.
#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>
#include <stdexcept>
#include <utility>
#include <vector>

#include "geometry/shapes.h"
#include "support/intersection_checker.h"

namespace pd::test {
namespace {

using FacePairs = std::vector<std::pair<int, int>>;

// Meshes stacked into one scene (vertex and face indices offset), as the simulator stores frames.
TriMesh stack(std::initializer_list<TriMesh> parts) {
  TriMesh s;
  for (const TriMesh& m : parts) {
    const Eigen::Index n0 = s.V.rows(), m0 = s.F.rows();
    s.V.conservativeResize(n0 + m.V.rows(), 3);
    s.V.bottomRows(m.V.rows()) = m.V;
    s.F.conservativeResize(m0 + m.F.rows(), 3);
    s.F.bottomRows(m.F.rows()) = m.F.array() + static_cast<int>(n0);
  }
  return s;
}

TriMesh shifted(TriMesh m, double x, double y, double z) {
  m.V.rowwise() += Eigen::RowVector3d(x, y, z);
  return m;
}

TriMesh triangles(const std::vector<Vec3>& points, const std::vector<std::array<int, 3>>& faces) {
  TriMesh m;
  m.V.resize(static_cast<int>(points.size()), 3);
  for (std::size_t i = 0; i < points.size(); ++i) m.V.row(static_cast<int>(i)) = points[i].transpose();
  m.F.resize(static_cast<int>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f)
    m.F.row(static_cast<int>(f)) << faces[f][0], faces[f][1], faces[f][2];
  return m;
}

// A 0.4 m x 0.2 m sheet (20 x 10 cells of 2 cm) folded about x = 0: the right half (u = x > 0) is
// mirrored onto the left half at height z(u).
template <class Height>
TriMesh folded_sheet(Height z) {
  TriMesh m = make_rectangle(0.4, 0.2, 20, 10);
  for (int i = 0; i < m.num_vertices(); ++i) {
    const double u = m.V(i, 0);
    if (u > 1e-12) m.V.row(i) << -u, m.V(i, 1), z(u);
  }
  return m;
}

// The mesh path and the soup path must agree on valid meshes; returns the mesh path's report.
IntersectionReport check_both_paths(const TriMesh& m) {
  const IntersectionReport mesh = find_intersections(m.V, m.F);
  const IntersectionReport soup = find_intersections_in_soup(m.V, m.F);
  EXPECT_FALSE(mesh.triangle_soup) << "expected a valid polygon mesh";
  EXPECT_EQ(mesh.face_pairs, soup.face_pairs);
  EXPECT_EQ(mesh.degenerate_faces, soup.degenerate_faces);
  EXPECT_EQ(mesh.intersecting_pairs, static_cast<int>(mesh.face_pairs.size()));
  return mesh;
}

TEST(IntersectionChecker, SeparatedSheetsAreFree) {
  const TriMesh sheet = make_rectangle(0.5, 0.5, 10, 10);
  const TriMesh scene = stack({sheet, shifted(sheet, 0.1, 0.0, 0.01)});
  EXPECT_EQ(check_both_paths(scene).intersecting_pairs, 0);
  EXPECT_TRUE(intersection_free(scene.V, scene.F));
}

TEST(IntersectionChecker, TwoCrossingTrianglesAreOnePair) {
  // Triangle 1 stands in the plane x = 0.3 and pierces triangle 0 (z = 0) along a segment inside it.
  const std::vector<Vec3> points = {{0, 0, 0},        {1, 0, 0},       {0, 1, 0},
                                    {0.3, 0.1, -0.5}, {0.3, 0.1, 0.5}, {0.3, 0.5, 0}};
  const TriMesh m = triangles(points, {{0, 1, 2}, {3, 4, 5}});
  const IntersectionReport r = check_both_paths(m);
  EXPECT_EQ(r.intersecting_pairs, 1);
  EXPECT_EQ(r.face_pairs, (FacePairs{{0, 1}}));
  EXPECT_FALSE(intersection_free(m.V, m.F));
}

TEST(IntersectionChecker, DetectsAFoldedSheetPassingThroughItself) {
  // The upper half rises, then dips below z = 0 from u = 0.15 m on (between grid columns).
  const TriMesh m = folded_sheet([](double u) { return 0.03 * u - 0.2 * u * u; });
  const IntersectionReport r = check_both_paths(m);
  EXPECT_GT(r.intersecting_pairs, 0);
  for (const auto& [f, g] : r.face_pairs) {  // always one face of each half (left: x < 0 at z = 0)
    const bool f_lower = m.V(m.F(f, 0), 2) == 0 && m.V(m.F(f, 1), 2) == 0 && m.V(m.F(f, 2), 2) == 0;
    const bool g_lower = m.V(m.F(g, 0), 2) == 0 && m.V(m.F(g, 1), 2) == 0 && m.V(m.F(g, 2), 2) == 0;
    EXPECT_NE(f_lower, g_lower) << f << ", " << g;
  }
}

TEST(IntersectionChecker, SheetFoldedOntoItselfWithMicrometreGapIsFree) {
  const TriMesh m = folded_sheet([](double) { return 1e-6; });
  EXPECT_EQ(check_both_paths(m).intersecting_pairs, 0);
  EXPECT_TRUE(intersection_free(m.V, m.F));
  // Touching (gap 0) is an intersection: the upper half then lies in the lower half's faces.
  const TriMesh touching = folded_sheet([](double) { return 0.0; });
  EXPECT_GT(check_both_paths(touching).intersecting_pairs, 0);
}

TEST(IntersectionChecker, ClosedIcosphereIsFree) {
  const TriMesh sphere = make_icosphere(0.3, 3);
  EXPECT_EQ(check_both_paths(sphere).intersecting_pairs, 0);
  // Two overlapping spheres (two components) intersect; apart, they do not.
  EXPECT_GT(check_both_paths(stack({sphere, shifted(sphere, 0.4, 0.0, 0.0)})).intersecting_pairs, 0);
  EXPECT_EQ(check_both_paths(stack({sphere, shifted(sphere, 0.61, 0.0, 0.0)})).intersecting_pairs, 0);
}

TEST(IntersectionChecker, DetectsASpherePushedHalfwayThroughASheet) {
  const TriMesh sheet = make_rectangle(1.0, 1.0, 20, 20);
  const TriMesh sphere = shifted(make_icosphere(0.2, 3), 0.013, 0.007, 0.004);
  const TriMesh scene = stack({sheet, sphere});
  const IntersectionReport r = check_both_paths(scene);
  EXPECT_GT(r.intersecting_pairs, 10);
  for (const auto& [f, g] : r.face_pairs) {  // every pair is one sheet face and one sphere face
    EXPECT_LT(f, sheet.num_faces());
    EXPECT_GE(g, sheet.num_faces());
  }
  EXPECT_FALSE(intersection_free(scene.V, scene.F));
}

TEST(IntersectionChecker, NeverReportsAdjacentFacesOfValidMeshes) {
  std::vector<TriMesh> meshes = {
      make_rectangle(1.0, 0.5, 12, 6, GridDiagonals::Checkerboard),  // coplanar neighbours everywhere
      make_rectangle(1.0, 0.5, 12, 6, GridDiagonals::Rows),
      make_rectangle(1.0, 0.5, 12, 6, GridDiagonals::Uniform),
      make_rectangle_equilateral(1.0, 0.5, 10),
      make_box(Vec3(0.3, 0.2, 0.1), 4),
      make_cylinder(0.1, 0.4, 16, 5, true),
      make_icosphere(1.0, 2),
  };
  TriMesh wavy = make_rectangle(1.0, 1.0, 30, 30);
  for (int i = 0; i < wavy.num_vertices(); ++i)
    wavy.V(i, 2) = 0.1 * std::sin(9 * wavy.V(i, 0)) * std::cos(7 * wavy.V(i, 1));
  meshes.push_back(wavy);
  // A sharp crease: the right half swung back over the left half, 0.01 rad apart.
  meshes.push_back(folded_sheet([](double u) { return u * std::sin(0.01); }));
  for (const TriMesh& m : meshes) {
    const IntersectionReport r = check_both_paths(m);
    EXPECT_EQ(r.intersecting_pairs, 0);
    EXPECT_TRUE(r.degenerate_faces.empty());
  }
}

// The adjacency semantics themselves: sharing an edge counts only when folded flat onto each other;
// sharing a vertex counts when one face passes through the other.
TEST(IntersectionChecker, AdjacentFacesCountOnlyWhenTheyGenuinelyOverlap) {
  auto hinge = [](const Vec3& last) {  // faces (0, 1, 2) and (1, 0, 3) share the edge 0-1
    return triangles({{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, last}, {{0, 1, 2}, {1, 0, 3}});
  };
  EXPECT_EQ(check_both_paths(hinge({0.5, 0.8, 0})).intersecting_pairs, 1);   // folded flat onto face 0
  EXPECT_EQ(check_both_paths(hinge({0.5, -0.8, 0})).intersecting_pairs, 0);  // flat, other side
  EXPECT_EQ(check_both_paths(hinge({0.5, 0.8, 1e-9})).intersecting_pairs, 0);  // nearly folded
  // Two faces on the same three vertices (a closed two-triangle "pillow"): full overlap.
  EXPECT_EQ(check_both_paths(triangles({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 1}})).face_pairs,
            (FacePairs{{0, 1}}));

  // Faces 0 and 2 of a manifold fan around vertex 0 share only that vertex (face 1 joins them).
  auto fan = [](const Vec3& b, const Vec3& c) {
    return triangles({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, b, c}, {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}});
  };
  // Face 2's far edge pierces face 0: reported. Both above face 0: not.
  EXPECT_EQ(check_both_paths(fan({0.4, 0.2, 0.5}, {0.2, 0.4, -0.5})).face_pairs, (FacePairs{{0, 2}}));
  EXPECT_EQ(check_both_paths(fan({0.4, 0.2, 0.5}, {0.2, 0.4, 0.5})).intersecting_pairs, 0);

  // The same rule on a bow tie (two faces, one shared vertex: non-manifold, so the soup path), where
  // coplanar cases can be isolated: a face inside the other's corner overlaps it; outside, not.
  auto bowtie = [](const Vec3& b, const Vec3& c) {
    const TriMesh m = triangles({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, b, c}, {{0, 1, 2}, {0, 3, 4}});
    const IntersectionReport r = find_intersections(m.V, m.F);
    EXPECT_TRUE(r.triangle_soup);
    return r.intersecting_pairs;
  };
  EXPECT_EQ(bowtie({0.4, 0.2, 0.5}, {0.2, 0.4, -0.5}), 1);
  EXPECT_EQ(bowtie({0.4, 0.2, 0.5}, {0.2, 0.4, 0.5}), 0);
  EXPECT_EQ(bowtie({0.2, 0.1, 0}, {0.1, 0.2, 0}), 1);
  EXPECT_EQ(bowtie({-1, 0, 0}, {0, -1, 0}), 0);
}

TEST(IntersectionChecker, DegenerateTrianglesDoNotCrash) {
  const TriMesh sheet = make_rectangle(0.5, 0.5, 5, 5);
  // A zero-area face as its own component (a valid mesh: the Surface_mesh path).
  const TriMesh sliver = triangles({{0, 0, 0.1}, {0.1, 0, 0.1}, {0.3, 0, 0.1}}, {{0, 1, 2}});
  const TriMesh scene = stack({sheet, sliver});
  const IntersectionReport r = find_intersections(scene.V, scene.F);
  EXPECT_FALSE(r.triangle_soup);
  EXPECT_EQ(r.intersecting_pairs, 0);
  EXPECT_EQ(r.degenerate_faces, std::vector<int>{sheet.num_faces()});
  EXPECT_FALSE(intersection_free(scene.V, scene.F));  // cannot be certified
  EXPECT_EQ(find_intersections_in_soup(scene.V, scene.F).degenerate_faces, r.degenerate_faces);

  // Repeated indices and coincident points (the soup path).
  TriMesh repeated = stack({sheet, triangles({{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, {{0, 1, 2}})});
  repeated.F.conservativeResize(repeated.F.rows() + 1, 3);
  repeated.F.bottomRows(1) << 3, 3, 4;
  const IntersectionReport s = find_intersections(repeated.V, repeated.F);
  EXPECT_TRUE(s.triangle_soup);
  EXPECT_EQ(s.intersecting_pairs, 0);
  EXPECT_EQ(s.degenerate_faces, (std::vector<int>{sheet.num_faces(), sheet.num_faces() + 1}));
}

TEST(IntersectionChecker, HandlesNonManifoldSoups) {
  // Three pages on the spine 0-1 (an edge with three faces), 120 degrees apart: no intersection.
  const double c = std::cos(2.0944), s = std::sin(2.0944);
  const std::vector<Vec3> book = {{0, 0, 0},   {0, 1, 0},    {1, 0.5, 0},
                                  {c, 0.5, s}, {c, 0.5, -s}, {0.5, 0.5, 0}};
  const TriMesh three = triangles(book, {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}});
  const IntersectionReport r = find_intersections(three.V, three.F);
  EXPECT_TRUE(r.triangle_soup);
  EXPECT_EQ(r.intersecting_pairs, 0);
  // A fourth, smaller page lying inside the first one: the two overlap.
  const TriMesh four = triangles(book, {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}, {1, 0, 5}});
  EXPECT_EQ(find_intersections(four.V, four.F).face_pairs, (FacePairs{{0, 3}}));

  // Two closed boxes touching at one shared vertex index (a non-manifold vertex): free, and
  // crossing once one is pushed into the other.
  TriMesh a = make_box(Vec3(1, 1, 1), 1);
  TriMesh b = shifted(a, 1, 1, 1);
  int corner_a = -1, corner_b = -1;  // a's (+.5,+.5,+.5) corner and b's (-.5,-.5,-.5) corner coincide
  for (int i = 0; i < a.num_vertices(); ++i) {
    if (a.V.row(i).isApprox(Eigen::RowVector3d(0.5, 0.5, 0.5))) corner_a = i;
    if (b.V.row(i).isApprox(Eigen::RowVector3d(0.5, 0.5, 0.5))) corner_b = i;
  }
  ASSERT_GE(corner_a, 0);
  ASSERT_GE(corner_b, 0);
  TriMesh pinched = stack({a, b});
  for (Eigen::Index k = a.F.size(); k < pinched.F.size(); ++k)
    if (pinched.F.data()[k] == a.num_vertices() + corner_b) pinched.F.data()[k] = corner_a;
  const IntersectionReport p = find_intersections(pinched.V, pinched.F);
  EXPECT_TRUE(p.triangle_soup);
  EXPECT_EQ(p.intersecting_pairs, 0);
  // b's far corner pulled to inside a drives b's faces through a's.
  for (int i = 0; i < b.num_vertices(); ++i)
    if (b.V.row(i).isApprox(Eigen::RowVector3d(1.5, 1.5, 1.5)))
      pinched.V.row(a.num_vertices() + i).setConstant(0.1);
  EXPECT_GT(find_intersections(pinched.V, pinched.F).intersecting_pairs, 0);

  // A flipped face makes the orientation inconsistent: the soup path, same answer.
  TriMesh flipped = make_rectangle(0.5, 0.5, 5, 5);
  std::swap(flipped.F(7, 0), flipped.F(7, 1));
  const IntersectionReport f = find_intersections(flipped.V, flipped.F);
  EXPECT_TRUE(f.triangle_soup);
  EXPECT_EQ(f.intersecting_pairs, 0);
}

TEST(IntersectionChecker, HandlesEmptyAndInvalidInput) {
  EXPECT_TRUE(intersection_free(Positions(0, 3), Faces(0, 3)));
  TriMesh m = make_rectangle(0.5, 0.5, 2, 2);
  m.F(0, 0) = m.num_vertices();
  EXPECT_THROW(find_intersections(m.V, m.F), std::invalid_argument);
  TriMesh n = make_rectangle(0.5, 0.5, 2, 2);
  n.V(0, 2) = std::nan("");
  EXPECT_THROW(find_intersections(n.V, n.F), std::invalid_argument);
}

}  // namespace
}  // namespace pd::test
