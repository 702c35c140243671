// Tests of decimation by recorded edge collapse (hierarchy/decimation.h): vertex counts per level,
// valid and consistently oriented meshes, boundary and locked vertices kept in place, the records
// undone as vertex splits giving back every finer level exactly, determinism, and bad input.
// Meshes stay below 1K vertices so the whole suite runs in a few seconds.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "geometry/shapes.h"
#include "geometry/topology.h"
#include "hierarchy/decimation.h"
#include "hierarchy/grid_coarsening.h"
#include "util/input_error.h"

namespace pd {
namespace {

TriMesh sheet() { return make_rectangle(1.0, 1.0, 29, 29); }         // 900 vertices, 116 on the boundary
TriMesh sphere() { return make_icosphere(0.5, 3); }                  // 642 vertices, closed
TriMesh open_cylinder() { return make_cylinder(0.3, 1.0, 40, 20, false); }  // 840 vertices, 80 on the boundary

std::vector<Level> timed_build(const TriMesh& mesh, const LevelSettings& settings, const char* label) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<Level> levels = build_levels(mesh, settings);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::string counts;
  for (auto it = levels.rbegin(); it != levels.rend(); ++it)
    counts += (counts.empty() ? "" : " -> ") + std::to_string(it->mesh.num_vertices());
  std::printf("  [%s] vertices %s in %.3f s\n", label, counts.c_str(), s);
  return levels;
}

double quality(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double l2 = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
  return 2.0 * std::sqrt(3.0) * (b - a).cross(c - a).norm() / l2;
}

Vec3 row(const TriMesh& m, int i) { return m.V.row(i).transpose(); }

Vec3 face_normal(const TriMesh& m, int f) {
  return (row(m, m.F(f, 1)) - row(m, m.F(f, 0))).cross(row(m, m.F(f, 2)) - row(m, m.F(f, 0)));
}

// Area-weighted vertex normals.
std::vector<Vec3> vertex_normals(const TriMesh& m) {
  std::vector<Vec3> n(static_cast<std::size_t>(m.num_vertices()), Vec3::Zero());
  for (int f = 0; f < m.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) n[static_cast<std::size_t>(m.F(f, k))] += face_normal(m, f);
  return n;
}

// Every level: validate_mesh passes (manifold edges, consistent orientation, no zero-area face, no
// unused vertex), and every face's normal agrees in sign with the finest surface near it (the normal
// at the finest vertex nearest to the face's centroid). Returns the worst triangle quality seen.
double expect_valid_levels(const std::vector<Level>& levels, const std::string& label) {
  const TriMesh& finest = levels.back().mesh;
  const std::vector<Vec3> fine_n = vertex_normals(finest);
  double worst = 1.0;
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const TriMesh& m = levels[l].mesh;
    SCOPED_TRACE(label + " level " + std::to_string(l));
    EXPECT_NO_THROW(validate_mesh(m, "level"));
    int disagree = 0;
    for (int f = 0; f < m.num_faces(); ++f) {
      const Vec3 c = (row(m, m.F(f, 0)) + row(m, m.F(f, 1)) + row(m, m.F(f, 2))) / 3.0;
      int best = 0;
      double best_d = 1e300;
      for (int i = 0; i < finest.num_vertices(); ++i) {
        const double d = (row(finest, i) - c).squaredNorm();
        if (d < best_d) best_d = d, best = i;
      }
      if (face_normal(m, f).dot(fine_n[static_cast<std::size_t>(best)]) <= 0.0) ++disagree;
      worst = std::min(worst, quality(row(m, m.F(f, 0)), row(m, m.F(f, 1)), row(m, m.F(f, 2))));
    }
    EXPECT_EQ(disagree, 0) << "faces whose normal opposes the fine surface";
    // The maps are consistent with the meshes.
    EXPECT_TRUE(m.V.allFinite());
    EXPECT_EQ(static_cast<int>(levels[l].to_finest.size()), m.num_vertices());
    if (l + 1 < levels.size()) {
      const Level& finer = levels[l + 1];
      if (static_cast<int>(levels[l].coarse_to_fine.size()) != m.num_vertices() ||
          static_cast<int>(levels[l].fine_to_coarse.size()) != finer.mesh.num_vertices()) {
        ADD_FAILURE() << "map sizes";
        continue;
      }
      int removed = 0;
      for (int j = 0; j < finer.mesh.num_vertices(); ++j) {
        const int c = levels[l].fine_to_coarse[static_cast<std::size_t>(j)];
        if (c < 0) { ++removed; continue; }
        EXPECT_EQ(levels[l].coarse_to_fine[static_cast<std::size_t>(c)], j);
        EXPECT_EQ(levels[l].to_finest[static_cast<std::size_t>(c)], finer.to_finest[static_cast<std::size_t>(j)]);
      }
      EXPECT_EQ(removed, static_cast<int>(levels[l].collapses.size()));
      EXPECT_EQ(removed, finer.mesh.num_vertices() - m.num_vertices());
    }
  }
  std::printf("  [%s] worst triangle quality over all levels %.3f (finest %.3f)\n", label.c_str(), worst,
              [&] {
                double w = 1.0;
                for (int f = 0; f < finest.num_faces(); ++f)
                  w = std::min(w, quality(row(finest, finest.F(f, 0)), row(finest, finest.F(f, 1)),
                                          row(finest, finest.F(f, 2))));
                return w;
              }());
  return worst;
}

