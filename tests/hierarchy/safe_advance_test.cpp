// Additive CCD-filtered advancement toward per-vertex targets (hierarchy/safe_advance.h).
#include "hierarchy/safe_advance.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "geometry/shapes.h"
#include "geometry/topology.h"
#include "physics/contact/distance.h"
#include "support/intersection_checker.h"

namespace pd {
namespace {

// Several meshes stacked as objects of one scene (object k = meshes[k]).
struct Stack {
  ContactPrimitives prims;
  Positions V;
  Faces F;
};

Stack stack(const std::vector<TriMesh>& meshes, bool self_contact) {
  Stack s;
  int nv = 0, nf = 0;
  for (const TriMesh& m : meshes) nv += m.num_vertices(), nf += m.num_faces();
  s.V.resize(nv, 3);
  s.F.resize(nf, 3);
  int ov = 0, of = 0;
  for (std::size_t k = 0; k < meshes.size(); ++k) {
    const TriMesh& m = meshes[k];
    s.V.middleRows(ov, m.num_vertices()) = m.V;
    s.F.middleRows(of, m.num_faces()) = (m.F.array() + ov).matrix();
    for (auto e : build_topology(m).edges) s.prims.edges.push_back({e[0] + ov, e[1] + ov});
    for (int v = 0; v < m.num_vertices(); ++v) s.prims.vertex_object.push_back(static_cast<int>(k));
    s.prims.object_self_contact.push_back(self_contact ? 1 : 0);
    ov += m.num_vertices();
    of += m.num_faces();
  }
  s.prims.faces = s.F;
  return s;
}

TriMesh translated(TriMesh m, const Vec3& t) {
  m.V.rowwise() += t.transpose();
  return m;
}

// Smallest distance over every point-triangle and edge-edge pair between different objects, by
// brute force (no broad phase).
double brute_min_distance(const Stack& s, const Positions& x) {
  double best = INFINITY;
  auto p = [&](int i) -> Vec3 { return x.row(i).transpose(); };
  for (int v = 0; v < x.rows(); ++v)
    for (int f = 0; f < s.F.rows(); ++f) {
      if (s.prims.vertex_object[v] == s.prims.vertex_object[s.F(f, 0)]) continue;
      Vec<12> x12;
      x12 << p(v), p(s.F(f, 0)), p(s.F(f, 1)), p(s.F(f, 2));
      best = std::min(best, std::sqrt(point_triangle_squared_distance(x12)));
    }
  for (const auto& a : s.prims.edges)
    for (const auto& b : s.prims.edges) {
      if (s.prims.vertex_object[a[0]] >= s.prims.vertex_object[b[0]]) continue;
      Vec<12> x12;
      x12 << p(a[0]), p(a[1]), p(b[0]), p(b[1]);
      best = std::min(best, std::sqrt(edge_edge_squared_distance(x12)));
    }
  return best;
}

// A unit right triangle in the plane z = 0 (object 0) and a small triangle (object 1) whose first
// vertex (global id 3) hovers `height` m above the big one's interior at (0.2, 0.2).
Stack hovering_triangle(double height) {
  TriMesh big, small;
  big.V.resize(3, 3);
  big.V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  big.F.resize(1, 3);
  big.F << 0, 1, 2;
  small = big;
  small.V << 0.2, 0.2, height, 0.3, 0.2, 0.05, 0.2, 0.3, 0.05;
  return stack({big, small}, false);
}

TEST(SafeAdvance, WithoutContactEveryVertexReachesItsTarget) {
  const Stack s = stack({make_rectangle(1.0, 1.0, 4, 4)}, true);
  Positions target = s.V;
  for (int i = 0; i < target.rows(); ++i) target(i, 2) = 0.1 * std::sin(3.0 * s.V(i, 0)) * s.V(i, 1);
  Positions x = s.V;
  const AdvanceReport r = advance_toward_targets(s.prims, 0.0, 0.01, nullptr, target, x);
  EXPECT_EQ(r.stopped_vertices, 0);
  EXPECT_LT((x - target).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(SafeAdvance, SheetsDrivenThroughEachOtherStopApartAndIntersectionFree) {
  // Two 1 m sheets 2 cm apart; the targets swap their heights, so every vertex would cross.
  const Stack s = stack({make_rectangle(1.0, 1.0, 6, 6), translated(make_rectangle(0.8, 0.8, 5, 5), Vec3(0.03, 0.02, 0.02))},
                        false);
  Positions target = s.V;
  for (int i = 0; i < target.rows(); ++i) target(i, 2) = s.prims.vertex_object[i] == 0 ? 0.03 : -0.01;
  Positions x = s.V;
  const double g0 = brute_min_distance(s, x);
  const AdvanceReport r = advance_toward_targets(s.prims, 0.0, g0, nullptr, target, x);
  EXPECT_GT(r.events, 0);
  EXPECT_GT(r.stopped_vertices + r.redirections, 0);
  // Far pairs keep at least far_ratio = 0.1 of their gap: nothing ends closer than 0.1 g0 (up to
  // ACCD's own margin, which is on the safe side).
  const double g1 = brute_min_distance(s, x);
  EXPECT_GE(g1, 0.1 * g0 * (1 - 1e-9)) << "g0 " << g0 << " g1 " << g1;
  EXPECT_TRUE(test::intersection_free(x, s.F));
  // Progress: the sheets did come closer than they started.
  EXPECT_LT(g1, g0);
}

TEST(SafeAdvance, PairsMuchCloserThanTheGapKeepNinetyNinePointNinePercent) {
  // A vertex 1e-5 m above a triangle, reference gap 1e-3 m: close (d0 < 0.1 g), so r = 0.999.
  const Stack s = hovering_triangle(1e-5);
  Positions target = s.V;
  target.bottomRows(3).col(2).array() -= 0.5;  // straight down through the big triangle
  Positions x = s.V;
  advance_toward_targets(s.prims, 0.0, 1e-3, nullptr, target, x);
  EXPECT_GE(x(3, 2), 0.999 * 1e-5 * (1 - 1e-9));
  EXPECT_LE(x(3, 2), 1e-5);
}

TEST(SafeAdvance, PairWithinTheOffsetIsOnlyKeptIntersectionFree) {
  // Offset 1 mm, the vertex starts 0.5 mm above: the pair keeps thickness 0 and its own distance.
  const Stack s = hovering_triangle(5e-4);
  Positions target = s.V;
  target.bottomRows(3).col(2).array() -= 0.5;
  Positions x = s.V;
  advance_toward_targets(s.prims, 1e-3, 1e-3, nullptr, target, x);
  EXPECT_GT(x(3, 2), 0.0);
  EXPECT_GE(x(3, 2), 0.1 * 5e-4 * (1 - 1e-9));  // d0 = 0.5 g: a far pair, r = 0.1
  EXPECT_EQ(min_contact_gap(s.prims, s.V, 1e-3, 1e-2), 5e-4);  // thickness 0 below the offset
}

TEST(SafeAdvance, GroundStopsVerticesAboveItAndOthersGoOn) {
  const Stack s = stack({translated(make_rectangle(1.0, 1.0, 4, 4), Vec3(0, 0, 0.1))}, false);
  GroundPlane ground{Vec3(0, 0, 1), 0.0, std::vector<char>(static_cast<std::size_t>(s.V.rows()), 1)};
  Positions target = s.V;
  for (int i = 0; i < target.rows(); ++i) target(i, 2) = s.V(i, 0) < 0 ? -0.1 : 0.05;  // half goes below
  Positions x = s.V;
  const double offset = 0.01;
  advance_toward_targets(s.prims, offset, 0.09, &ground, target, x);
  for (int i = 0; i < x.rows(); ++i) {
    EXPECT_GT(x(i, 2) - offset, 0.0);
    if (s.V(i, 0) < 0) {
      EXPECT_GE(x(i, 2) - offset, 0.1 * 0.09 * (1 - 1e-9));
    }
  }
  // A vertex whose stencil never bounded the motion (no mesh pairs: self-contact off, one object)
  // reaches its target.
  int reached = 0;
  for (int i = 0; i < x.rows(); ++i) reached += (x.row(i) - target.row(i)).norm() < 1e-15;
  EXPECT_GT(reached, 0);
}

TEST(SafeAdvance, VerticesDrivenObliquelyIntoTheGroundSlideAlongItInsteadOfStopping) {
  // Targets 0.3 m to the side and 5 cm under the ground: the approaching component is removed when
  // the ground bounds the motion, the tangential one goes on.
  const Stack s = stack({translated(make_rectangle(0.2, 0.2, 2, 2), Vec3(0, 0, 0.1))}, false);
  GroundPlane ground{Vec3(0, 0, 1), 0.0, std::vector<char>(static_cast<std::size_t>(s.V.rows()), 1)};
  Positions target = s.V;
  target.col(0).array() += 0.3;
  target.col(2).array() = -0.05;
  Positions x = s.V;
  const AdvanceReport r = advance_toward_targets(s.prims, 0.0, 0.1, &ground, target, x);
  EXPECT_EQ(r.redirections, x.rows());
  EXPECT_EQ(r.stopped_vertices, 0);
  for (int i = 0; i < x.rows(); ++i) {
    EXPECT_GT(x(i, 2), 0.0);
    EXPECT_NEAR(x(i, 0), target(i, 0), 1e-12);  // the whole tangential motion
  }
}

TEST(SafeAdvance, RandomCrumplingTargetsNeverIntersectAndRunsAreBitIdentical) {
  // A self-contacting sheet driven toward random, heavily self-intersecting targets.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 6; ++trial) {
    const Stack s = stack({make_rectangle(0.5, 0.5, 8, 8)}, true);
    Positions target = s.V;
    for (int i = 0; i < target.rows(); ++i)
      target.row(i) += 0.15 * Vec3(u(rng), u(rng), u(rng)).transpose();
    Positions x = s.V, again = s.V;
    const double g = min_contact_gap(s.prims, s.V, 0.0, 0.1);
    advance_toward_targets(s.prims, 0.0, g, nullptr, target, x);
    advance_toward_targets(s.prims, 0.0, g, nullptr, target, again);
    EXPECT_TRUE(test::intersection_free(x, s.F)) << "trial " << trial;
    EXPECT_TRUE((x.array() == again.array()).all());
    ++checked;
  }
  EXPECT_EQ(checked, 6);
}

TEST(SafeAdvance, BadInputIsRejected) {
  const Stack s = stack({make_rectangle(1.0, 1.0, 2, 2)}, true);
  Positions x = s.V;
  EXPECT_THROW(advance_toward_targets(s.prims, 0.0, 0.0, nullptr, s.V, x), std::invalid_argument);
  EXPECT_THROW(advance_toward_targets(s.prims, 0.0, 0.1, nullptr, s.V.topRows(3), x), std::invalid_argument);
  GroundPlane ground{Vec3(0, 0, 1), -1.0, {1, 0}};
  EXPECT_THROW(advance_toward_targets(s.prims, 0.0, 0.1, &ground, s.V, x), std::invalid_argument);
}

}  // namespace
}  // namespace pd
