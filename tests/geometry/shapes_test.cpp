// Tests of the procedural shapes: exact counts, indexing, extents, orientation (outward normals,
// consistent winding), closedness and volume.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "geometry/shapes.h"
#include "geometry/topology.h"

namespace pd {
namespace {

const double kPi = std::acos(-1.0);

Vec3 vertex(const TriMesh& m, int i) { return m.V.row(i).transpose(); }

// Area-weighted normal (twice the area times the unit normal) of face f.
Vec3 face_normal(const TriMesh& m, int f) {
  const Vec3 a = vertex(m, m.F(f, 0)), b = vertex(m, m.F(f, 1)), c = vertex(m, m.F(f, 2));
  return (b - a).cross(c - a);
}

Vec3 centroid(const TriMesh& m, int f) {
  return (vertex(m, m.F(f, 0)) + vertex(m, m.F(f, 1)) + vertex(m, m.F(f, 2))) / 3.0;
}

// Sum of signed tetrahedron volumes (origin, a, b, c): the enclosed volume of a closed mesh, positive
// exactly when its normals point outward.
double signed_volume(const TriMesh& m) {
  double v = 0.0;
  for (int f = 0; f < m.num_faces(); ++f)
    v += vertex(m, m.F(f, 0)).dot(vertex(m, m.F(f, 1)).cross(vertex(m, m.F(f, 2)))) / 6.0;
  return v;
}

double total_area(const TriMesh& m) {
  double a = 0.0;
  for (int f = 0; f < m.num_faces(); ++f) a += 0.5 * face_normal(m, f).norm();
  return a;
}

// Independent of topology.cpp: in a closed, consistently oriented mesh every directed edge occurs
// exactly once and its reverse exactly once.
bool closed_and_consistently_oriented(const TriMesh& m) {
  std::map<std::pair<int, int>, int> directed;
  for (int f = 0; f < m.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) ++directed[{m.F(f, k), m.F(f, (k + 1) % 3)}];
  for (const auto& [edge, count] : directed) {
    const auto reverse = directed.find({edge.second, edge.first});
    if (count != 1 || reverse == directed.end() || reverse->second != 1) return false;
  }
  return true;
}

int euler_characteristic(const TriMesh& m) {
  const Topology t = build_topology(m);
  return m.num_vertices() - static_cast<int>(t.edges.size()) + m.num_faces();
}

// ---- rectangle -------------------------------------------------------------------------------------

TEST(Rectangle, CountsIndexingAndExtent) {
  const int cx = 5, cy = 3;
  const TriMesh m = make_rectangle(2.0, 0.6, cx, cy);
  EXPECT_EQ(m.num_vertices(), (cx + 1) * (cy + 1));
  EXPECT_EQ(m.num_faces(), 2 * cx * cy);
  for (int j = 0; j <= cy; ++j)
    for (int i = 0; i <= cx; ++i) {
      const Vec3 p = vertex(m, j * (cx + 1) + i);
      EXPECT_NEAR(p.x(), -1.0 + 2.0 * i / cx, 1e-15);
      EXPECT_NEAR(p.y(), -0.3 + 0.6 * j / cy, 1e-15);
      EXPECT_EQ(p.z(), 0.0);
    }
  // Corners exactly on +-size/2.
  EXPECT_EQ(vertex(m, 0), Vec3(-1.0, -0.3, 0.0));
  EXPECT_EQ(vertex(m, (cx + 1) * (cy + 1) - 1), Vec3(1.0, 0.3, 0.0));
}

// Checks every cell's diagonal against `up(i, j)`: true = (i, j)-(i+1, j+1), false = (i+1, j)-(i, j+1).
template <class Up>
void expect_diagonals(const TriMesh& m, int cx, int cy, Up up) {
  const int nx = cx + 1;
  const Topology t = build_topology(m);
  auto has_edge = [&](int a, int b) {
    const std::array<int, 2> e{std::min(a, b), std::max(a, b)};
    return std::binary_search(t.edges.begin(), t.edges.end(), e);
  };
  for (int j = 0; j < cy; ++j)
    for (int i = 0; i < cx; ++i) {
      const int a = j * nx + i;  // corners a (i,j), b (i+1,j), c (i+1,j+1), d (i,j+1)
      EXPECT_EQ(has_edge(a, a + nx + 1), up(i, j)) << "cell " << i << "," << j;
      EXPECT_EQ(has_edge(a + 1, a + nx), !up(i, j)) << "cell " << i << "," << j;
    }
}

TEST(Rectangle, AlternatesDiagonalsAsDocumented) {
  expect_diagonals(make_rectangle(1.0, 1.0, 4, 3), 4, 3, [](int i, int j) { return (i + j) % 2 == 0; });
}

TEST(Rectangle, RowsPatternAlternatesDiagonalsByRowAndUniformNever) {
  expect_diagonals(make_rectangle(1.0, 1.0, 4, 3, GridDiagonals::Rows), 4, 3,
                   [](int, int j) { return j % 2 == 0; });
  expect_diagonals(make_rectangle(1.0, 1.0, 4, 3, GridDiagonals::Uniform), 4, 3, [](int, int) { return true; });
}

TEST(Rectangle, NormalsPointAlongZAndAreasSumToWidthTimesHeight) {
  const TriMesh m = make_rectangle(1.5, 0.8, 6, 4);
  for (int f = 0; f < m.num_faces(); ++f) EXPECT_GT(face_normal(m, f).z(), 0.0) << "face " << f;
  EXPECT_NEAR(total_area(m), 1.5 * 0.8, 1e-14);
  EXPECT_EQ(euler_characteristic(m), 1);  // a disc
}

TEST(RectangleEquilateral, CountsExtentAndRowLayout) {
  const double w = 1.0, h = 1.0;
  const int cx = 10;
  const TriMesh m = make_rectangle_equilateral(w, h, cx);
  // rows = round(1 / (sqrt(3)/2 * 0.1)) = round(11.547) = 12.
  const int rows = 12;
  EXPECT_EQ(m.num_vertices(), (rows + 1) * (cx + 1) + (rows + 1) / 2);
  EXPECT_EQ(m.num_faces(), rows * (2 * cx + 1));
  EXPECT_EQ(m.V.col(0).minCoeff(), -0.5 * w);
  EXPECT_EQ(m.V.col(0).maxCoeff(), 0.5 * w);
  EXPECT_EQ(m.V.col(1).minCoeff(), -0.5 * h);
  EXPECT_EQ(m.V.col(1).maxCoeff(), 0.5 * h);
  EXPECT_EQ(m.V.col(2).cwiseAbs().maxCoeff(), 0.0);
  // Row j starts at j * (cx + 1) + j / 2, at x = -w/2, and odd rows' second vertex is half a cell in.
  for (int j = 0; j <= rows; ++j) {
    const Vec3 first = vertex(m, j * (cx + 1) + j / 2);
    EXPECT_EQ(first.x(), -0.5 * w);
    EXPECT_NEAR(first.y(), -0.5 * h + h * j / rows, 1e-15);
    EXPECT_NEAR(vertex(m, j * (cx + 1) + j / 2 + 1).x(), -0.5 * w + (j % 2 ? 0.05 : 0.1), 1e-15);
  }
}

TEST(RectangleEquilateral, TrianglesAreNearEquilateralAndBoundaryIsStraight) {
  const TriMesh m = make_rectangle_equilateral(2.0, 1.0, 20);
  double min_angle = kPi;
  for (int f = 0; f < m.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = vertex(m, m.F(f, k));
      const Vec3 e1 = vertex(m, m.F(f, (k + 1) % 3)) - p, e2 = vertex(m, m.F(f, (k + 2) % 3)) - p;
      min_angle = std::min(min_angle, std::acos(e1.dot(e2) / (e1.norm() * e2.norm())));
    }
  }
  // Full triangles are within a few degrees of 60; the half triangles at the ends are right
  // triangles with legs c/2 and ~sqrt(3)/2 c, whose smallest angle is ~30 degrees.
  EXPECT_GT(min_angle * 180.0 / kPi, 29.0);
  const Topology t = build_topology(m);
  for (int i = 0; i < m.num_vertices(); ++i) {
    const Vec3 p = vertex(m, i);
    const bool on_rectangle = std::abs(p.x()) == 1.0 || std::abs(p.y()) == 0.5;
    EXPECT_EQ(t.boundary_vertex[i] != 0, on_rectangle) << "vertex " << i;
  }
}

TEST(RectangleEquilateral, NormalsAlongZAreaExactAndDisc) {
  for (const auto& [w, h, cx] : {std::tuple{1.0, 1.0, 1}, std::tuple{1.0, 0.01, 4}, std::tuple{0.3, 2.0, 7}}) {
    const TriMesh m = make_rectangle_equilateral(w, h, cx);
    for (int f = 0; f < m.num_faces(); ++f) EXPECT_GT(face_normal(m, f).z(), 0.0) << "face " << f;
    EXPECT_NEAR(total_area(m), w * h, 1e-13);
    EXPECT_EQ(euler_characteristic(m), 1);
    EXPECT_NO_THROW(validate_mesh(m, "equilateral"));
  }
}

// ---- icosphere -------------------------------------------------------------------------------------

TEST(Icosphere, CountsAre10Times4PowSPlus2) {
  for (int s = 0; s <= 4; ++s) {
    const TriMesh m = make_icosphere(1.0, s);
    const int p = 1 << (2 * s);
    EXPECT_EQ(m.num_vertices(), 10 * p + 2) << "s=" << s;
    EXPECT_EQ(m.num_faces(), 20 * p) << "s=" << s;
    EXPECT_EQ(euler_characteristic(m), 2) << "s=" << s;
  }
}

TEST(Icosphere, VerticesLieOnTheSphereToRoundOff) {
  const double r = 0.73;
  const TriMesh m = make_icosphere(r, 4);
  for (int i = 0; i < m.num_vertices(); ++i) EXPECT_NEAR(m.V.row(i).norm(), r, 4e-16 * r) << "vertex " << i;
}

TEST(Icosphere, ClosedConsistentAndOutward) {
  for (int s = 0; s <= 3; ++s) {
    const TriMesh m = make_icosphere(2.0, s);
    EXPECT_TRUE(closed_and_consistently_oriented(m)) << "s=" << s;
    for (int f = 0; f < m.num_faces(); ++f) EXPECT_GT(face_normal(m, f).dot(centroid(m, f)), 0.0);
    EXPECT_GT(signed_volume(m), 0.0);
  }
}

TEST(Icosphere, VolumeApproachesBallVolume) {
  // The polyhedron is inscribed (vertices on the sphere), so its volume is below the ball's; each
  // tetrahedron (origin, face) contains the matching cone of the ball of radius d (the face plane's
  // distance from the origin), so volume >= (d_min / r)^3 * ball. The discretization error also
  // shrinks about 4x per subdivision (it is O(edge^2)); measured relative deficits are 0.86% at s = 3
  // and 0.216% at s = 4, and the test allows 1% and 0.25%.
  const double r = 1.3, ball = 4.0 / 3.0 * kPi * r * r * r;
  double previous_error = 1.0;
  for (int s = 1; s <= 4; ++s) {
    const TriMesh m = make_icosphere(r, s);
    double d_min = r;
    for (int f = 0; f < m.num_faces(); ++f)
      d_min = std::min(d_min, face_normal(m, f).normalized().dot(vertex(m, m.F(f, 0))));
    const double v = signed_volume(m), error = (ball - v) / ball;
    EXPECT_LT(v, ball) << "s=" << s;
    EXPECT_GE(v, std::pow(d_min / r, 3) * ball) << "s=" << s;
    EXPECT_LT(error, previous_error / 3.5) << "s=" << s;
    if (s == 3) { EXPECT_LT(error, 0.01); }
    if (s == 4) { EXPECT_LT(error, 0.0025); }
    previous_error = error;
  }
}

// ---- box -------------------------------------------------------------------------------------------

TEST(Box, CountsWeldedClosedEulerTwo) {
  for (int n = 1; n <= 4; ++n) {
    const TriMesh m = make_box(Vec3(1.0, 2.0, 3.0), n);
    EXPECT_EQ(m.num_vertices(), 6 * n * n + 2) << "cells=" << n;
    EXPECT_EQ(m.num_faces(), 12 * n * n) << "cells=" << n;
    EXPECT_TRUE(closed_and_consistently_oriented(m)) << "cells=" << n;
    const Topology t = build_topology(m);
    EXPECT_TRUE(t.closed());
    for (int c : t.edge_face_count) EXPECT_EQ(c, 2);
    EXPECT_EQ(euler_characteristic(m), 2) << "cells=" << n;
  }
}

TEST(Box, VolumeExactAndNormalsOutward) {
  const Vec3 size(0.5, 1.25, 2.0);  // with 4 cells every coordinate is a short binary fraction
  const TriMesh m = make_box(size, 4);
  EXPECT_NEAR(signed_volume(m), size.prod(), 1e-15);
  EXPECT_NEAR(total_area(m), 2.0 * (size.x() * size.y() + size.y() * size.z() + size.z() * size.x()), 1e-14);
  for (int f = 0; f < m.num_faces(); ++f) {
    // Each face's normal is axis-aligned and points to the side its centroid is on.
    const Vec3 n = face_normal(m, f).normalized(), c = centroid(m, f);
    int axis = 0;
    n.cwiseAbs().maxCoeff(&axis);
    EXPECT_NEAR(std::abs(n[axis]), 1.0, 1e-15);
    EXPECT_NEAR(std::abs(c[axis]), 0.5 * size[axis], 1e-15);
    EXPECT_GT(n[axis] * c[axis], 0.0) << "face " << f;
  }
}

TEST(Box, VerticesLieOnTheSurface) {
  const Vec3 size(1.0, 2.0, 3.0);
  const TriMesh m = make_box(size, 2);
  for (int i = 0; i < m.num_vertices(); ++i) {
    const Vec3 p = vertex(m, i);
    bool on_side = false;
    for (int k = 0; k < 3; ++k) {
      EXPECT_LE(std::abs(p[k]), 0.5 * size[k]);
      on_side = on_side || std::abs(p[k]) == 0.5 * size[k];
    }
    EXPECT_TRUE(on_side) << "vertex " << i;
  }
}

// ---- cylinder --------------------------------------------------------------------------------------

TEST(Cylinder, CountsIndexingAndRadius) {
  const int seg = 12, rings = 3;
  const double r = 0.4, h = 1.5;
  for (bool capped : {false, true}) {
    const TriMesh m = make_cylinder(r, h, seg, rings, capped);
    EXPECT_EQ(m.num_vertices(), seg * (rings + 1) + (capped ? 2 : 0));
    EXPECT_EQ(m.num_faces(), 2 * seg * rings + (capped ? 2 * seg : 0));
    for (int ring = 0; ring <= rings; ++ring)
      for (int s = 0; s < seg; ++s) {
        const Vec3 p = vertex(m, ring * seg + s);
        EXPECT_NEAR(std::hypot(p.x(), p.z()), r, 1e-15);
        EXPECT_NEAR(p.y(), -0.5 * h + h * ring / rings, 1e-15);
      }
    if (capped) {
      EXPECT_EQ(vertex(m, seg * (rings + 1)), Vec3(0.0, -0.5 * h, 0.0));
      EXPECT_EQ(vertex(m, seg * (rings + 1) + 1), Vec3(0.0, 0.5 * h, 0.0));
    }
  }
}

TEST(Cylinder, CappedIsClosedOutwardWithPrismVolume) {
  const int seg = 16;
  const double r = 0.5, h = 2.0;
  const TriMesh m = make_cylinder(r, h, seg, 4, true);
  EXPECT_TRUE(closed_and_consistently_oriented(m));
  EXPECT_EQ(euler_characteristic(m), 2);
  // The mesh is exactly a prism over a regular 16-gon: area (n/2) r^2 sin(2 pi / n).
  const double prism = 0.5 * seg * r * r * std::sin(2.0 * kPi / seg) * h;
  EXPECT_NEAR(signed_volume(m), prism, 1e-14);
  for (int f = 0; f < m.num_faces(); ++f) EXPECT_GT(face_normal(m, f).dot(centroid(m, f)), 0.0);
}

TEST(Cylinder, OpenTubeHasTwoBoundaryRingsAndOutwardNormals) {
  const int seg = 8;
  const TriMesh m = make_cylinder(1.0, 1.0, seg, 2, false);
  const Topology t = build_topology(m);
  EXPECT_FALSE(t.closed());
  int boundary_edges = 0;
  for (int c : t.edge_face_count) boundary_edges += (c == 1);
  EXPECT_EQ(boundary_edges, 2 * seg);
  for (int i = 0; i < m.num_vertices(); ++i)
    EXPECT_EQ(t.boundary_vertex[i] != 0, std::abs(m.V(i, 1)) == 0.5) << "vertex " << i;
  EXPECT_EQ(euler_characteristic(m), 0);  // an annulus
  for (int f = 0; f < m.num_faces(); ++f) {
    const Vec3 c = centroid(m, f);
    EXPECT_GT(face_normal(m, f).dot(Vec3(c.x(), 0.0, c.z())), 0.0) << "face " << f;
  }
}

// ---- cup -------------------------------------------------------------------------------------------

TEST(Cup, CountsIndexingAndBottomCentre) {
  const int seg = 12, rings = 3;
  const double r = 0.4, h = 1.5;
  const TriMesh m = make_cup(r, h, seg, rings);
  EXPECT_EQ(m.num_vertices(), seg * (rings + 1) + 1);
  EXPECT_EQ(m.num_faces(), 2 * seg * rings + seg);
  // Same wall as make_cylinder; the bottom centre is the last vertex.
  const TriMesh tube = make_cylinder(r, h, seg, rings, false);
  EXPECT_EQ(m.V.topRows(tube.num_vertices()), tube.V);
  EXPECT_EQ(m.F.topRows(tube.num_faces()), tube.F);
  EXPECT_EQ(vertex(m, seg * (rings + 1)), Vec3(0.0, -0.5 * h, 0.0));
}

TEST(Cup, OnlyTheRimIsBoundaryAndNormalsPointOut) {
  const int seg = 10, rings = 2;
  const double h = 1.0;
  const TriMesh m = make_cup(0.5, h, seg, rings);
  EXPECT_NO_THROW(validate_mesh(m, "cup"));  // manifold, consistently oriented, no zero-area face
  const Topology t = build_topology(m);
  EXPECT_FALSE(t.closed());
  int boundary_edges = 0;
  for (std::size_t e = 0; e < t.edges.size(); ++e) {
    EXPECT_TRUE(t.edge_face_count[e] == 1 || t.edge_face_count[e] == 2);
    if (t.edge_face_count[e] != 1) continue;
    ++boundary_edges;
    EXPECT_EQ(m.V(t.edges[e][0], 1), 0.5 * h) << "boundary edge off the rim";
    EXPECT_EQ(m.V(t.edges[e][1], 1), 0.5 * h) << "boundary edge off the rim";
  }
  EXPECT_EQ(boundary_edges, seg);
  EXPECT_EQ(euler_characteristic(m), 1);  // a disc
  for (int f = 0; f < m.num_faces(); ++f) {
    const Vec3 n = face_normal(m, f), c = centroid(m, f);
    EXPECT_GT(n.norm(), 1e-6) << "face " << f;
    if (f < 2 * seg * rings) EXPECT_GT(n.dot(Vec3(c.x(), 0.0, c.z())), 0.0) << "wall face " << f;
    else EXPECT_LT(n.y(), 0.0) << "bottom face " << f;
  }
}

// ---- gear ------------------------------------------------------------------------------------------

TEST(Gear, CountsAndOutlineRadii) {
  const double tip = 0.5, root = 0.35, t = 0.1;
  for (int teeth : {3, 8, 20}) {
    const TriMesh m = make_gear(tip, root, teeth, t);
    EXPECT_EQ(m.num_vertices(), 8 * teeth + 2) << "teeth=" << teeth;
    EXPECT_EQ(m.num_faces(), 16 * teeth) << "teeth=" << teeth;
    const int n = 4 * teeth;
    for (int level = 0; level < 2; ++level)
      for (int s = 0; s < n; ++s) {
        const Vec3 p = vertex(m, level * n + s);
        const bool at_tip = s % 4 == 1 || s % 4 == 2;
        EXPECT_NEAR(std::hypot(p.x(), p.z()), at_tip ? tip : root, 1e-15) << "s=" << s;
        EXPECT_NEAR(std::atan2(-p.z(), p.x()), std::remainder(2.0 * kPi * s / n, 2.0 * kPi), 1e-12) << "s=" << s;
        EXPECT_EQ(p.y(), level == 0 ? -0.5 * t : 0.5 * t);
      }
    EXPECT_EQ(vertex(m, 2 * n), Vec3(0.0, -0.5 * t, 0.0));
    EXPECT_EQ(vertex(m, 2 * n + 1), Vec3(0.0, 0.5 * t, 0.0));
  }
}

TEST(Gear, ClosedOutwardManifoldWithPrismVolume) {
  const double tip = 0.5, root = 0.35, t = 0.1;
  const int teeth = 12;
  const TriMesh m = make_gear(tip, root, teeth, t);
  EXPECT_NO_THROW(validate_mesh(m, "gear"));  // no zero-area face, manifold, consistent
  EXPECT_TRUE(closed_and_consistently_oriented(m));
  const Topology topo = build_topology(m);
  EXPECT_TRUE(topo.closed());
  for (int c : topo.edge_face_count) EXPECT_EQ(c, 2);
  EXPECT_EQ(euler_characteristic(m), 2);
  // Outline triangles (centre, s, s+1) span 2 pi / (4 teeth); per tooth the radius pairs are
  // (root, tip), (tip, tip), (tip, root), (root, root), so the outline area is
  // teeth/2 sin(2 pi / (4 teeth)) (tip + root)^2.
  const double area = 0.5 * teeth * std::sin(2.0 * kPi / (4 * teeth)) * (tip + root) * (tip + root);
  EXPECT_NEAR(signed_volume(m), area * t, 1e-14);
  for (int f = 0; f < m.num_faces(); ++f) {
    const Vec3 n = face_normal(m, f), c = centroid(m, f);
    EXPECT_GT(n.norm(), 1e-6) << "face " << f;
    if (std::abs(n.y()) > 1e-12 * n.norm()) {
      EXPECT_GT(n.y() * c.y(), 0.0) << "cap face " << f;  // caps face away from the mid-plane
    } else {
      EXPECT_GT(n.dot(Vec3(c.x(), 0.0, c.z())), 0.0) << "side face " << f;  // sides face away from the axis
    }
  }
}

TEST(Shapes, InvalidArgumentsThrow) {
  EXPECT_THROW(make_rectangle(0.0, 1.0, 2, 2), std::invalid_argument);
  EXPECT_THROW(make_rectangle(1.0, 1.0, 0, 2), std::invalid_argument);
  EXPECT_THROW(make_rectangle_equilateral(1.0, std::nan(""), 2), std::invalid_argument);
  EXPECT_THROW(make_icosphere(1.0, -1), std::invalid_argument);
  EXPECT_THROW(make_box(Vec3(1.0, -1.0, 1.0), 1), std::invalid_argument);
  EXPECT_THROW(make_cylinder(1.0, 1.0, 2, 1, true), std::invalid_argument);
  EXPECT_THROW(make_cup(1.0, 0.0, 8, 1), std::invalid_argument);
  EXPECT_THROW(make_cup(1.0, 1.0, 2, 1), std::invalid_argument);
  EXPECT_THROW(make_cup(1.0, 1.0, 8, 0), std::invalid_argument);
  EXPECT_THROW(make_gear(1.0, 0.5, 2, 0.1), std::invalid_argument);    // too few teeth
  EXPECT_THROW(make_gear(1.0, 1.0, 8, 0.1), std::invalid_argument);    // root_radius == radius
  EXPECT_THROW(make_gear(1.0, 1.5, 8, 0.1), std::invalid_argument);    // root_radius > radius
  EXPECT_THROW(make_gear(1.0, 0.0, 8, 0.1), std::invalid_argument);    // root_radius == 0
  EXPECT_THROW(make_gear(1.0, 0.5, 8, -0.1), std::invalid_argument);   // negative thickness
  EXPECT_THROW(make_gear(std::nan(""), 0.5, 8, 0.1), std::invalid_argument);
}

}  // namespace
}  // namespace pd