// Undoes level l's collapses, last first, as vertex splits on level l's mesh (in level l+1 ids):
// faces_after out, faces_before in, the two vertices back at their recorded positions. The result must
// be level l+1's mesh exactly: the same set of faces and bit-identical positions.
void expect_replay_gives_finer(const Level& coarse, const Level& finer) {
  std::set<Tri> faces;
  for (int f = 0; f < coarse.mesh.num_faces(); ++f) {
    auto to_fine = [&](int k) { return coarse.coarse_to_fine[static_cast<std::size_t>(coarse.mesh.F(f, k))]; };
    faces.insert(canonical_tri(to_fine(0), to_fine(1), to_fine(2)));
  }
  Positions P = Positions::Constant(finer.mesh.num_vertices(), 3, std::nan(""));
  for (int i = 0; i < coarse.mesh.num_vertices(); ++i)
    P.row(coarse.coarse_to_fine[static_cast<std::size_t>(i)]) = coarse.mesh.V.row(i);
  std::set<int> alive(coarse.coarse_to_fine.begin(), coarse.coarse_to_fine.end());

  for (auto it = coarse.collapses.rbegin(); it != coarse.collapses.rend(); ++it) {
    const Collapse& c = *it;
    ASSERT_NE(c.removed, c.kept);
    ASSERT_EQ(alive.count(c.kept), 1u);
    ASSERT_EQ(alive.count(c.removed), 0u) << "vertex " << c.removed << " split twice";
    // faces_after is faces_before without the faces on the edge, with removed renamed kept.
    std::vector<Tri> derived;
    for (const Tri& t : c.faces_before) {
      const bool has_r = std::count(t.begin(), t.end(), c.removed) > 0, has_k = std::count(t.begin(), t.end(), c.kept) > 0;
      ASSERT_TRUE(has_r || has_k);
      if (has_r && has_k) continue;
      Tri u = t;
      for (int& v : u) if (v == c.removed) v = c.kept;
      derived.push_back(canonical_tri(u[0], u[1], u[2]));
    }
    std::sort(derived.begin(), derived.end());
    ASSERT_EQ(derived, c.faces_after);
    ASSERT_TRUE(std::is_sorted(c.faces_before.begin(), c.faces_before.end()));
    // The filter's promises (default settings): every surviving face turns by at most 45 degrees and
    // keeps quality >= min(0.2, the patch's worst before).
    {
      Positions before = P;
      before.row(c.kept) = c.kept_position_before.transpose();
      before.row(c.removed) = c.removed_position.transpose();
      auto pos = [](const Positions& X, int i) { return Vec3(X.row(i).transpose()); };
      double worst_before = 1.0;
      for (const Tri& t : c.faces_before)
        worst_before = std::min(worst_before, quality(pos(before, t[0]), pos(before, t[1]), pos(before, t[2])));
      for (const Tri& t : c.faces_before) {
        if (std::count(t.begin(), t.end(), c.removed) + std::count(t.begin(), t.end(), c.kept) == 2) continue;
        Tri u = t;
        for (int& v : u) if (v == c.removed) v = c.kept;
        const Vec3 nb = (pos(before, t[1]) - pos(before, t[0])).cross(pos(before, t[2]) - pos(before, t[0]));
        Vec3 ua[3];
        for (int k = 0; k < 3; ++k) ua[k] = u[static_cast<std::size_t>(k)] == c.kept ? c.kept_position_after : pos(P, u[static_cast<std::size_t>(k)]);
        const Vec3 na = (ua[1] - ua[0]).cross(ua[2] - ua[0]);
        EXPECT_GE(nb.normalized().dot(na.normalized()), std::cos(45.0 * M_PI / 180.0) - 1e-12);
        EXPECT_GE(quality(ua[0], ua[1], ua[2]), std::min(0.2, worst_before) - 1e-12);
      }
    }
    // The split.
    for (const Tri& t : c.faces_after) ASSERT_EQ(faces.erase(t), 1u) << "faces_after not in the mesh";
    for (const Tri& t : c.faces_before) ASSERT_TRUE(faces.insert(t).second) << "faces_before already there";
    ASSERT_EQ(Vec3(P.row(c.kept).transpose()), c.kept_position_after);
    P.row(c.kept) = c.kept_position_before.transpose();
    P.row(c.removed) = c.removed_position.transpose();
    alive.insert(c.removed);
  }
  const std::vector<Tri> expected = sorted_tris(finer.mesh.F);
  EXPECT_EQ(std::vector<Tri>(faces.begin(), faces.end()), expected);
  EXPECT_TRUE(P == finer.mesh.V) << "positions after the splits differ from the finer level's";
}

