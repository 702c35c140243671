// Tests of the start-state intersection check (physics/contact/start_check.h): a needle through a
// triangle's interior (invisible to distances), touching at exactly the offset, clean scenes,
// self-intersection with self-contact on and off, overlapping spheres, messages, report limits, and
// agreement with the independent CGAL checker on random triangle pairs.
#include "physics/contact/start_check.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/shapes.h"
#include "physics/contact/distance.h"
#include "support/intersection_checker.h"

namespace pd {
namespace {

using Kind = StartViolation::Kind;

// Objects stacked into one scene, as the simulator does; edges are every face's sides, deduplicated.
struct Scene {
  Positions V = Positions(0, 3);
  ContactPrimitives prims;
  std::vector<std::string> names;
  void add(const std::string& name, const Positions& Vo, const Faces& Fo, bool self_contact) {
    const int offset = static_cast<int>(V.rows());
    const int object = static_cast<int>(names.size());
    names.push_back(name);
    V.conservativeResize(offset + Vo.rows(), 3);
    V.bottomRows(Vo.rows()) = Vo;
    const int m0 = static_cast<int>(prims.faces.rows());
    prims.faces.conservativeResize(m0 + Fo.rows(), 3);
    prims.faces.bottomRows(Fo.rows()) = Fo.array() + offset;
    std::set<std::array<int, 2>> edges;
    for (int f = 0; f < Fo.rows(); ++f)
      for (int k = 0; k < 3; ++k) {
        const int a = Fo(f, k), b = Fo(f, (k + 1) % 3);
        edges.insert({std::min(a, b) + offset, std::max(a, b) + offset});
      }
    prims.edges.insert(prims.edges.end(), edges.begin(), edges.end());
    prims.vertex_object.insert(prims.vertex_object.end(), static_cast<std::size_t>(Vo.rows()), object);
    prims.object_self_contact.push_back(self_contact ? 1 : 0);
  }
  void add(const std::string& name, const TriMesh& m, bool self_contact) { add(name, m.V, m.F, self_contact); }
  std::vector<StartViolation> check(double offset, int max_reports = 16, int* total = nullptr) const {
    return find_start_violations(prims, V, offset, max_reports, total);
  }
};

Positions rows(std::initializer_list<Vec3> points) {
  Positions V(static_cast<Eigen::Index>(points.size()), 3);
  int i = 0;
  for (const Vec3& p : points) V.row(i++) = p.transpose();
  return V;
}

Faces one_face() {
  Faces F(1, 3);
  F << 0, 1, 2;
  return F;
}

// Smallest point-triangle and edge-edge distance over all non-adjacent pairs (brute force), m.
double min_pair_distance(const Scene& s) {
  double d2 = std::numeric_limits<double>::infinity();
  auto x12 = [&](int a, int b, int c, int d) {
    Vec<12> x;
    x << s.V.row(a).transpose(), s.V.row(b).transpose(), s.V.row(c).transpose(), s.V.row(d).transpose();
    return x;
  };
  const auto& F = s.prims.faces;
  for (int v = 0; v < s.V.rows(); ++v)
    for (int f = 0; f < F.rows(); ++f)
      if (v != F(f, 0) && v != F(f, 1) && v != F(f, 2))
        d2 = std::min(d2, point_triangle_squared_distance(x12(v, F(f, 0), F(f, 1), F(f, 2))));
  for (const auto& a : s.prims.edges)
    for (const auto& b : s.prims.edges)
      if (a[0] != b[0] && a[0] != b[1] && a[1] != b[0] && a[1] != b[1])
        d2 = std::min(d2, edge_edge_squared_distance(x12(a[0], a[1], b[0], b[1])));
  return std::sqrt(d2);
}

TEST(StartCheck, FindsANeedleThroughATrianglesInteriorThatNoDistanceSees) {
  // A 2 m triangle in z = 0 and a thin needle triangle standing through its middle: its edges
  // (0, 1) and (0, 2) cross the plane 1 cm from their ends, 0.4 m or more from the big triangle's
  // edges.
  Scene s;
  s.add("sheet", rows({{-1, -1, 0}, {1, -1, 0}, {0, 1, 0}}), one_face(), false);
  s.add("needle", rows({{0, 0, -0.01}, {0, 0, 0.01}, {0.001, 0, 0.01}}), one_face(), false);
  const double offset = 1e-3;
  ASSERT_GT(min_pair_distance(s), 5 * offset);  // (a) alone cannot see it
  int total = -1;
  const std::vector<StartViolation> v = s.check(offset, 16, &total);
  ASSERT_EQ(v.size(), 2u);
  EXPECT_EQ(total, 2);
  // Edges (sorted): 0 (0,1), 1 (0,2), 2 (1,2) of the sheet; 3 (3,4), 4 (3,5), 5 (4,5) of the needle.
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(v[k].kind, Kind::EdgeTriangle);
    EXPECT_EQ(v[k].a, 3 + k);
    EXPECT_EQ(v[k].b, 0);
    EXPECT_EQ(v[k].object_a, 1);
    EXPECT_EQ(v[k].object_b, 0);
    EXPECT_EQ(v[k].distance, 0.0);
  }
  EXPECT_EQ(describe(v[0], s.names), "object 'needle' edge (0, 1) passes through object 'sheet' face 0");
  EXPECT_EQ(describe(v[1], s.names), "object 'needle' edge (0, 2) passes through object 'sheet' face 0");
  // Lifted 2 cm, the needle is clear of the sheet.
  Scene lifted = s;
  lifted.V.bottomRows(3).col(2).array() += 0.02;
  EXPECT_TRUE(lifted.check(offset).empty());
}

TEST(StartCheck, TouchingAtExactlyTheOffsetIsAViolation) {
  // Triangle B's lowest vertex sits exactly `offset` above triangle A's interior: the barrier is
  // infinite there (d^2 == offset^2), so the start is invalid. 1e-9 m higher it is valid.
  const double offset = 5e-4;
  for (double lift : {0.0, 1e-9}) {
    Scene s;
    s.add("floor", rows({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}), one_face(), true);
    s.add("cloth", rows({{0.25, 0.25, offset + lift}, {0.5, 0.25, 0.5}, {0.25, 0.5, 0.5}}), one_face(), true);
    const std::vector<StartViolation> v = s.check(offset);
    if (lift > 0.0) {
      EXPECT_TRUE(v.empty());
      continue;
    }
    ASSERT_EQ(v.size(), 1u);
    EXPECT_EQ(v[0].kind, Kind::PointTriangle);
    EXPECT_EQ(v[0].a, 3);
    EXPECT_EQ(v[0].b, 0);
    EXPECT_EQ(v[0].distance, offset);
    EXPECT_EQ(describe(v[0], s.names),
              "object 'cloth' vertex 0 is 0.5 mm from object 'floor' face 0 (contact offset 0.5 mm)");
  }
  // With no offset, touching means distance 0: the vertex on the floor is reported as a point-
  // triangle pair and, since the vertex ends two of B's edges, as those edges meeting the floor.
  Scene s;
  s.add("floor", rows({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}), one_face(), true);
  s.add("cloth", rows({{0.25, 0.25, 0.0}, {0.5, 0.25, 0.5}, {0.25, 0.5, 0.5}}), one_face(), true);
  const std::vector<StartViolation> v = s.check(0.0);
  ASSERT_EQ(v.size(), 3u);
  EXPECT_EQ(v[0].kind, Kind::PointTriangle);
  EXPECT_EQ(v[1].kind, Kind::EdgeTriangle);
  EXPECT_EQ(v[2].kind, Kind::EdgeTriangle);
}

TEST(StartCheck, EdgeEdgeWithinTheOffsetIsReportedWithItsDistance) {
  // Two triangles whose edges cross 0.2 mm apart, against a 0.5 mm offset.
  Scene s;
  s.add("a", rows({{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}}), one_face(), false);
  s.add("b", rows({{0, -1, 2e-4}, {0, 1, 2e-4}, {1, 1, 1}}), one_face(), false);
  const std::vector<StartViolation> v = s.check(5e-4);
  const auto ee = std::find_if(v.begin(), v.end(), [](const StartViolation& x) { return x.kind == Kind::EdgeEdge; });
  ASSERT_NE(ee, v.end());
  EXPECT_NEAR(ee->distance, 2e-4, 1e-15);
  EXPECT_EQ(describe(*ee, s.names),
            "object 'a' edge (0, 1) is 0.2 mm from object 'b' edge (0, 1) (contact offset 0.5 mm)");
}

TEST(StartCheck, CleanScenesGiveNoViolations) {
  Scene s;
  TriMesh ball = make_icosphere(0.1, 2);
  s.add("ball_a", ball, true);
  ball.V.col(0).array() += 0.25;
  s.add("ball_b", ball, true);
  TriMesh sheet = make_rectangle(0.6, 0.3, 24, 12);
  sheet.V.col(2).array() += ball.V.col(2).maxCoeff() + 2e-3;  // 2 mm above both balls' top vertices
  sheet.V.col(0).array() += 0.125;
  s.add("sheet", sheet, true);
  int total = -1;
  EXPECT_TRUE(s.check(1e-3, 16, &total).empty());
  EXPECT_EQ(total, 0);
  EXPECT_TRUE(test::intersection_free(s.V, s.prims.faces));
  // 3 mm offset: the sheet is now within it over both balls' top vertices.
  EXPECT_FALSE(s.check(3e-3).empty());
}

// A 1 m x 0.2 m strip bent along a figure-eight curve (x, z) = 0.3 (cos t, sin t cos t), t from 0.2
// to 2 pi - 0.2: the curve crosses itself at the origin, so the strip passes through itself along y.
TriMesh figure_eight_strip() {
  TriMesh m = make_rectangle(1.0, 0.2, 40, 4);
  for (int i = 0; i < m.num_vertices(); ++i) {
    const double pi = 3.14159265358979323846;
    const double t = 0.2 + (m.V(i, 0) + 0.5) * (2.0 * pi - 0.4);
    m.V.row(i) << 0.3 * std::cos(t), m.V(i, 1), 0.3 * std::sin(t) * std::cos(t);
  }
  return m;
}

TEST(StartCheck, SelfIntersectionIsReportedOnlyWithSelfContactOn) {
  ASSERT_FALSE(test::intersection_free(figure_eight_strip().V, figure_eight_strip().F));  // CGAL agrees
  for (bool self : {true, false}) {
    Scene s;
    s.add("ribbon", figure_eight_strip(), self);
    int total = -1;
    const std::vector<StartViolation> v = s.check(0.0, 1000, &total);
    if (!self) {
      EXPECT_TRUE(v.empty());
      EXPECT_EQ(total, 0);
      continue;
    }
    ASSERT_FALSE(v.empty());
    // The crossing is along y: edges of the strip cross its faces there, and each of the 5 rows of
    // vertices (an exactly planar curve, y = const) crosses itself at distance 0, which the edge-edge
    // distances see too.
    int piercing = 0, edge_edge = 0;
    for (const StartViolation& x : v) {
      EXPECT_EQ(x.object_a, 0);
      EXPECT_EQ(x.object_b, 0);
      EXPECT_NE(x.kind, Kind::PointTriangle);  // no vertex lies on the other sheet
      piercing += x.kind == Kind::EdgeTriangle;
      edge_edge += x.kind == Kind::EdgeEdge;
    }
    std::printf("[ info     ] figure-eight ribbon: %d violations (%d edge-edge at distance 0, %d piercing); first: "
                "%s\n", total, edge_edge, piercing, describe(v[0], s.names).c_str());
    EXPECT_EQ(edge_edge, 5);
    EXPECT_GT(piercing, 0);
  }
}

TEST(StartCheck, OverlappingSpheresAreFoundAndTheMessageNamesBoth) {
  Scene s;
  TriMesh ball = make_icosphere(0.1, 2);
  s.add("ball_a", ball, false);
  ball.V.col(0).array() += 0.15;  // centres 0.15 m apart, radii 0.1 m: the surfaces cross on a circle
  s.add("ball_b", ball, false);
  int total = -1;
  const std::vector<StartViolation> v = s.check(5e-4, 16, &total);
  ASSERT_EQ(v.size(), 16u);
  EXPECT_GT(total, 16);
  std::printf("[ info     ] overlapping icospheres: %d violations; first: %s\n", total, describe(v[0], s.names).c_str());
  for (const StartViolation& x : v) {
    EXPECT_NE(x.object_a, x.object_b);
    const std::string message = describe(x, s.names);
    EXPECT_NE(message.find("object 'ball_a'"), std::string::npos) << message;
    EXPECT_NE(message.find("object 'ball_b'"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos);
  }
  // The same scene with no offset still intersects (by piercing); the report is deterministic and
  // its first entries do not depend on the limit.
  int total0 = -1;
  const std::vector<StartViolation> all = s.check(0.0, 100000, &total0);
  EXPECT_EQ(static_cast<int>(all.size()), total0);
  EXPECT_GT(total0, 0);
  const std::vector<StartViolation> few = s.check(0.0, 3);
  ASSERT_EQ(few.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(few[k].kind, all[k].kind);
    EXPECT_EQ(few[k].a, all[k].a);
    EXPECT_EQ(few[k].b, all[k].b);
  }
  EXPECT_TRUE(s.check(0.0, 0).empty());
  // Apart, the spheres are clean.
  s.V.bottomRows(ball.num_vertices()).col(0).array() += 0.1;
  EXPECT_TRUE(s.check(5e-4).empty());
}

TEST(StartCheck, CoplanarOverlapCountsAsIntersecting) {
  // Two triangles in the same plane z = 0, overlapping, of different objects (no PT or EE pair is
  // within a positive distance test that could miss it; with offset 0 only exact zeros count).
  Scene s;
  s.add("a", rows({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}), one_face(), false);
  s.add("b", rows({{0.2, 0.2, 0}, {0.6, 0.3, 0}, {0.3, 0.7, 0}}), one_face(), false);  // inside a
  const std::vector<StartViolation> v = s.check(0.0);
  EXPECT_TRUE(std::any_of(v.begin(), v.end(), [](const StartViolation& x) { return x.kind == Kind::EdgeTriangle; }));
  // A coplanar edge crossing the triangle with both endpoints outside it.
  Scene c;
  c.add("a", rows({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}), one_face(), false);
  c.add("b", rows({{-0.5, 0.2, 0}, {1.5, 0.2, 0}, {0.5, 3, 0.0}}), one_face(), false);
  const std::vector<StartViolation> w = c.check(0.0);
  EXPECT_TRUE(std::any_of(w.begin(), w.end(), [](const StartViolation& x) {
    return x.kind == Kind::EdgeTriangle && x.object_a == 1 && x.a_local == std::array<int, 2>{{0, 1}};
  }));
  // Coplanar but apart: nothing.
  Scene d;
  d.add("a", rows({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}), one_face(), false);
  d.add("b", rows({{0.6, 0.6, 0}, {1.6, 0.6, 0}, {0.6, 1.6, 0}}), one_face(), false);
  EXPECT_TRUE(d.check(0.0).empty());
}

// Random pairs of triangles (generic, in a unit cube), as two objects, and as one object sharing a
// vertex: with offset 0 the check must agree with CGAL's exact test on every configuration.
TEST(StartCheck, AgreesWithTheCgalCheckerOnRandomTrianglePairs) {
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int intersecting = 0, agree = 0, trials = 0;
  for (int trial = 0; trial < 1500; ++trial) {
    const bool share = trial % 3 == 0;
    Positions P(6, 3);
    for (Eigen::Index i = 0; i < P.size(); ++i) P.data()[i] = u(rng);
    Faces F(2, 3);
    F << 0, 1, 2, 3, 4, 5;
    Scene s;
    if (share) {
      F(1, 0) = 0;  // the second triangle shares vertex 0 (one object, self-contact on)
      s.add("one", P, F, true);
    } else {
      s.add("a", P.topRows(3), one_face(), false);
      s.add("b", P.bottomRows(3), one_face(), false);
    }
    const bool cgal = test::find_intersections(s.V, s.prims.faces).intersecting_pairs > 0;
    const bool ours = !s.check(0.0).empty();
    intersecting += cgal;
    agree += cgal == ours;
    ++trials;
    EXPECT_EQ(ours, cgal) << "trial " << trial;
  }
  std::printf("[ info     ] random triangle pairs: %d of %d agree with CGAL, %d intersecting\n", agree, trials,
              intersecting);
  EXPECT_GT(intersecting, 100);
  EXPECT_LT(intersecting, trials - 100);
}

TEST(StartCheck, RejectsInvalidArguments) {
  Scene s;
  s.add("a", rows({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}), one_face(), false);
  EXPECT_THROW(s.check(-1e-3), std::invalid_argument);
  EXPECT_THROW(s.check(NAN), std::invalid_argument);
  EXPECT_THROW(s.check(0.0, -1), std::invalid_argument);
  Positions bad = s.V;
  bad(0, 0) = NAN;
  EXPECT_THROW(find_start_violations(s.prims, bad, 0.0), std::invalid_argument);
  StartViolation x;
  x.kind = Kind::PointTriangle;
  x.object_a = 0;
  x.object_b = 5;
  x.a_local = {{1, -1}};
  x.b_local = {{2, -1}};
  EXPECT_EQ(describe(x, {"a"}), "object 'a' vertex 1 is 0 mm from object '#5' face 2 (contact offset 0 mm)");
}

}  // namespace
}  // namespace pd
