// Tests of build_topology (edges, counts, hinge convention, boundary flags) and validate_mesh (each
// rejected defect, with the message naming the mesh and the offending element, and acceptance of every
// procedural shape).
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "geometry/shapes.h"
#include "geometry/topology.h"
#include "util/input_error.h"

namespace pd {
namespace {

TriMesh make_mesh(const std::vector<Vec3>& points, const std::vector<std::array<int, 3>>& faces) {
  TriMesh m;
  m.V.resize(static_cast<int>(points.size()), 3);
  for (std::size_t i = 0; i < points.size(); ++i) m.V.row(static_cast<int>(i)) = points[i].transpose();
  m.F.resize(static_cast<int>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f) m.F.row(static_cast<int>(f)) << faces[f][0], faces[f][1], faces[f][2];
  return m;
}

// Unit square split along 0-2: face 0 = (0, 1, 2), face 1 = (0, 2, 3), both counter-clockwise from +z.
TriMesh two_triangles() {
  return make_mesh({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 3}});
}

// True if (a, b, c) is face f up to cyclic rotation (same orientation).
bool is_face_rotation(const TriMesh& m, int f, int a, int b, int c) {
  for (int k = 0; k < 3; ++k)
    if (m.F(f, k) == a && m.F(f, (k + 1) % 3) == b && m.F(f, (k + 2) % 3) == c) return true;
  return false;
}

int find_face(const TriMesh& m, int a, int b, int c) {
  for (int f = 0; f < m.num_faces(); ++f)
    if (is_face_rotation(m, f, a, b, c)) return f;
  return -1;
}

// validate_mesh must throw InputError with exactly `message` after "<what>: ".
void expect_invalid(const TriMesh& m, const std::string& message) {
  const std::string what = "scene.json: objects[1].mesh";
  try {
    validate_mesh(m, what);
    ADD_FAILURE() << "accepted; expected: " << message;
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), what + ": " + message);
  }
}

// ---- build_topology --------------------------------------------------------------------------------

TEST(BuildTopology, TwoTrianglesEdgesCountsHingeAndBoundary) {
  const Topology t = build_topology(two_triangles());
  const std::vector<std::array<int, 2>> edges{{0, 1}, {0, 2}, {0, 3}, {1, 2}, {2, 3}};
  EXPECT_EQ(t.edges, edges);
  EXPECT_EQ(t.edge_face_count, (std::vector<int>{1, 2, 1, 1, 1}));
  ASSERT_EQ(t.hinges.size(), 1u);
  // Face 0 (0, 1, 2) runs the shared edge 2 -> 0 with 1 opposite; face 1's opposite vertex is 3.
  EXPECT_EQ(t.hinges[0].v, (std::array<int, 4>{2, 0, 1, 3}));
  EXPECT_EQ(t.boundary_vertex, (std::vector<char>{1, 1, 1, 1}));
  EXPECT_FALSE(t.closed());
}

TEST(BuildTopology, HingeConventionHoldsOnEveryInteriorEdge) {
  // For each hinge: (v0, v1, v2) is the lower-indexed face of the edge, counter-clockwise, and
  // (v1, v0, v3) is the other face, counter-clockwise.
  for (const TriMesh& m : {make_icosphere(1.0, 2), make_rectangle(1.0, 1.0, 4, 3), make_box(Vec3(1, 2, 3), 2)}) {
    const Topology t = build_topology(m);
    int interior = 0;
    for (int c : t.edge_face_count) interior += (c == 2);
    ASSERT_EQ(static_cast<int>(t.hinges.size()), interior);
    std::size_t h = 0;
    for (std::size_t e = 0; e < t.edges.size(); ++e) {
      if (t.edge_face_count[e] != 2) continue;
      const auto& v = t.hinges[h++].v;
      // Hinges follow the order of `edges`.
      EXPECT_EQ(std::min(v[0], v[1]), t.edges[e][0]);
      EXPECT_EQ(std::max(v[0], v[1]), t.edges[e][1]);
      const int first = find_face(m, v[0], v[1], v[2]), second = find_face(m, v[1], v[0], v[3]);
      ASSERT_GE(first, 0);
      ASSERT_GE(second, 0);
      EXPECT_LT(first, second);
    }
  }
}

TEST(BuildTopology, EdgesSortedUniqueAndEulerConsistent) {
  const TriMesh m = make_icosphere(1.0, 3);
  const Topology t = build_topology(m);
  EXPECT_TRUE(std::is_sorted(t.edges.begin(), t.edges.end()));
  EXPECT_EQ(std::adjacent_find(t.edges.begin(), t.edges.end()), t.edges.end());
  for (const auto& e : t.edges) EXPECT_LT(e[0], e[1]);
  EXPECT_EQ(t.edges.size() * 2, static_cast<std::size_t>(m.num_faces()) * 3);  // closed: E = 3F/2
  EXPECT_TRUE(t.closed());
  EXPECT_EQ(std::count(t.boundary_vertex.begin(), t.boundary_vertex.end(), 1), 0);
}

TEST(BuildTopology, BoundaryVertexFlagsOnRectangle) {
  const int cx = 5, cy = 4;
  const TriMesh m = make_rectangle(1.0, 1.0, cx, cy);
  const Topology t = build_topology(m);
  for (int j = 0; j <= cy; ++j)
    for (int i = 0; i <= cx; ++i) {
      const bool edge = i == 0 || j == 0 || i == cx || j == cy;
      EXPECT_EQ(t.boundary_vertex[j * (cx + 1) + i], edge ? 1 : 0) << i << "," << j;
    }
  // E = 3 cx cy + cx + cy; boundary edges 2 (cx + cy).
  EXPECT_EQ(static_cast<int>(t.edges.size()), 3 * cx * cy + cx + cy);
  EXPECT_EQ(std::count(t.edge_face_count.begin(), t.edge_face_count.end(), 1), 2 * (cx + cy));
}