void expect_all_replays(const std::vector<Level>& levels) {
  for (std::size_t l = 0; l + 1 < levels.size(); ++l) {
    SCOPED_TRACE("undoing level " + std::to_string(l));
    expect_replay_gives_finer(levels[l], levels[l + 1]);
  }
}

// Finest ids present in `level` with their finest positions unchanged.
void expect_kept_in_place(const std::vector<Level>& levels, const std::vector<int>& finest_ids, const char* what) {
  const TriMesh& finest = levels.back().mesh;
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const std::vector<int>& tf = levels[l].to_finest;
    int missing = 0, moved = 0;
    for (int id : finest_ids) {
      const auto it = std::lower_bound(tf.begin(), tf.end(), id);
      if (it == tf.end() || *it != id) { ++missing; continue; }
      const int i = static_cast<int>(it - tf.begin());
      if (!(levels[l].mesh.V.row(i) == finest.V.row(id))) ++moved;
    }
    EXPECT_EQ(missing, 0) << what << " vertices removed at level " << l;
    EXPECT_EQ(moved, 0) << what << " vertices moved at level " << l;
  }
}

std::vector<int> boundary_ids(const TriMesh& m) {
  const Topology topo = build_topology(m);
  std::vector<int> ids;
  for (int i = 0; i < m.num_vertices(); ++i)
    if (topo.boundary_vertex[static_cast<std::size_t>(i)]) ids.push_back(i);
  return ids;
}

void expect_counts(const std::vector<Level>& levels, const std::vector<int>& finer_to_coarser_targets) {
  ASSERT_EQ(levels.size(), finer_to_coarser_targets.size() + 1);
  for (std::size_t k = 0; k < finer_to_coarser_targets.size(); ++k) {
    const int l = static_cast<int>(finer_to_coarser_targets.size() - 1 - k);
    const int t = finer_to_coarser_targets[k];
    const int got = levels[static_cast<std::size_t>(l)].mesh.num_vertices();
    EXPECT_GE(got, t) << "level " << l;
    EXPECT_LE(got, t + t / 50) << "level " << l;  // the default 2% tolerance
  }
}

// ---- Counts -----------------------------------------------------------------------------------------

TEST(Decimation, SheetHitsTargetCountsAndKeepsEveryBoundaryVertex) {
  const TriMesh m = sheet();
  LevelSettings s;
  s.target_vertex_counts = {450, 225, 150};
  const std::vector<Level> levels = timed_build(m, s, "sheet 30x30");
  expect_counts(levels, s.target_vertex_counts);
  expect_valid_levels(levels, "sheet");
  expect_kept_in_place(levels, boundary_ids(m), "boundary");
  expect_all_replays(levels);
}

