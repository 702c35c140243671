// Tests of the contact broad phase: identical candidate sets to a brute force over all pairs (random
// soups, a folded sheet, oversized primitives), adjacency and self-contact exclusion, swept queries,
// determinism, input checks, and a 100K-vertex sheet (timing printed, not asserted).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <stdexcept>
#include <vector>

#include "geometry/shapes.h"
#include "physics/contact/broad_phase.h"

namespace pd {
namespace {

using Pairs = std::vector<std::array<int, 2>>;

// Unique undirected edges (lo < hi) of any triangle soup, sorted.
std::vector<std::array<int, 2>> edges_of(const Faces& F) {
  std::set<std::array<int, 2>> s;
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      s.insert({std::min(a, b), std::max(a, b)});
    }
  return {s.begin(), s.end()};
}

// Several objects stacked into one scene, as the simulator does.
struct Scene {
  Positions V;
  ContactPrimitives prims;
  void add(const Positions& Vo, const Faces& Fo, bool self_contact) {
    const int offset = static_cast<int>(V.rows());
    const int object = static_cast<int>(prims.object_self_contact.size());
    V.conservativeResize(offset + Vo.rows(), 3);
    V.bottomRows(Vo.rows()) = Vo;
    const int m0 = static_cast<int>(prims.faces.rows());
    prims.faces.conservativeResize(m0 + Fo.rows(), 3);
    prims.faces.bottomRows(Fo.rows()) = Fo.array() + offset;
    for (auto e : edges_of(Fo)) prims.edges.push_back({e[0] + offset, e[1] + offset});
    prims.vertex_object.insert(prims.vertex_object.end(), static_cast<std::size_t>(Vo.rows()), object);
    prims.object_self_contact.push_back(self_contact ? 1 : 0);
  }
  void add(const TriMesh& m, bool self_contact) { add(m.V, m.F, self_contact); }
};

// ---- brute force: the contract of broad_phase.h, written out over all pairs ---------------------

struct TestBox {
  double lo[3], hi[3];
};

TestBox box(const std::vector<int>& vs, const Positions& V0, const Positions* V1, double r) {
  TestBox b{{1e300, 1e300, 1e300}, {-1e300, -1e300, -1e300}};
  for (const Positions* V : {&V0, V1})
    if (V)
      for (int v : vs)
        for (int k = 0; k < 3; ++k) {
          b.lo[k] = std::min(b.lo[k], (*V)(v, k));
          b.hi[k] = std::max(b.hi[k], (*V)(v, k));
        }
  for (int k = 0; k < 3; ++k) {
    b.lo[k] -= 0.5 * r;
    b.hi[k] += 0.5 * r;
  }
  return b;
}

bool boxes_overlap(const TestBox& a, const TestBox& b) {
  for (int k = 0; k < 3; ++k)
    if (a.lo[k] > b.hi[k] || b.lo[k] > a.hi[k]) return false;
  return true;
}

CandidatePairs brute_force(const ContactPrimitives& p, const Positions& V0, const Positions* V1, double r) {
  const auto& obj = p.vertex_object;
  auto allowed = [&](int u, int v) { return obj[u] != obj[v] || p.object_self_contact[obj[u]]; };
  CandidatePairs out;
  for (int v = 0; v < V0.rows(); ++v)
    for (int f = 0; f < p.faces.rows(); ++f) {
      const std::vector<int> fv = {p.faces(f, 0), p.faces(f, 1), p.faces(f, 2)};
      if (std::count(fv.begin(), fv.end(), v) == 0 && allowed(v, fv[0]) &&
          boxes_overlap(box({v}, V0, V1, r), box(fv, V0, V1, r)))
        out.point_triangle.push_back({v, f});
    }
  const int ne = static_cast<int>(p.edges.size());
  for (int a = 0; a < ne; ++a)
    for (int b = a + 1; b < ne; ++b) {
      const auto &ea = p.edges[a], &eb = p.edges[b];
      const bool share = ea[0] == eb[0] || ea[0] == eb[1] || ea[1] == eb[0] || ea[1] == eb[1];
      if (!share && allowed(ea[0], eb[0]) &&
          boxes_overlap(box({ea[0], ea[1]}, V0, V1, r), box({eb[0], eb[1]}, V0, V1, r)))
        out.edge_edge.push_back({a, b});
    }
  return out;
}

CandidatePairs query(const Scene& s, const Positions* V1, double r) {
  return V1 ? find_swept_candidates(s.prims, s.V, *V1, r) : find_candidates(s.prims, s.V, r);
}

void expect_sorted_unique(const Pairs& p) {
  for (std::size_t i = 1; i < p.size(); ++i) ASSERT_LT(p[i - 1], p[i]) << "at " << i;
}

// Grid result == brute force, and both non-trivial (returns the number of pairs).
std::size_t expect_matches_brute_force(const Scene& s, const Positions* V1, double r) {
  const CandidatePairs fast = query(s, V1, r);
  const CandidatePairs slow = brute_force(s.prims, s.V, V1, r);
  EXPECT_EQ(fast.point_triangle, slow.point_triangle) << "r = " << r << (V1 ? " swept" : "");
  EXPECT_EQ(fast.edge_edge, slow.edge_edge) << "r = " << r << (V1 ? " swept" : "");
  expect_sorted_unique(fast.point_triangle);
  expect_sorted_unique(fast.edge_edge);
  return slow.point_triangle.size() + slow.edge_edge.size();
}

// ---- scenes ----------------------------------------------------------------------------------------

// A random-walk soup: nearby faces share vertices and edges, far ones do not (metres, ~unit cube).
void add_random_soup(Scene& s, std::mt19937& rng, int n, bool self_contact) {
  std::uniform_real_distribution<double> step(-0.08, 0.08), start(0.0, 1.0);
  std::uniform_int_distribution<int> near(1, 4);
  Positions V(n, 3);
  V.row(0) << start(rng), start(rng), start(rng);
  for (int i = 1; i < n; ++i) V.row(i) = V.row(i - 1) + Eigen::RowVector3d(step(rng), step(rng), step(rng));
  std::vector<std::array<int, 3>> faces;
  for (int i = 0; i + 4 < n; ++i) {
    const int j = i + near(rng), k = i + near(rng);
    if (j != k) faces.push_back({i, j, k});
  }
  Faces F(static_cast<int>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f)
    F.row(static_cast<int>(f)) << faces[f][0], faces[f][1], faces[f][2];
  s.add(V, F, self_contact);
}

// A 0.4 m x 0.2 m sheet (20 x 10 cells, 2 cm) folded in half about x = 0: the right half lies
// mirrored `gap` metres above the left half.
TriMesh folded_sheet(double gap) {
  TriMesh m = make_rectangle(0.4, 0.2, 20, 10);
  for (int i = 0; i < m.num_vertices(); ++i)
    if (m.V(i, 0) > 1e-12) m.V.row(i) << -m.V(i, 0), m.V(i, 1), gap;
  return m;
}

// ---- tests ---------------------------------------------------------------------------------------

TEST(BroadPhase, MatchesBruteForceOnRandomSoups) {
  std::mt19937 rng(12345);
  std::size_t total = 0;
  for (int trial = 0; trial < 12; ++trial) {
    Scene s;
    for (int o = 0; o < 3; ++o) add_random_soup(s, rng, 30, (trial + o) % 2 == 0);
    std::normal_distribution<double> motion(0.0, 0.05);
    Positions V1 = s.V;
    for (Eigen::Index i = 0; i < V1.size(); ++i) V1.data()[i] += motion(rng);
    for (double r : {0.0, 0.01, 0.05, 0.2}) {
      total += expect_matches_brute_force(s, nullptr, r);
      total += expect_matches_brute_force(s, &V1, r);
    }
  }
  EXPECT_GT(total, 1000u);  // the comparison is not vacuous
}

// A query primitive of an object without self-contact steps over its own object's targets when they
// are one run of ids (as scenes stack them); when they are not, nothing is skipped. Both give the
// brute force's pairs: two soups without self-contact, once as added and once with a face and an
// edge of each object swapped, so neither object's faces or edges are one run.
TEST(BroadPhase, MatchesBruteForceWhetherOrNotAnObjectsPrimitivesAreOneRun) {
  std::mt19937 rng(777);
  std::size_t total = 0;
  for (bool interleave : {false, true}) {
    Scene s;
    add_random_soup(s, rng, 40, false);
    const Eigen::Index faces0 = s.prims.faces.rows();
    const std::size_t edges0 = s.prims.edges.size();
    add_random_soup(s, rng, 40, false);
    if (interleave) {
      s.prims.faces.row(0).swap(s.prims.faces.row(faces0));
      std::swap(s.prims.edges[0], s.prims.edges[edges0]);
    }
    for (double r : {0.01, 0.05, 0.2}) total += expect_matches_brute_force(s, nullptr, r);
  }
  EXPECT_GT(total, 200u);  // the comparison is not vacuous
}

TEST(BroadPhase, MatchesBruteForceOnFoldedSheets) {
  Scene s;
  s.add(folded_sheet(0.004), true);
  TriMesh below = make_rectangle(0.3, 0.3, 9, 9);
  below.V.col(2).array() -= 0.003;
  s.add(below, false);
  Positions V1 = s.V;  // the step moves everything down 1 cm and shears it
  for (int i = 0; i < V1.rows(); ++i) V1.row(i) += Eigen::RowVector3d(0.2 * V1(i, 1), 0.0, -0.01);
  for (double r : {0.0, 0.001, 0.005, 0.03}) {
    EXPECT_GT(expect_matches_brute_force(s, nullptr, r), 0u);
    EXPECT_GT(expect_matches_brute_force(s, &V1, r), 0u);
  }
  Scene faces_only = s;  // no edge list: the cell size comes from the faces' sides
  faces_only.prims.edges.clear();
  EXPECT_GT(expect_matches_brute_force(faces_only, nullptr, 0.005), 0u);
}

// A 100 m ground (two triangles) under a fine sheet, and one sheet vertex that moves 5 m in the step:
// their boxes cover far more cells than the limit, so they take the direct-test path.
TEST(BroadPhase, MatchesBruteForceWithOversizedPrimitives) {
  Scene s;
  TriMesh ground = make_rectangle(100.0, 100.0, 1, 1);
  s.add(ground, false);
  TriMesh sheet = make_rectangle(0.2, 0.2, 10, 10);
  sheet.V.col(2).array() += 0.002;
  s.add(sheet, true);
  s.add(folded_sheet(0.003), true);
  Positions V1 = s.V;
  V1.col(2).array() -= 0.004;
  V1.row(10) += Eigen::RowVector3d(3.0, -4.0, 0.0);
  for (double r : {0.0, 0.001, 0.005}) {
    EXPECT_GT(expect_matches_brute_force(s, nullptr, r), 0u);
    EXPECT_GT(expect_matches_brute_force(s, &V1, r), 0u);
  }
}

// Unit square split along 0-2, with a radius so large that every box overlaps every other: only the
// non-adjacent pairs remain. Edges (sorted): 0:(0,1) 1:(0,2) 2:(0,3) 3:(1,2) 4:(2,3).
TEST(BroadPhase, ExcludesPairsSharingAVertex) {
  Scene s;
  Positions V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  Faces F(2, 3);
  F << 0, 1, 2, 0, 2, 3;
  s.add(V, F, true);
  const CandidatePairs c = find_candidates(s.prims, s.V, 10.0);
  EXPECT_EQ(c.point_triangle, (Pairs{{1, 1}, {3, 0}}));
  EXPECT_EQ(c.edge_edge, (Pairs{{0, 4}, {2, 3}}));

  // On a folded sheet, no reported pair shares a vertex (and there are many pairs).
  Scene f;
  f.add(folded_sheet(0.002), true);
  const CandidatePairs d = find_candidates(f.prims, f.V, 0.01);
  ASSERT_GT(d.point_triangle.size(), 100u);
  for (const auto& [v, face] : d.point_triangle)
    for (int k = 0; k < 3; ++k) EXPECT_NE(v, f.prims.faces(face, k));
  for (const auto& [a, b] : d.edge_edge) {
    const auto &ea = f.prims.edges[a], &eb = f.prims.edges[b];
    EXPECT_TRUE(ea[0] != eb[0] && ea[0] != eb[1] && ea[1] != eb[0] && ea[1] != eb[1]);
  }
}

TEST(BroadPhase, SelfContactOffExcludesIntraObjectPairsOnly) {
  auto count = [](const Scene& s, const CandidatePairs& c) {
    std::array<int, 3> n{};  // [0]: within object 0, [1]: within object 1, [2]: across
    auto tally = [&](int u, int v) {
      const int ou = s.prims.vertex_object[u], ov = s.prims.vertex_object[v];
      ++n[ou != ov ? 2 : ou];
    };
    for (const auto& [v, f] : c.point_triangle) tally(v, s.prims.faces(f, 0));
    for (const auto& [a, b] : c.edge_edge) tally(s.prims.edges[a][0], s.prims.edges[b][0]);
    return n;
  };
  TriMesh upper = folded_sheet(0.002);
  upper.V.col(2).array() += 0.004;
  for (bool self0 : {true, false}) {
    Scene s;
    s.add(folded_sheet(0.002), self0);
    s.add(upper, true);
    const std::array<int, 3> n = count(s, find_candidates(s.prims, s.V, 0.005));
    if (self0)
      EXPECT_GT(n[0], 0);
    else
      EXPECT_EQ(n[0], 0);
    EXPECT_GT(n[1], 0);
    EXPECT_GT(n[2], 0);
  }
}

// Triangle B (vertices 3-5) falls from 1 m above triangle A (0-2) to 1 m below it: the two only meet
// mid-step, so only the swept query pairs them.
TEST(BroadPhase, SweptQueryFindsPairsMeetingOnlyMidStep) {
  Scene s;
  Positions V(6, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0,  //
      0.2, 0.2, 1, 0.9, 0.3, 1, 0.3, 0.9, 1;
  Faces F(2, 3);
  F << 0, 1, 2, 3, 4, 5;
  s.add(V, F, true);
  Positions V1 = V;
  V1.bottomRows(3).col(2).array() = -1.0;
  const double r = 0.01;
  EXPECT_TRUE(find_candidates(s.prims, V, r) == CandidatePairs{});
  EXPECT_TRUE(find_candidates(s.prims, V1, r) == CandidatePairs{});
  const CandidatePairs swept = find_swept_candidates(s.prims, V, V1, r);
  const Pairs& pt = swept.point_triangle;
  EXPECT_NE(std::find(pt.begin(), pt.end(), std::array<int, 2>{3, 0}), pt.end());  // B's corner through A
  // A's hypotenuse (1,2) and B's edge (3,4) cross in projection: an edge-edge pair mid-step.
  const auto& E = s.prims.edges;
  const int a = static_cast<int>(std::find(E.begin(), E.end(), std::array<int, 2>{1, 2}) - E.begin());
  const int b = static_cast<int>(std::find(E.begin(), E.end(), std::array<int, 2>{3, 4}) - E.begin());
  const Pairs& ee = swept.edge_edge;
  EXPECT_NE(std::find(ee.begin(), ee.end(), std::array<int, 2>{a, b}), ee.end());
  EXPECT_EQ(expect_matches_brute_force(s, &V1, r), pt.size() + ee.size());
}

TEST(BroadPhase, IsDeterministic) {
  Scene s;
  std::mt19937 rng(7);
  add_random_soup(s, rng, 200, true);
  s.add(folded_sheet(0.002), true);
  const Positions V1 = s.V.array() + 0.01;
  const CandidatePairs first = find_candidates(s.prims, s.V, 0.01);
  const Scene copy = s;
  EXPECT_EQ(find_candidates(copy.prims, copy.V, 0.01), first);
  EXPECT_EQ(find_candidates(s.prims, s.V, 0.01), first);
  EXPECT_EQ(find_swept_candidates(s.prims, s.V, V1, 0.01),
            find_swept_candidates(copy.prims, copy.V, V1, 0.01));
}

TEST(BroadPhase, RejectsInconsistentInput) {
  Scene s;
  s.add(folded_sheet(0.002), true);
  EXPECT_THROW(find_candidates(s.prims, s.V, -1.0), std::invalid_argument);
  EXPECT_THROW(find_candidates(s.prims, s.V, std::nan("")), std::invalid_argument);
  EXPECT_THROW(find_candidates(s.prims, s.V.topRows(3), 0.01), std::invalid_argument);
  EXPECT_THROW(find_swept_candidates(s.prims, s.V, s.V.topRows(3), 0.01), std::invalid_argument);
  ContactPrimitives bad = s.prims;
  bad.faces(0, 0) = static_cast<int>(s.V.rows());
  EXPECT_THROW(find_candidates(bad, s.V, 0.01), std::invalid_argument);
  bad = s.prims;
  bad.object_self_contact.push_back(1);
  bad.vertex_object[bad.faces(0, 1)] = 1;  // face 0 now spans objects 0 and 1
  EXPECT_THROW(find_candidates(bad, s.V, 0.01), std::invalid_argument);
  Positions nan_v = s.V;
  nan_v(0, 0) = std::nan("");
  EXPECT_THROW(find_candidates(s.prims, nan_v, 0.01), std::invalid_argument);
  EXPECT_TRUE(find_candidates(ContactPrimitives{}, Positions(0, 3), 0.01) == CandidatePairs{});
}

// Scale: a 317 x 317 vertex sheet (100,489 vertices), waved so the grid is genuinely 3D. Timing is
// printed for the record, never asserted (it depends on the machine and build type).
TEST(BroadPhase, HandlesAHundredThousandVertexSheet) {
  Scene s;
  TriMesh sheet = make_rectangle(1.0, 1.0, 316, 316);
  for (int i = 0; i < sheet.num_vertices(); ++i)
    sheet.V(i, 2) = 0.05 * std::sin(20 * sheet.V(i, 0)) * std::cos(17 * sheet.V(i, 1));
  s.add(sheet, true);
  const auto t0 = std::chrono::steady_clock::now();
  const CandidatePairs c = find_candidates(s.prims, s.V, 1e-3);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[ info     ] %ld vertices, r = 1 mm: %zu point-triangle + %zu edge-edge pairs in %.1f ms\n",
              static_cast<long>(s.V.rows()), c.point_triangle.size(), c.edge_edge.size(), ms);
  EXPECT_GT(c.point_triangle.size(), 100000u);
  expect_sorted_unique(c.point_triangle);
  expect_sorted_unique(c.edge_edge);
}

// ---- edge-face candidates (find_edge_face_candidates, for the start-state check) -----------------

Pairs brute_force_edge_face(const ContactPrimitives& p, const Positions& V, double r) {
  const auto& obj = p.vertex_object;
  Pairs out;
  for (int e = 0; e < static_cast<int>(p.edges.size()); ++e)
    for (int f = 0; f < p.faces.rows(); ++f) {
      const std::vector<int> fv = {p.faces(f, 0), p.faces(f, 1), p.faces(f, 2)};
      const auto& ev = p.edges[e];
      const bool share = std::count(fv.begin(), fv.end(), ev[0]) + std::count(fv.begin(), fv.end(), ev[1]) > 0;
      const bool allowed = obj[ev[0]] != obj[fv[0]] || p.object_self_contact[obj[ev[0]]];
      if (!share && allowed && boxes_overlap(box({ev[0], ev[1]}, V, nullptr, r), box(fv, V, nullptr, r)))
        out.push_back({e, f});
    }
  return out;
}

std::size_t expect_edge_face_matches_brute_force(const Scene& s, double r) {
  const Pairs fast = find_edge_face_candidates(s.prims, s.V, r);
  const Pairs slow = brute_force_edge_face(s.prims, s.V, r);
  EXPECT_EQ(fast, slow) << "r = " << r;
  expect_sorted_unique(fast);
  return slow.size();
}

TEST(BroadPhaseEdgeFace, MatchesBruteForce) {
  std::size_t total = 0;
  std::mt19937 rng(4242);
  for (int trial = 0; trial < 8; ++trial) {
    Scene s;
    for (int o = 0; o < 3; ++o) add_random_soup(s, rng, 30, (trial + o) % 2 == 0);
    for (double r : {0.0, 0.01, 0.05, 0.2}) total += expect_edge_face_matches_brute_force(s, r);
  }
  Scene folded;  // a folded sheet with self-contact over a flat one without
  folded.add(folded_sheet(0.004), true);
  TriMesh below = make_rectangle(0.3, 0.3, 9, 9);
  below.V.col(2).array() -= 0.003;
  folded.add(below, false);
  for (double r : {0.0, 0.001, 0.005, 0.03}) EXPECT_GT(expect_edge_face_matches_brute_force(folded, r), 0u);
  Scene oversized;  // a 100 m ground of two triangles: boxes beyond the cell limit take the direct path
  oversized.add(make_rectangle(100.0, 100.0, 1, 1), false);
  TriMesh sheet = make_rectangle(0.2, 0.2, 10, 10);
  sheet.V.col(2).array() += 0.002;
  oversized.add(sheet, true);
  for (double r : {0.0, 0.005}) EXPECT_GT(expect_edge_face_matches_brute_force(oversized, r), 0u);
  Scene faces_only = folded;  // no edges at all: no pairs
  faces_only.prims.edges.clear();
  EXPECT_TRUE(find_edge_face_candidates(faces_only.prims, faces_only.V, 0.01).empty());
  EXPECT_GT(total, 1000u);  // the comparison is not vacuous
}

TEST(BroadPhaseEdgeFace, ExcludesSharedVerticesAndSelfContactOff) {
  // Unit square split along 0-2: every edge touches every face, so nothing remains even though all
  // boxes overlap.
  Scene square;
  Positions V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  Faces F(2, 3);
  F << 0, 1, 2, 0, 2, 3;
  square.add(V, F, true);
  EXPECT_TRUE(find_edge_face_candidates(square.prims, square.V, 10.0).empty());
  // Two separate triangles (A: vertices 0-2, B: 3-5) in one object: 3 edges of each against the
  // other's face, but none with self-contact off; as two objects, all 6 whatever the flags.
  Positions T(6, 3);
  T << 0, 0, 0, 1, 0, 0, 0, 1, 0,  //
      0.2, 0.2, 0.5, 0.9, 0.3, 0.5, 0.3, 0.9, 0.5;
  Faces FT(2, 3);
  FT << 0, 1, 2, 3, 4, 5;
  for (bool self : {true, false}) {
    Scene one;
    one.add(T, FT, self);
    EXPECT_EQ(find_edge_face_candidates(one.prims, one.V, 1.0).size(), self ? 6u : 0u);
    Scene two;
    Faces single(1, 3);
    single << 0, 1, 2;
    two.add(T.topRows(3), single, self);
    two.add(T.bottomRows(3), single, self);
    EXPECT_EQ(find_edge_face_candidates(two.prims, two.V, 1.0),
              (Pairs{{0, 1}, {1, 1}, {2, 1}, {3, 0}, {4, 0}, {5, 0}}));
  }
  EXPECT_THROW(find_edge_face_candidates(square.prims, square.V, -1.0), std::invalid_argument);
}

}  // namespace
}  // namespace pd