TEST(BuildTopology, NonManifoldEdgeCountedWithoutHinge) {
  const TriMesh m = make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}},
                              {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}});
  const Topology t = build_topology(m);
  EXPECT_EQ(t.edge_face_count[0], 3);  // edge (0, 1) sorts first
  EXPECT_TRUE(t.hinges.empty());
}

TEST(BuildTopology, HandlesMoreThan100KVertices) {
  // 163842 vertices, 327680 faces; the sort-based construction is O(m log m).
  const TriMesh m = make_icosphere(1.0, 7);
  const Topology t = build_topology(m);
  EXPECT_EQ(t.edges.size(), 491520u);
  EXPECT_EQ(t.hinges.size(), 491520u);
  EXPECT_TRUE(t.closed());
}

// ---- validate_mesh: rejections ---------------------------------------------------------------------

TEST(ValidateMesh, RejectsDegenerateTriangle) {
  // Face 1's vertices are collinear.
  expect_invalid(make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}}, {{0, 1, 2}, {0, 3, 1}}),
                 "face 1 has zero area");
  // Below the relative threshold 1e-12 * bbox_diagonal^2, not exactly zero.
  expect_invalid(make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 1e-13, 0}}, {{0, 1, 2}, {1, 0, 3}}),
                 "face 1 has zero area");
}

TEST(ValidateMesh, RejectsRepeatedVertex) {
  expect_invalid(make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}, {2, 1, 1}}), "face 1 repeats vertex 1");
}

TEST(ValidateMesh, RejectsNonManifoldEdge) {
  // Three faces on edge (0, 1), with orientations that would otherwise be acceptable pairwise.
  expect_invalid(make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}},
                           {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}}),
                 "edge between vertices 0 and 1 is shared by 3 faces (0, 1, 2); a manifold edge has at most 2");
}

TEST(ValidateMesh, RejectsInconsistentOrientation) {
  // Face 1 is (0, 3, 2) flipped: both faces run 0 -> 2.
  expect_invalid(make_mesh({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 3, 2}}),
                 "faces 0 and 1 traverse the edge between vertices 0 and 2 in the same direction "
                 "(inconsistent orientation)");
  // A single flipped face in a closed mesh.
  TriMesh sphere = make_icosphere(1.0, 1);
  std::swap(sphere.F(17, 1), sphere.F(17, 2));
  EXPECT_THROW(validate_mesh(sphere, "sphere"), InputError);
}

TEST(ValidateMesh, RejectsUnusedVertex) {
  expect_invalid(make_mesh({{0, 0, 0}, {1, 0, 0}, {5, 5, 5}, {0, 1, 0}}, {{0, 1, 3}}),
                 "vertex 2 is not used by any face");
}

TEST(ValidateMesh, RejectsOutOfRangeIndex) {
  expect_invalid(make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 3}}),
                 "face 1 references vertex 3, which does not exist (the mesh has 3 vertices)");
  expect_invalid(make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, -1, 2}}),
                 "face 0 references vertex -1, which does not exist (the mesh has 3 vertices)");
}

TEST(ValidateMesh, RejectsNonFiniteCoordinate) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  expect_invalid(make_mesh({{0, 0, 0}, {1, nan, 0}, {0, 1, 0}}, {{0, 1, 2}}), "vertex 1 has a non-finite coordinate");
  expect_invalid(make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, -inf}}, {{0, 1, 2}}), "vertex 2 has a non-finite coordinate");
}

TEST(ValidateMesh, RejectsEmptyMesh) {
  expect_invalid(TriMesh{}, "mesh has no faces");
}

// ---- validate_mesh: acceptance ---------------------------------------------------------------------

TEST(ValidateMesh, AcceptsAllProceduralShapes) {
  EXPECT_NO_THROW(validate_mesh(make_rectangle(2.0, 1.0, 8, 5), "rectangle"));
  EXPECT_NO_THROW(validate_mesh(make_rectangle(1e-3, 1e-3, 1, 1), "tiny rectangle"));
  EXPECT_NO_THROW(validate_mesh(make_rectangle_equilateral(2.0, 1.0, 9), "equilateral"));
  for (int s = 0; s <= 4; ++s) EXPECT_NO_THROW(validate_mesh(make_icosphere(0.5, s), "icosphere"));
  for (int n = 1; n <= 4; ++n) EXPECT_NO_THROW(validate_mesh(make_box(Vec3(1.0, 0.2, 3.0), n), "box"));
  EXPECT_NO_THROW(validate_mesh(make_cylinder(0.3, 1.0, 3, 1, false), "cylinder"));
  EXPECT_NO_THROW(validate_mesh(make_cylinder(0.3, 1.0, 24, 6, false), "cylinder"));
  EXPECT_NO_THROW(validate_mesh(make_cylinder(0.3, 1.0, 24, 6, true), "capped cylinder"));
  EXPECT_NO_THROW(validate_mesh(make_cylinder(0.3, 1.0, 3, 1, true), "capped cylinder"));
}

}  // namespace
}  // namespace pd