TEST(Decimation, IcosphereHitsDefaultRatioCounts) {
  const TriMesh m = sphere();
  const std::vector<Level> levels = timed_build(m, LevelSettings{}, "icosphere 642, ratio 4");
  // Default: three coarser levels, 4x fewer vertices each: round(642 / 4^k).
  expect_counts(levels, {161, 40, 10});
  const double worst = expect_valid_levels(levels, "icosphere");
  EXPECT_GT(worst, 0.0);
  expect_all_replays(levels);
}

TEST(Decimation, CylinderWithBoundaryHitsTargetCounts) {
  const TriMesh m = open_cylinder();
  LevelSettings s;
  s.target_vertex_counts = {420, 200, 110};
  const std::vector<Level> levels = timed_build(m, s, "open cylinder 840");
  expect_counts(levels, s.target_vertex_counts);
  expect_valid_levels(levels, "cylinder");
  const std::vector<int> boundary = boundary_ids(m);
  ASSERT_EQ(boundary.size(), 80u);
  expect_kept_in_place(levels, boundary, "boundary");
  expect_all_replays(levels);
}

TEST(Decimation, SingleDecimateMatchesItsMaps) {
  const TriMesh m = sphere();
  const Decimation d = decimate(m, 100);
  EXPECT_EQ(d.coarse.num_vertices(), 100);
  EXPECT_EQ(static_cast<int>(d.collapses.size()), m.num_vertices() - 100);
  ASSERT_EQ(static_cast<int>(d.fine_to_coarse.size()), m.num_vertices());
  EXPECT_TRUE(std::is_sorted(d.coarse_to_fine.begin(), d.coarse_to_fine.end()));
  for (int i = 0; i < d.coarse.num_vertices(); ++i)
    EXPECT_EQ(d.fine_to_coarse[static_cast<std::size_t>(d.coarse_to_fine[static_cast<std::size_t>(i)])], i);
  // Every removed id is removed once; the coarse vertices are exactly those never removed.
  std::vector<int> removed;
  for (const Collapse& c : d.collapses) removed.push_back(c.removed);
  std::sort(removed.begin(), removed.end());
  EXPECT_EQ(std::unique(removed.begin(), removed.end()), removed.end());
  for (int r : removed) EXPECT_EQ(d.fine_to_coarse[static_cast<std::size_t>(r)], -1);
  Level as_level{d.coarse, {}, d.coarse_to_fine, d.fine_to_coarse, d.collapses};
  Level fine_level{m, {}, {}, {}, {}};
  expect_replay_gives_finer(as_level, fine_level);
}

// ---- Boundary and locked vertices ---------------------------------------------------------------------

TEST(Decimation, LockedVerticesSurviveInPlace) {
  const TriMesh m = sphere();
  std::vector<int> cap;  // a pinned cap around the north pole (z > 0.35 of radius 0.5), and the south pole
  for (int i = 0; i < m.num_vertices(); ++i)
    if (m.V(i, 2) > 0.35 || m.V(i, 2) < -0.499) cap.push_back(i);
  ASSERT_GT(cap.size(), 40u);
  LevelSettings s;
  s.locked_vertices = cap;
  s.target_vertex_counts = {300, 200, 150};
  const std::vector<Level> levels = timed_build(m, s, "icosphere with locked cap");
  expect_counts(levels, s.target_vertex_counts);
  expect_valid_levels(levels, "locked sphere");
  expect_kept_in_place(levels, cap, "locked");
  expect_all_replays(levels);
}

TEST(Decimation, LockedInteriorVerticesOfASheetSurvive) {
  const TriMesh m = sheet();
  std::vector<int> pinned;  // a 4x4 block in the middle and a diagonal line
  for (int j = 13; j < 17; ++j)
    for (int i = 13; i < 17; ++i) pinned.push_back(j * 30 + i);
  for (int k = 2; k < 28; k += 3) pinned.push_back(k * 30 + k);
  LevelSettings s;
  s.locked_vertices = pinned;
  s.target_vertex_counts = {400, 200};
  const std::vector<Level> levels = timed_build(m, s, "sheet with locked block");
  expect_counts(levels, s.target_vertex_counts);
  expect_valid_levels(levels, "locked sheet");
  expect_kept_in_place(levels, pinned, "locked");
  expect_kept_in_place(levels, boundary_ids(m), "boundary");
  expect_all_replays(levels);
}

