// Local relaxation solves of safe upsampling (PSQ 4.4.3 gap / element relaxation, 4.4.5 strain
// feasibility): goals met, measured independently (brute-force distances over all pairs, the CGAL
// intersection checker, principal stretches), fixed vertices untouched, bad input refused.
#include "hierarchy/patch_relaxation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "geometry/shapes.h"
#include "geometry/topology.h"
#include "physics/contact/distance.h"
#include "physics/strain_limit.h"
#include "support/intersection_checker.h"

namespace pd {
namespace {

// Objects stacked into one mesh with their contact primitives (global indices).
struct Scene {
  ContactPrimitives prims;
  Positions rest;
  Positions x;  // current positions, m

  void add(const TriMesh& rest_mesh, const Positions& current, bool self_contact) {
    const int base = static_cast<int>(rest.rows());
    const int object = static_cast<int>(prims.object_self_contact.size());
    rest.conservativeResize(base + rest_mesh.num_vertices(), 3);
    rest.bottomRows(rest_mesh.num_vertices()) = rest_mesh.V;
    x.conservativeResize(base + rest_mesh.num_vertices(), 3);
    x.bottomRows(rest_mesh.num_vertices()) = current;
    const Eigen::Index faces = prims.faces.rows();
    prims.faces.conservativeResize(faces + rest_mesh.num_faces(), 3);
    prims.faces.bottomRows(rest_mesh.num_faces()) = (rest_mesh.F.array() + base).matrix();
    for (auto e : build_topology(rest_mesh).edges) prims.edges.push_back({e[0] + base, e[1] + base});
    prims.vertex_object.resize(static_cast<std::size_t>(rest.rows()), object);
    prims.object_self_contact.push_back(self_contact ? 1 : 0);
  }
  RelaxationMesh mesh(double offset = 0.0) const { return RelaxationMesh{&prims, &rest, offset}; }
};

// min over ALL point-triangle and edge-edge pairs (brute force, the broad phase's exclusions: shared
// vertices; same object without self-contact) of the distance d (m), with distance.h.
double brute_force_min_distance(const Scene& s) {
  const ContactPrimitives& p = s.prims;
  const auto allowed = [&](int a, int b) {
    const int oa = p.vertex_object[static_cast<std::size_t>(a)], ob = p.vertex_object[static_cast<std::size_t>(b)];
    return oa != ob || p.object_self_contact[static_cast<std::size_t>(oa)];
  };
  const auto row = [&](int v) -> Vec3 { return s.x.row(v).transpose(); };
  double best = std::numeric_limits<double>::infinity();
  for (int v = 0; v < s.x.rows(); ++v)
    for (int f = 0; f < p.faces.rows(); ++f) {
      const int a = p.faces(f, 0), b = p.faces(f, 1), c = p.faces(f, 2);
      if (v == a || v == b || v == c || !allowed(v, a)) continue;
      Vec<12> x12;
      x12 << row(v), row(a), row(b), row(c);
      best = std::min(best, std::sqrt(point_triangle_squared_distance(x12)));
    }
  for (std::size_t i = 0; i < p.edges.size(); ++i)
    for (std::size_t j = i + 1; j < p.edges.size(); ++j) {
      const auto& A = p.edges[i];
      const auto& B = p.edges[j];
      if (A[0] == B[0] || A[0] == B[1] || A[1] == B[0] || A[1] == B[1] || !allowed(A[0], B[0])) continue;
      Vec<12> x12;
      x12 << row(A[0]), row(A[1]), row(B[0]), row(B[1]);
      best = std::min(best, std::sqrt(edge_edge_squared_distance(x12)));
    }
  return best;
}

double max_stretch(const Scene& s) {
  double m = 0.0;
  for (int f = 0; f < s.prims.faces.rows(); ++f) {
    Vec<9> X, x;
    for (int k = 0; k < 3; ++k) {
      X.segment<3>(3 * k) = s.rest.row(s.prims.faces(f, k)).transpose();
      x.segment<3>(3 * k) = s.x.row(s.prims.faces(f, k)).transpose();
    }
    m = std::max(m, principal_stretches(x, strain_limit_rest(X.segment<3>(0), X.segment<3>(3), X.segment<3>(6)))[0]);
  }
  return m;
}

void expect_rows_identical(const Positions& a, const Positions& b, const std::vector<char>& free_mask) {
  for (int v = 0; v < a.rows(); ++v) {
    if (free_mask[static_cast<std::size_t>(v)]) continue;
    for (int k = 0; k < 3; ++k) ASSERT_EQ(a(v, k), b(v, k)) << "fixed vertex " << v << " moved";
  }
}

// A 1 m square (4 x 4 cells, fixed) and a 0.6 m square (3 x 3 cells, free) above it, rotated and
// shifted so that no vertex sits over a vertex, `gap` m above (parallel planes).
Scene two_parallel_sheets(double gap, std::vector<int>& free_vertices) {
  Scene s;
  const TriMesh lower = make_rectangle(1.0, 1.0, 4, 4);
  s.add(lower, lower.V, false);
  TriMesh upper = make_rectangle(0.6, 0.6, 3, 3);
  const double c = std::cos(0.2), sn = std::sin(0.2);
  for (int i = 0; i < upper.num_vertices(); ++i) {
    const double px = upper.V(i, 0), py = upper.V(i, 1);
    upper.V.row(i) << c * px - sn * py + 0.05, sn * px + c * py - 0.03, gap;
  }
  s.add(upper, upper.V, false);
  free_vertices.clear();
  for (int v = lower.num_vertices(); v < s.x.rows(); ++v) free_vertices.push_back(v);
  return s;
}

std::vector<char> mask_of(const std::vector<int>& free_vertices, Eigen::Index n) {
  std::vector<char> m(static_cast<std::size_t>(n), 0);
  for (int v : free_vertices) m[static_cast<std::size_t>(v)] = 1;
  return m;
}

TEST(PatchRelaxation, GapsOfParallelSheetsRestoredIntersectionFreeFixedUntouched) {
  std::vector<int> free;
  Scene s = two_parallel_sheets(1e-5, free);
  const Positions start = s.x;
  GapRelaxationSettings gs;
  gs.min_gap = 1e-3;
  const RelaxationReport r = relax_gaps(s.mesh(), free, gs, s.x);
  const double d = brute_force_min_distance(s);
  std::printf("[gaps] rounds %d, Newton %d, min gap %.3g -> %.6g m (brute force %.6g), satisfied %d\n", r.rounds,
              r.newton_iterations, r.min_gap_before, r.min_gap_after, d, r.satisfied);
  EXPECT_TRUE(r.satisfied);
  EXPECT_NEAR(r.min_gap_before, 1e-5, 1e-12);
  EXPECT_GE(d, gs.min_gap);
  EXPECT_LE(d, 2.0 * gs.min_gap);  // the barrier's reach bounds how far the patch is pushed
  EXPECT_DOUBLE_EQ(r.min_gap_after, d);
  EXPECT_TRUE(test::intersection_free(s.x, s.prims.faces));
  expect_rows_identical(start, s.x, mask_of(free, s.x.rows()));
  EXPECT_EQ(r.skipped_faces, 0);

  // Deterministic: the same input gives bit-identical output.
  std::vector<int> free2;
  Scene again = two_parallel_sheets(1e-5, free2);
  relax_gaps(again.mesh(), free2, gs, again.x);
  EXPECT_TRUE(again.x == s.x);
}

// A 0.4 m sheet (4 x 4 cells) with one interior vertex moved to 1e-4 m from the opposite edge of one
// of its triangles (that triangle's quality ~1e-3 of its rest quality; the vertex is 1e-4 m from the
// triangle across that edge, a self-contact pair).
Scene crushed_sheet(int& vertex) {
  Scene s;
  const TriMesh sheet = make_rectangle(0.4, 0.4, 4, 4);
  vertex = 2 * 5 + 2;  // (i, j) = (2, 2), interior
  int face = -1;
  for (int f = 0; f < sheet.num_faces() && face < 0; ++f)
    for (int k = 0; k < 3; ++k)
      if (sheet.F(f, k) == vertex) face = f;
  int a = -1, b = -1;
  for (int k = 0; k < 3; ++k)
    if (sheet.F(face, k) == vertex) {
      a = sheet.F(face, (k + 1) % 3);
      b = sheet.F(face, (k + 2) % 3);
    }
  Positions x = sheet.V;
  const Vec3 mid = 0.5 * (sheet.V.row(a) + sheet.V.row(b)).transpose();
  const Vec3 toward = (sheet.V.row(vertex).transpose() - mid).normalized();
  x.row(vertex) = (mid + 1e-4 * toward).transpose();
  s.add(sheet, x, true);
  return s;
}

TEST(PatchRelaxation, CrushedTriangleReopenedByGapRelaxationAndByStrainRelaxation) {
  int v = -1;
  {
    Scene s = crushed_sheet(v);
    const Positions start = s.x;
    GapRelaxationSettings gs;
    gs.min_gap = 1e-3;
    const RelaxationReport r = relax_gaps(s.mesh(), {v}, gs, s.x);
    std::printf("[crushed, relax_gaps] rounds %d, Newton %d, min rel. quality %.4g -> %.4g, gap %.3g -> %.4g m, "
                "vertex off rest by %.3g m\n",
                r.rounds, r.newton_iterations, r.min_relative_quality_before, r.min_relative_quality_after,
                r.min_gap_before, r.min_gap_after, (s.x.row(v) - s.rest.row(v)).norm());
    EXPECT_LT(r.min_relative_quality_before, 0.01);
    // The distorted faces are pulled toward their rest shape; the vertex's faces stretched less than
    // 2x keep their start shape as reference (GapRelaxationSettings::keep_start_shape_within) and hold
    // it back a little: 0.90 here (0.998 with every face toward its rest shape, below).
    EXPECT_GT(r.min_relative_quality_after, 0.85);
    EXPECT_TRUE(r.satisfied);
    EXPECT_GE(brute_force_min_distance(s), gs.min_gap);
    EXPECT_TRUE(test::intersection_free(s.x, s.prims.faces));
    expect_rows_identical(start, s.x, mask_of({v}, s.x.rows()));
  }
  {
    Scene s = crushed_sheet(v);
    GapRelaxationSettings gs;
    gs.min_gap = 1e-3;
    gs.keep_start_shape_within = 1.0;  // PSQ as written
    const RelaxationReport r = relax_gaps(s.mesh(), {v}, gs, s.x);
    std::printf("[crushed, relax_gaps, every face toward rest] min rel. quality %.4g -> %.4g\n",
                r.min_relative_quality_before, r.min_relative_quality_after);
    EXPECT_GT(r.min_relative_quality_after, 0.9);
    EXPECT_TRUE(test::intersection_free(s.x, s.prims.faces));
  }
  {
    Scene s = crushed_sheet(v);
    const std::vector<double> limit(static_cast<std::size_t>(s.prims.faces.rows()), 1.1);
    const RelaxationReport r = relax_strain(s.mesh(), {v}, limit, StrainRelaxationSettings{}, s.x);
    std::printf("[crushed, relax_strain] rounds %d, Newton %d, max stretch %.4g -> %.6g, min rel. quality %.4g -> "
                "%.4g\n",
                r.rounds, r.newton_iterations, r.max_stretch_before, r.max_stretch_after,
                r.min_relative_quality_before, r.min_relative_quality_after);
    EXPECT_GT(r.max_stretch_before, 1.1);
    EXPECT_TRUE(r.satisfied);
    EXPECT_LE(max_stretch(s), 1.1 * (1.0 - 1e-3));
    EXPECT_GT(r.min_relative_quality_after, 0.9);
    EXPECT_TRUE(test::intersection_free(s.x, s.prims.faces));
  }
}

// Upsampling-like: an 8 x 8 cell, 1 m sheet; the "old" (coarse) vertices, i and j both even, on the
// rest grid stretched 1.05x in x and fixed; the "new" vertices free, those with odd i shifted by
// 0.15 cell in +x and those with odd j lifted 0.02 cell, so the triangles on the left of odd columns
// are stretched ~1.2x. A limit above 1.05 is reachable: the affine 1.05x state meets it.
struct Upsampled {
  Scene scene;
  std::vector<int> free;
};
Upsampled upsampled_sheet() {
  const int cells = 8;
  const double h = 1.0 / cells;
  const TriMesh sheet = make_rectangle(1.0, 1.0, cells, cells);
  Positions x = sheet.V;
  std::vector<int> free;
  for (int j = 0; j <= cells; ++j)
    for (int i = 0; i <= cells; ++i) {
      const int v = j * (cells + 1) + i;
      x(v, 0) *= 1.05;
      if (i % 2 == 0 && j % 2 == 0) continue;  // old vertex
      free.push_back(v);
      if (i % 2 == 1) x(v, 0) += 0.15 * h;
      if (j % 2 == 1) x(v, 2) += 0.02 * h;
    }
  Upsampled u;
  u.scene.add(sheet, x, true);
  u.free = free;
  return u;
}

// Limit 1.1: the membrane alone (round 1) brings every face under it. Limit 1.06: the membrane's
// equilibrium leaves a few faces at ~1.064 (anchor and free-boundary effects), so the reweighting
// rounds must trade stretch to their neighbours.
TEST(PatchRelaxation, StrainLimitRestoredWithCoarseVerticesFixed) {
  for (const double limit_value : {1.1, 1.06}) {
    Upsampled u = upsampled_sheet();
    Scene& s = u.scene;
    const Positions start = s.x;
    const std::vector<double> limit(static_cast<std::size_t>(s.prims.faces.rows()), limit_value);
    const RelaxationReport r = relax_strain(s.mesh(), u.free, limit, StrainRelaxationSettings{}, s.x);
    std::printf("[strain, limit %.3g] rounds %d, Newton %d, max stretch %.4g -> %.6g (independent %.6g), "
                "min gap %.3g -> %.3g, min rel. quality %.3g -> %.3g\n",
                limit_value, r.rounds, r.newton_iterations, r.max_stretch_before, r.max_stretch_after,
                max_stretch(s), r.min_gap_before, r.min_gap_after, r.min_relative_quality_before,
                r.min_relative_quality_after);
    EXPECT_GE(r.max_stretch_before, 1.19);
    EXPECT_TRUE(r.satisfied);
    EXPECT_LE(max_stretch(s), limit_value * (1.0 - 1e-3));
    EXPECT_DOUBLE_EQ(r.max_stretch_after, max_stretch(s));
    if (limit_value < 1.1) {
      EXPECT_GT(r.rounds, 1);
    }
    EXPECT_TRUE(test::intersection_free(s.x, s.prims.faces));
    expect_rows_identical(start, s.x, mask_of(u.free, s.x.rows()));
  }
}

// Nothing free (or only faces whose vertices are all fixed over the limit): nothing can be done;
// reported unsatisfied and x is left as it was.
TEST(PatchRelaxation, StrainOverLimitOnFixedFacesReportedUnsatisfiedAndUntouched) {
  Upsampled u = upsampled_sheet();
  Scene& s = u.scene;
  const Positions start = s.x;
  const std::vector<double> limit(static_cast<std::size_t>(s.prims.faces.rows()), 1.1);
  const RelaxationReport r = relax_strain(s.mesh(), {}, limit, StrainRelaxationSettings{}, s.x);
  EXPECT_FALSE(r.satisfied);
  EXPECT_EQ(r.rounds, 0);
  EXPECT_GE(r.max_stretch_after, 1.19);
  EXPECT_TRUE(s.x == start);
}

// A sheet stretched 20 % in x and dented, its gaps already wide: the relaxation has nothing to open and no
// crushed face to reshape, so the free interior keeps the stress it starts with (every face's
// reference is its start triangle) and stays where it is. With every face measured from its rest
// shape (PSQ as written) the same interior moves toward rest, the stress that drove the centimetre
// Newton steps of a stretched sheet resting in contact (header, relax_gaps, "Reference").
TEST(PatchRelaxation, AStretchedPatchWithWideGapsKeepsItsStress) {
  const TriMesh sheet = make_rectangle(0.4, 0.4, 4, 4);
  std::vector<int> free;
  for (int v = 0; v < sheet.num_vertices(); ++v) {
    const double px = sheet.V(v, 0), py = sheet.V(v, 1);
    if (std::abs(px) < 0.15 && std::abs(py) < 0.15) free.push_back(v);
  }
  ASSERT_EQ(free.size(), 9u);
  Positions stretched = sheet.V;  // stretched and dented 5 cm at its centre: tension pulls it flat
  stretched.col(0) *= 1.2;
  for (int v = 0; v < sheet.num_vertices(); ++v) {
    const double px = sheet.V(v, 0), py = sheet.V(v, 1);
    stretched(v, 2) = -0.05 * (0.04 - px * px) * (0.04 - py * py) / 0.0016;
  }
  double moved[2] = {0.0, 0.0};
  for (int k = 0; k < 2; ++k) {
    Scene s;
    s.add(sheet, stretched, true);
    GapRelaxationSettings gs;
    gs.min_gap = 1e-3;
    if (k == 1) gs.keep_start_shape_within = 1.0;
    const RelaxationReport r = relax_gaps(s.mesh(), free, gs, s.x);
    EXPECT_TRUE(r.satisfied);
    moved[k] = (s.x - stretched).cwiseAbs().maxCoeff();
  }
  std::printf("[stretched patch] largest move: start as reference %.3g m, rest as reference %.3g m\n", moved[0],
              moved[1]);
  EXPECT_LT(moved[0], 1e-12);
  EXPECT_GT(moved[1], 1e-3);
}

// A stiff anchor (100x the membrane) resists the barrier: kappa_0 is not enough and the stiffness
// rounds must double it until the gap is reached.
TEST(PatchRelaxation, StiffPatchNeedsSeveralStiffnessRounds) {
  std::vector<int> free;
  Scene s = two_parallel_sheets(1e-5, free);
  GapRelaxationSettings gs;
  gs.min_gap = 1e-3;
  gs.anchor_stiffness = 100.0;
  const RelaxationReport r = relax_gaps(s.mesh(), free, gs, s.x);
  const double d = brute_force_min_distance(s);
  std::printf("[stiff anchor] rounds %d, Newton %d, min gap %.3g -> %.6g m (brute force %.6g)\n", r.rounds,
              r.newton_iterations, r.min_gap_before, r.min_gap_after, d);
  EXPECT_GT(r.rounds, 1);
  EXPECT_TRUE(r.satisfied);
  EXPECT_GE(d, gs.min_gap);
  EXPECT_TRUE(test::intersection_free(s.x, s.prims.faces));
}

// A free sheet between two fixed sheets 2e-5 m apart, 3e-6 m above the lower one, asked for a gap
// of 1 mm it can never have, with one Newton iteration per round (so that no round converges). The
// rounds move it toward the middle while its gap grows, then stall (header, "Stalls"): they stop
// there instead of doubling kappa 16 times, with the same gap to within a few percent, and
// intersection-free either way.
TEST(PatchRelaxation, ARelaxationThatCannotOpenItsGapsStopsWhenItsRoundsStall) {
  std::vector<int> free;
  Scene s = two_parallel_sheets(3e-6, free);
  TriMesh upper = make_rectangle(1.0, 1.0, 4, 4);
  for (int i = 0; i < upper.num_vertices(); ++i) upper.V.row(i) << upper.V(i, 0) + 0.013, upper.V(i, 1) - 0.021, 2e-5;
  s.add(upper, upper.V, false);
  Scene full = s;
  GapRelaxationSettings gs;
  gs.min_gap = 1e-3;
  gs.max_stiffness_rounds = 16;
  gs.newton_iterations_per_round = 1;
  const RelaxationReport stopped = relax_gaps(s.mesh(), free, gs, s.x);
  gs.stop_when_stalled = false;
  const RelaxationReport all = relax_gaps(full.mesh(), free, gs, full.x);
  std::printf("[stall] stopped: rounds %d, gap %.4g -> %.4g; all rounds: %d, gap %.4g\n", stopped.rounds,
              stopped.min_gap_before, stopped.min_gap_after, all.rounds, all.min_gap_after);
  EXPECT_FALSE(stopped.satisfied);
  EXPECT_TRUE(stopped.stalled);
  EXPECT_GT(stopped.rounds, 1);  // the first rounds make progress
  EXPECT_LT(stopped.rounds, 16);
  EXPECT_GT(stopped.min_gap_after, stopped.min_gap_before);
  EXPECT_FALSE(all.stalled);
  EXPECT_EQ(all.rounds, 16);
  EXPECT_FALSE(all.satisfied);
  EXPECT_NEAR(stopped.min_gap_after, all.min_gap_after, 0.05 * all.min_gap_after);
  EXPECT_TRUE(test::intersection_free(s.x, s.prims.faces));
  EXPECT_TRUE(test::intersection_free(full.x, full.prims.faces));
}

// Thickness offset 1 mm, sheets 1e-5 m apart: every pair starts 1 mm *inside* the offset (but
// intersection-free). relax_gaps must push them out to d >= offset + min_gap.
TEST(PatchRelaxation, PairsBelowOffsetPushedPastOffsetPlusMinGap) {
  std::vector<int> free;
  Scene s = two_parallel_sheets(1e-5, free);
  const Positions start = s.x;
  const double offset = 1e-3;
  GapRelaxationSettings gs;
  gs.min_gap = 5e-4;
  const RelaxationReport r = relax_gaps(s.mesh(offset), free, gs, s.x);
  const double d = brute_force_min_distance(s);
  std::printf("[offset] rounds %d, Newton %d, d - offset %.4g -> %.6g m (brute force %.6g)\n", r.rounds,
              r.newton_iterations, r.min_gap_before, r.min_gap_after, d - offset);
  EXPECT_LT(r.min_gap_before, -9e-4);
  EXPECT_TRUE(r.satisfied);
  EXPECT_GE(d - offset, gs.min_gap);
  EXPECT_TRUE(test::intersection_free(s.x, s.prims.faces));
  expect_rows_identical(start, s.x, mask_of(free, s.x.rows()));
}

// relax_toward: the free sheet's aim is its own shape moved 0.1 m sideways and 0.05 m down into
// the fixed sheet below. The pull slides it sideways over the fixed sheet (the barrier holds it
// above) instead of stopping where its straight path meets the fixed sheet.
TEST(PatchRelaxation, PullTowardAimsSlidesAlongAFixedSheetAndKeepsTheOffset) {
  std::vector<int> free;
  Scene s = two_parallel_sheets(2e-3, free);
  const Positions start = s.x;
  const double offset = 1e-3;
  Positions aim = s.x;
  for (int v : free) aim.row(v) += Vec3(0.1, 0.0, -0.05).transpose();
  std::vector<Positions> path;
  const RelaxationReport r = relax_toward(s.mesh(offset), free, aim, TargetRelaxationSettings{}, s.x, &path);
  double sideways = 0.0;
  for (int v : free) sideways += (s.x(v, 0) - start(v, 0)) / static_cast<double>(free.size());
  const double d = brute_force_min_distance(s);
  std::printf("[pull] Newton %d, converged %d, distance to aims %.4g -> %.4g m, mean sideways %.5f m, d - offset %.3g m\n",
              r.newton_iterations, r.satisfied ? 1 : 0, r.max_target_distance_before, r.max_target_distance_after,
              sideways, d - offset);
  EXPECT_TRUE(r.satisfied);
  EXPECT_NEAR(sideways, 0.1, 1e-3);
  EXPECT_GT(d, offset);
  EXPECT_TRUE(test::intersection_free(s.x, s.prims.faces));
  expect_rows_identical(start, s.x, mask_of(free, s.x.rows()));
  // The path: one entry per accepted Newton step (the converged iteration takes none), ending at
  // the result, every one intersection-free.
  ASSERT_GE(static_cast<int>(path.size()), r.newton_iterations - 1);
  ASSERT_LE(static_cast<int>(path.size()), r.newton_iterations);
  EXPECT_TRUE(path.back() == s.x);
  for (const Positions& p : path) EXPECT_TRUE(test::intersection_free(p, s.prims.faces));
}

// The ground of a RelaxationMesh holds free vertices above height + offset, in every solve.
TEST(PatchRelaxation, GroundHoldsFreeVerticesAboveItsOffset) {
  Scene s;
  const TriMesh sheet = make_rectangle(0.5, 0.5, 4, 4);
  Positions lifted = sheet.V;
  lifted.col(2).array() += 2e-3;
  s.add(sheet, lifted, true);
  std::vector<int> free;
  for (int v = 0; v < s.x.rows(); ++v) free.push_back(v);
  const double offset = 1e-3;
  GroundPlane ground{Vec3(0, 0, 1), 0.0, std::vector<char>(static_cast<std::size_t>(s.x.rows()), 1)};
  RelaxationMesh mesh = s.mesh(offset);
  mesh.ground = &ground;
  Positions aim = s.x;
  aim.col(2).array() -= 0.05;  // below the ground
  const RelaxationReport r = relax_toward(mesh, free, aim, TargetRelaxationSettings{}, s.x);
  std::printf("[ground] Newton %d, lowest vertex %.4g m (offset %.3g m)\n", r.newton_iterations, s.x.col(2).minCoeff(), offset);
  EXPECT_GT(s.x.col(2).minCoeff(), offset);
  EXPECT_LT(s.x.col(2).maxCoeff(), 2e-3);  // it was pulled down as far as the ground allows

  // Bad ground input: a vertex inside the offset, or vertex_collides of the wrong size.
  Positions low = s.x;
  low(0, 2) = 0.5 * offset;
  EXPECT_THROW(relax_toward(mesh, free, aim, TargetRelaxationSettings{}, low), std::invalid_argument);
  GroundPlane short_ground = ground;
  short_ground.vertex_collides.pop_back();
  mesh.ground = &short_ground;
  EXPECT_THROW(relax_toward(mesh, free, aim, TargetRelaxationSettings{}, s.x), std::invalid_argument);
}

TEST(PatchRelaxation, BadInputThrowsInvalidArgument) {
  std::vector<int> free;
  Scene s = two_parallel_sheets(1e-5, free);
  const int n = static_cast<int>(s.x.rows());
  GapRelaxationSettings gs;
  gs.min_gap = 1e-3;
  Positions x = s.x;
  EXPECT_THROW(relax_gaps(s.mesh(), {n}, gs, x), std::invalid_argument);
  EXPECT_THROW(relax_gaps(s.mesh(), {-1}, gs, x), std::invalid_argument);
  GapRelaxationSettings zero = gs, negative = gs;
  zero.min_gap = 0.0;
  negative.min_gap = -1e-3;
  EXPECT_THROW(relax_gaps(s.mesh(), free, zero, x), std::invalid_argument);
  EXPECT_THROW(relax_gaps(s.mesh(), free, negative, x), std::invalid_argument);
  EXPECT_THROW(relax_gaps(s.mesh(-1.0), free, gs, x), std::invalid_argument);
  EXPECT_THROW(relax_gaps(RelaxationMesh{}, free, gs, x), std::invalid_argument);

  const std::vector<double> ok(static_cast<std::size_t>(s.prims.faces.rows()), 1.1);
  EXPECT_THROW(relax_strain(s.mesh(), {n}, ok, StrainRelaxationSettings{}, x), std::invalid_argument);
  EXPECT_THROW(relax_strain(s.mesh(), free, std::vector<double>(3, 1.1), StrainRelaxationSettings{}, x),
               std::invalid_argument);
  EXPECT_THROW(relax_strain(s.mesh(), free, std::vector<double>(ok.size(), 0.9), StrainRelaxationSettings{}, x),
               std::invalid_argument);
  StrainRelaxationSettings no_gap;
  no_gap.contact_gap = 0.0;
  EXPECT_THROW(relax_strain(s.mesh(), free, ok, no_gap, x), std::invalid_argument);

  EXPECT_THROW(relax_toward(s.mesh(), free, x.topRows(3), TargetRelaxationSettings{}, x), std::invalid_argument);
  TargetRelaxationSettings no_pull;
  no_pull.target_stiffness = 0.0;
  EXPECT_THROW(relax_toward(s.mesh(), free, x, no_pull, x), std::invalid_argument);
  TargetRelaxationSettings no_reach;
  no_reach.contact_gap = -1.0;
  EXPECT_THROW(relax_toward(s.mesh(), free, x, no_reach, x), std::invalid_argument);

  // Touching start (the sheets coincide): the barrier is infinite there.
  Scene touching = two_parallel_sheets(0.0, free);
  EXPECT_THROW(relax_gaps(touching.mesh(), free, gs, touching.x), std::invalid_argument);
  EXPECT_TRUE(x == s.x);  // nothing was changed by refused calls
}

}  // namespace
}  // namespace pd