// keep_boundary = false: boundary vertices may go, but only along straight stretches, so the corners
// stay and every finest boundary vertex still lies on the coarse boundary polygon. This is what lets a
// sheet reach the default 4x-per-level counts (its 116 boundary vertices exceed the coarsest target).
TEST(Decimation, StraightBoundaryMayCoarsenWhenAllowed) {
  const TriMesh m = sheet();
  LevelSettings s;
  s.decimation.keep_boundary = false;
  const std::vector<Level> levels = timed_build(m, s, "sheet, straight boundary may coarsen");
  expect_counts(levels, {225, 56, 14});
  expect_valid_levels(levels, "sheet relaxed boundary");
  expect_kept_in_place(levels, {0, 29, 870, 899}, "corner");
  // Every coarse boundary vertex is a finest boundary vertex at its finest position, and every
  // finest boundary vertex lies on the square's outline (so on some coarse boundary edge).
  for (const Level& level : levels) {
    const std::vector<int> b = boundary_ids(level.mesh);
    for (int i : b) {
      const int id = level.to_finest[static_cast<std::size_t>(i)];
      EXPECT_TRUE(level.mesh.V.row(i) == m.V.row(id));
      const double x = std::abs(m.V(id, 0)), y = std::abs(m.V(id, 1));
      EXPECT_TRUE(x == 0.5 || y == 0.5) << "boundary vertex " << id << " off the outline";
    }
  }
  // The outline is unchanged: the coarsest boundary has the four corners and its area is 1.
  const TriMesh& c = levels.front().mesh;
  double area = 0.0;
  for (int f = 0; f < c.num_faces(); ++f) area += 0.5 * face_normal(c, f).z();
  EXPECT_NEAR(area, 1.0, 1e-12);
  expect_all_replays(levels);
}

// ---- Determinism ------------------------------------------------------------------------------------

// ---- Prescribed vertex sets (LevelSettings::kept_vertices) ------------------------------------------

// Faces of `level` that have no mirror image in it, mirrored in x (the sheet is centred on 0).
int faces_without_mirror_image(const Level& level) {
  const TriMesh& m = level.mesh;
  auto key = [](double x, double y) { return std::pair{std::llround(x * 1e6), std::llround(y * 1e6)}; };
  std::map<std::pair<long long, long long>, int> at;
  for (int v = 0; v < m.num_vertices(); ++v) at[key(m.V(v, 0), m.V(v, 1))] = v;
  const std::vector<Tri> tris = sorted_tris(m.F);
  int unmatched = 0;
  for (const Tri& t : tris) {
    std::array<int, 3> mirrored{};
    for (int k = 0; k < 3; ++k) {
      const auto it = at.find(key(-m.V(t[static_cast<std::size_t>(k)], 0), m.V(t[static_cast<std::size_t>(k)], 1)));
      mirrored[static_cast<std::size_t>(k)] = it == at.end() ? -1 : it->second;
    }
    // A mirror image has the opposite orientation: compare as vertex sets.
    std::sort(mirrored.begin(), mirrored.end());
    bool found = false;
    for (const Tri& u : tris) {
      std::array<int, 3> su = u;
      std::sort(su.begin(), su.end());
      found = found || su == mirrored;
    }
    unmatched += found ? 0 : 1;
  }
  return unmatched;
}

TEST(Decimation, KeptVertexSetsAreExactlyTheLevelsInPlaceMirrorSymmetricAndReplay) {
  const int cells = 16;
  const TriMesh m = make_rectangle(1.0, 1.0, cells, cells);
  for (const bool pinned_boundary : {false, true}) {
    SCOPED_TRACE(pinned_boundary ? "boundary pinned" : "free boundary");
    LevelSettings s;
    s.decimation.keep_boundary = false;  // as in scenes: straight boundary stretches coarsen too
    if (pinned_boundary) s.locked_vertices = boundary_ids(m);
    std::vector<char> fixed(static_cast<std::size_t>(m.num_vertices()), 0);
    for (int v : s.locked_vertices) fixed[static_cast<std::size_t>(v)] = 1;
    for (std::vector<int> kept : grid_level_vertices(lattice_of(m.V, {cells, cells, 0}), 2)) {
      for (int v = 0; v < m.num_vertices(); ++v)
        if (fixed[static_cast<std::size_t>(v)]) kept.push_back(v);
      std::sort(kept.begin(), kept.end());
      kept.erase(std::unique(kept.begin(), kept.end()), kept.end());
      s.target_vertex_counts.push_back(static_cast<int>(kept.size()));
      s.kept_vertices.push_back(std::move(kept));
    }
    const std::vector<Level> levels = timed_build(m, s, "sheet 17x17, grid sets");
    ASSERT_EQ(levels.size(), 3u);
    for (int k = 0; k < 2; ++k) {
      const Level& level = levels[static_cast<std::size_t>(1 - k)];
      EXPECT_EQ(level.to_finest, s.kept_vertices[static_cast<std::size_t>(k)]) << "level " << 1 - k;
      EXPECT_EQ(faces_without_mirror_image(level), 0) << "level " << 1 - k;
    }
    // Kept vertices collapse onto each other only when locked, so no vertex of any level has moved.
    for (const Level& level : levels)
      for (int i = 0; i < level.mesh.num_vertices(); ++i)
        EXPECT_TRUE(level.mesh.V.row(i) == m.V.row(level.to_finest[static_cast<std::size_t>(i)]));
    expect_valid_levels(levels, "grid sets");
    expect_all_replays(levels);
  }
}

bool same_collapse(const Collapse& a, const Collapse& b) {
  return a.removed == b.removed && a.kept == b.kept && a.removed_position == b.removed_position &&
         a.kept_position_before == b.kept_position_before && a.kept_position_after == b.kept_position_after &&
         a.faces_before == b.faces_before && a.faces_after == b.faces_after;
}

TEST(Decimation, TwoRunsAreBitIdentical) {
  const TriMesh m = open_cylinder();
  LevelSettings s;
  s.target_vertex_counts = {420, 200, 110};
  s.locked_vertices = {300, 301, 302, 340};
  const std::vector<Level> a = build_levels(m, s), b = build_levels(m, s);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t l = 0; l < a.size(); ++l) {
    EXPECT_TRUE(a[l].mesh.V == b[l].mesh.V) << "level " << l;  // exact, bit for bit
    EXPECT_TRUE(a[l].mesh.F == b[l].mesh.F) << "level " << l;
    EXPECT_EQ(a[l].to_finest, b[l].to_finest);
    EXPECT_EQ(a[l].coarse_to_fine, b[l].coarse_to_fine);
    EXPECT_EQ(a[l].fine_to_coarse, b[l].fine_to_coarse);
    ASSERT_EQ(a[l].collapses.size(), b[l].collapses.size());
    for (std::size_t k = 0; k < a[l].collapses.size(); ++k)
      ASSERT_TRUE(same_collapse(a[l].collapses[k], b[l].collapses[k])) << "level " << l << " collapse " << k;
  }
}

// ---- Bad input --------------------------------------------------------------------------------------

void expect_input_error(const TriMesh& m, const LevelSettings& s, const std::vector<std::string>& parts) {
  try {
    build_levels(m, s);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    for (const std::string& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
  }
}

TEST(Decimation, TooFewVerticesIsAnInputError) {
  LevelSettings s;
  s.target_vertex_counts = {100, 3};
  expect_input_error(sphere(), s, {"level 0 (coarsest)", "target of 3 vertices", "at least 4", "642"});
  s.target_vertex_counts = {700};
  expect_input_error(sphere(), s, {"level 0", "target of 700", "not below", "642"});
  s.target_vertex_counts = {300, 300};
  expect_input_error(sphere(), s, {"level 0", "target of 300", "not below level 1's 300"});
}

TEST(Decimation, FixedVerticesAboveTheTargetIsAnInputError) {
  // The sheet's 116 boundary vertices stay, so 100 cannot be reached.
  LevelSettings s;
  s.target_vertex_counts = {400, 100};
  expect_input_error(sheet(), s, {"level 0 (coarsest)", "target of 100", "from 900", "116 vertices are never removed",
                                  "0 locked, 116 other boundary vertices"});
  // Without keep_boundary, the open cylinder's two circular rims (80 vertices, every one a turn of
  // the boundary) still stay, so the default ratio's level 1 (53) cannot be reached.
  LevelSettings relaxed;
  relaxed.decimation.keep_boundary = false;
  expect_input_error(open_cylinder(), relaxed, {"level 1", "target of 53", "80 vertices are never removed",
                                                "80 other boundary vertices where the boundary is not straight"});
  // Everything locked.
  LevelSettings all;
  for (int i = 0; i < 642; ++i) all.locked_vertices.push_back(i);
  expect_input_error(sphere(), all, {"level 2", "target of 161", "642 vertices are never removed", "642 locked"});
  // A locked id that does not exist.
  LevelSettings bad;
  bad.locked_vertices = {642};
  expect_input_error(sphere(), bad, {"level 3 (finest)", "locked vertex 642 does not exist"});
}

TEST(Decimation, NonManifoldMeshIsAnInputError) {
  // Three triangles on one edge.
  TriMesh fin;
  fin.V.resize(5, 3);
  fin.V << 0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, -1, 0, 0.5, 0, 1;
  fin.F.resize(3, 3);
  fin.F << 0, 1, 2, 1, 0, 3, 0, 1, 4;
  LevelSettings s;
  s.target_vertex_counts = {4};
  expect_input_error(fin, s, {"level 1 (finest)", "shared by 3 faces"});
  // Two closed tetrahedra sharing one vertex (a pinched vertex; every edge is manifold).
  TriMesh bowtie;
  bowtie.V.resize(7, 3);
  bowtie.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, -1, 0, 0, 0, -1, 0, 0, 0, -1;
  bowtie.F.resize(8, 3);
  bowtie.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3,   // tetrahedron 0,1,2,3
              0, 5, 4, 0, 4, 6, 0, 6, 5, 4, 5, 6;   // tetrahedron 0,4,5,6
  s.target_vertex_counts = {6};
  expect_input_error(bowtie, s, {"level 1 (finest)", "vertex 0 is non-manifold", "2 separate fans"});
}

TEST(Decimation, UnreachableCountIsAnInputError) {
  // A closed mesh made of two tetrahedra (8 vertices): no collapse keeps a tetrahedron a manifold
  // surface, so the run stops at 8 vertices, far above 5.
  TriMesh two;
  two.V.resize(8, 3);
  two.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 3, 0, 0, 4, 0, 0, 3, 1, 0, 3, 0, 1;
  two.F.resize(8, 3);
  two.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3, 4, 6, 5, 4, 5, 7, 4, 7, 6, 5, 6, 7;
  LevelSettings s;
  s.target_vertex_counts = {5};
  expect_input_error(two, s, {"level 0 (coarsest)", "stopped at 8", "target of 5"});
}

TEST(Decimation, BadKeptVertexSetsAreInputErrors) {
  const TriMesh m = make_rectangle(1.0, 1.0, 4, 4);  // 25 vertices; (i, j) at 5 j + i
  LevelSettings s;
  s.decimation.keep_boundary = false;
  s.target_vertex_counts = {9};
  s.kept_vertices = {{0, 2, 4, 10, 12, 14, 20, 22, 24}, {0, 4, 20, 24}};
  expect_input_error(m, s, {"kept_vertices", "one list per entry"});
  // A coarser list naming a vertex the finer level no longer has.
  s.target_vertex_counts = {9, 5};
  s.kept_vertices = {{0, 2, 4, 10, 12, 14, 20, 22, 24}, {0, 4, 6, 20, 24}};
  expect_input_error(m, s, {"level 0 (coarsest)", "kept vertex 6", "not a vertex of level 1"});
  // A target above the kept set leaves a vertex that is neither kept nor fixed.
  s.target_vertex_counts = {10};
  s.kept_vertices = {{0, 2, 4, 10, 12, 14, 20, 22, 24}};
  expect_input_error(m, s, {"level 0", "target of 10 vertices leaves vertex", "neither kept nor fixed"});
}

}  // namespace
}  // namespace pd
