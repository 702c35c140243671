// Tests of the intrinsic (successive self-parameterization) locations of fine vertices on coarser
// levels (hierarchy/intrinsic_location.h): valid locations, flat sheets stay on the sheet and near the
// rest position, distinct points and orientation-preserving images (bijectivity), no jumping between
// close sheets of a folded strip, exact rest recovery of ShellProlongation built from them (per level
// and direct), direct vs composed operators, determinism. Meshes below 1K vertices.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "geometry/shapes.h"
#include "hierarchy/decimation.h"
#include "hierarchy/intrinsic_location.h"
#include "hierarchy/shell_prolongation.h"

namespace pd {
namespace {

LevelSettings settings(bool keep_boundary, int levels = 2, std::vector<int> targets = {}) {
  LevelSettings s;
  s.coarser_levels = levels;
  s.target_vertex_counts = std::move(targets);
  s.decimation.keep_boundary = keep_boundary;
  return s;
}

// Face in range, weights >= -1e-12, sum 1 within 1e-12.
void expect_valid(const std::vector<SurfaceLocation>& locs, const TriMesh& coarse, int num_fine) {
  ASSERT_EQ(static_cast<int>(locs.size()), num_fine);
  int bad = 0;
  for (const SurfaceLocation& s : locs)
    if (s.face < 0 || s.face >= coarse.num_faces() || s.bary.minCoeff() < -1e-12 ||
        std::abs(s.bary.sum() - 1.0) > 1e-12 || !s.bary.allFinite())
      ++bad;
  EXPECT_EQ(bad, 0) << "invalid locations";
}

Positions located_points(const std::vector<SurfaceLocation>& locs, const TriMesh& coarse) {
  Positions P(static_cast<Eigen::Index>(locs.size()), 3);
  for (std::size_t i = 0; i < locs.size(); ++i) {
    Vec3 x = Vec3::Zero();
    for (int k = 0; k < 3; ++k) x += locs[i].bary[k] * coarse.V.row(coarse.F(locs[i].face, k)).transpose();
    P.row(static_cast<Eigen::Index>(i)) = x.transpose();
  }
  return P;
}

double mean_edge(const TriMesh& m) {
  double s = 0.0;
  for (int f = 0; f < m.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) s += (m.V.row(m.F(f, k)) - m.V.row(m.F(f, (k + 1) % 3))).norm();
  return s / (3.0 * m.num_faces());
}

std::vector<SurfaceLocation> per_level(const std::vector<Level>& levels, std::size_t l, LocationStats* st = nullptr) {
  return locate_through_collapses(levels[l + 1].mesh, levels[l].collapses, levels[l].mesh, levels[l].coarse_to_fine, st);
}

// Flat sheet, both boundary settings: valid locations on the coarse plane, near the rest position.
TEST(IntrinsicLocation, FlatSheetValidOnPlaneAndNearRest) {
  for (bool keep : {true, false}) {
    const TriMesh fine = make_rectangle(1.0, 1.0, 24, 24);
    // With keep_boundary the 96 boundary vertices stay, so the targets are set above them.
    const std::vector<Level> levels =
        build_levels(fine, keep ? settings(true, 2, {250, 130}) : settings(false));
    for (std::size_t l = 0; l + 1 < levels.size(); ++l) {
      SCOPED_TRACE("keep_boundary " + std::to_string(keep) + " level " + std::to_string(l));
      LocationStats st;
      const auto locs = per_level(levels, l, &st);
      const TriMesh& coarse = levels[l].mesh;
      const TriMesh& finer = levels[l + 1].mesh;
      expect_valid(locs, coarse, finer.num_vertices());
      const Positions P = located_points(locs, coarse);
      double max_z = 0.0, max_d = 0.0, outside = 0.0;
      for (Eigen::Index i = 0; i < P.rows(); ++i) {
        max_z = std::max(max_z, std::abs(P(i, 2)));
        max_d = std::max(max_d, (P.row(i) - finer.V.row(i)).norm());
        for (int k = 0; k < 2; ++k) outside = std::max({outside, -0.5 - P(i, k), P(i, k) - 0.5});
      }
      const double h = mean_edge(coarse);
      std::printf("  [sheet keep=%d level %zu] %d -> %d vertices, %d collapses, %d fallbacks, worst clamped %.2e, "
                  "max |z| %.2e, max |U Vc - Xf| %.4f m = %.2f coarse mean edges\n",
                  keep, l, finer.num_vertices(), coarse.num_vertices(), st.collapses, st.fallback_collapses,
                  st.worst_negative, max_z, max_d, max_d / h);
      EXPECT_EQ(st.fallback_collapses, 0);
      EXPECT_LT(max_z, 1e-12);
      EXPECT_LT(outside, 1e-12);
      EXPECT_LT(max_d, 1.5 * h);
    }
    // Direct locations of the finest vertices on every level.
    for (int l = 0; l + 1 < static_cast<int>(levels.size()); ++l) {
      const auto locs = locate_finest_on_level(levels, l);
      expect_valid(locs, levels[static_cast<std::size_t>(l)].mesh, fine.num_vertices());
      const Positions P = located_points(locs, levels[static_cast<std::size_t>(l)].mesh);
      const double max_d = (P - fine.V).rowwise().norm().maxCoeff();
      std::printf("  [sheet keep=%d direct level %d] max |U Vc - Xf| %.4f m = %.2f level mean edges\n", keep, l,
                  max_d, max_d / mean_edge(levels[static_cast<std::size_t>(l)].mesh));
      EXPECT_LT(max_d, 1.5 * mean_edge(levels[static_cast<std::size_t>(l)].mesh));
    }
  }
}

// Bijectivity: on a flat sheet the located points of distinct fine vertices are distinct, and the
// images of the fine faces (the fine mesh drawn with its vertices at their located points) keep their
// orientation (measured; a piecewise-linear bijection need not map straight fine edges to straight
// lines, so a few flips would not contradict bijectivity, but none are expected at these sizes).
TEST(IntrinsicLocation, SheetDistinctPointsAndOrientation) {
  const TriMesh fine = make_rectangle(1.0, 1.0, 24, 24);
  const std::vector<Level> levels = build_levels(fine, settings(false));
  for (int l = 0; l + 1 < static_cast<int>(levels.size()); ++l) {
    const auto locs = locate_finest_on_level(levels, l);
    const Positions P = located_points(locs, levels[static_cast<std::size_t>(l)].mesh);
    double min_sep = 1e300;
    for (Eigen::Index i = 0; i < P.rows(); ++i)
      for (Eigen::Index j = i + 1; j < P.rows(); ++j) min_sep = std::min(min_sep, (P.row(i) - P.row(j)).norm());
    int flipped = 0;
    double min_ratio = 1e300;
    for (int f = 0; f < fine.num_faces(); ++f) {
      auto area = [&](const Positions& X) {
        const Eigen::RowVector3d a = X.row(fine.F(f, 0)), b = X.row(fine.F(f, 1)), c = X.row(fine.F(f, 2));
        return 0.5 * ((b - a)(0) * (c - a)(1) - (b - a)(1) * (c - a)(0));
      };
      const double r = area(P) / area(fine.V);
      min_ratio = std::min(min_ratio, r);
      if (r <= 0.0) ++flipped;
    }
    const double h = 1.0 / 24.0;
    std::printf("  [sheet direct level %d] min separation of located points %.4f fine edges, flipped fine-face "
                "images %d of %d, smallest area ratio %.3f\n",
                l, min_sep / h, flipped, fine.num_faces(), min_ratio);
    EXPECT_GT(min_sep, 1e-3 * h);
    EXPECT_EQ(flipped, 0);
  }
}

// A long strip folded into a U with the arms 1 mm apart: every fine vertex is located on its own arm.
TEST(IntrinsicLocation, FoldedStripNoJumpBetweenArms) {
  const double a = 0.5, g = 1e-3, w = 0.1;
  const int n = 25, rows = 5;  // cells per arm along x, cells across
  const int cols = 2 * (n + 1);
  TriMesh m;
  m.V.resize(cols * (rows + 1), 3);
  std::vector<int> arm(static_cast<std::size_t>(cols * (rows + 1)));
  for (int c = 0; c < cols; ++c)
    for (int r = 0; r <= rows; ++r) {
      const int v = r * cols + c;
      const bool second = c > n;
      const double x = second ? a - (c - n - 1) * (a / n) : c * (a / n);
      m.V.row(v) << x, r * (w / rows), second ? g : 0.0;
      arm[static_cast<std::size_t>(v)] = second ? 1 : 0;
    }
  m.F.resize(2 * (cols - 1) * rows, 3);
  int f = 0;
  for (int c = 0; c + 1 < cols; ++c)
    for (int r = 0; r < rows; ++r) {
      const int v00 = r * cols + c, v10 = v00 + 1, v01 = v00 + cols, v11 = v01 + 1;
      m.F.row(f++) << v00, v10, v11;
      m.F.row(f++) << v00, v11, v01;
    }
  const std::vector<Level> levels = build_levels(m, settings(false));
  for (int l = 0; l + 1 < static_cast<int>(levels.size()); ++l) {
    const TriMesh& coarse = levels[static_cast<std::size_t>(l)].mesh;
    LocationStats st;
    const auto locs = locate_finest_on_level(levels, l, &st);
    expect_valid(locs, coarse, m.num_vertices());
    const Positions P = located_points(locs, coarse);
    const double H = mean_edge(coarse);
    int wrong_side = 0, mixed_far = 0, mixed_near = 0;
    double max_dz = 0.0;
    for (int i = 0; i < m.num_vertices(); ++i) {
      const int own = arm[static_cast<std::size_t>(i)];
      const double dz = std::abs(P(i, 2) - m.V(i, 2));
      max_dz = std::max(max_dz, dz);
      if (dz >= 0.5 * g) ++wrong_side;
      bool mixed = false;
      for (int k = 0; k < 3; ++k) {
        const int fv = levels[static_cast<std::size_t>(l)].to_finest[static_cast<std::size_t>(coarse.F(locs[static_cast<std::size_t>(i)].face, k))];
        if (arm[static_cast<std::size_t>(fv)] != own) mixed = true;
      }
      if (mixed) (a - m.V(i, 0) > 3.0 * H ? mixed_far : mixed_near)++;
    }
    std::printf("  [folded strip level %d] %d -> %d vertices, %d fallbacks, max |z_located - z_rest| %.2e m "
                "(gap %.0e), on the other arm %d, in a face bridging the arms: %d within 3 coarse edges of the "
                "fold, %d farther\n",
                l, m.num_vertices(), coarse.num_vertices(), st.fallback_collapses, max_dz, g, wrong_side, mixed_near,
                mixed_far);
    EXPECT_EQ(wrong_side, 0);
    EXPECT_EQ(mixed_far, 0);
  }
}

// ShellProlongation from these locations gives back the fine rest shape exactly, per level and direct.
void expect_exact_recovery(const TriMesh& fine, const LevelSettings& s, const char* label) {
  const std::vector<Level> levels = build_levels(fine, s);
  double worst = 0.0;
  int fallbacks = 0;
  for (std::size_t l = 0; l + 1 < levels.size(); ++l) {
    SCOPED_TRACE(std::string(label) + " level " + std::to_string(l));
    LocationStats st;
    const auto locs = per_level(levels, l, &st);
    fallbacks += st.fallback_collapses;
    expect_valid(locs, levels[l].mesh, levels[l + 1].mesh.num_vertices());
    const ShellProlongation P(levels[l].mesh.V, levels[l].mesh.F, levels[l + 1].mesh.V, locs);
    const double err = (P.apply(levels[l].mesh.V) - levels[l + 1].mesh.V).cwiseAbs().maxCoeff();
    worst = std::max(worst, err);
    EXPECT_LT(err, 1e-12);
    const Eigen::SparseMatrix<double, Eigen::RowMajor> Ur = P.U();
    for (Eigen::Index r = 0; r < Ur.rows(); ++r) EXPECT_LE(Ur.outerIndexPtr()[r + 1] - Ur.outerIndexPtr()[r], 3);
    // Direct P^l.
    const auto dlocs = locate_finest_on_level(levels, static_cast<int>(l), &st);
    fallbacks += st.fallback_collapses;
    const ShellProlongation Pd(levels[l].mesh.V, levels[l].mesh.F, fine.V, dlocs);
    const double derr = (Pd.apply(levels[l].mesh.V) - fine.V).cwiseAbs().maxCoeff();
    worst = std::max(worst, derr);
    EXPECT_LT(derr, 1e-12);
  }
  std::printf("  [%s] %d vertices, %zu levels: worst |P(Vc) - Xf| %.2e m (per level and direct), %d fallback collapses\n",
              label, fine.num_vertices(), levels.size(), worst, fallbacks);
}

TEST(IntrinsicLocation, ShellProlongationRecoversRestShape) {
  expect_exact_recovery(make_rectangle(1.0, 1.0, 24, 24), settings(false), "sheet");
  expect_exact_recovery(make_icosphere(0.5, 3), settings(true, 3), "icosphere");
  expect_exact_recovery(make_cylinder(0.3, 1.0, 40, 20, false), settings(true, 2, {300, 120}),
                        "open cylinder (boundary kept)");
  expect_exact_recovery(make_rectangle(1.0, 1.0, 24, 24), settings(true, 2, {250, 130}), "sheet (boundary kept)");
}

// Direct P^0 vs the composition of per-level operators: both recover the finest rest shape; their
// intrinsic parts (U^0 Vc) differ only by the difference between tracking a point through the
// piecewise-linear maps and interpolating its tracked neighbours linearly (measured).
TEST(IntrinsicLocation, DirectVsComposedLevel0) {
  const TriMesh fine = make_icosphere(0.5, 3);
  const std::vector<Level> levels = build_levels(fine, settings(true, 3));
  const int L = static_cast<int>(levels.size()) - 1;
  Eigen::SparseMatrix<double> Ucomp;
  for (int l = L - 1; l >= 0; --l) {
    const auto locs = per_level(levels, static_cast<std::size_t>(l));
    const ShellProlongation P(levels[static_cast<std::size_t>(l)].mesh.V, levels[static_cast<std::size_t>(l)].mesh.F,
                              levels[static_cast<std::size_t>(l + 1)].mesh.V, locs);
    Ucomp = (l == L - 1) ? P.U() : Eigen::SparseMatrix<double>(Ucomp * P.U());
  }
  const TriMesh& c0 = levels[0].mesh;
  const auto dlocs = locate_finest_on_level(levels, 0);
  const ShellProlongation Pd(c0.V, c0.F, fine.V, dlocs);
  const Positions direct = Pd.apply_linear(c0.V);
  const Positions composed = Ucomp * c0.V;
  const double diff = (direct - composed).rowwise().norm().maxCoeff();
  const double mean_diff = (direct - composed).rowwise().norm().mean();
  int max_nnz = 0;
  const Eigen::SparseMatrix<double, Eigen::RowMajor> Ur = Ucomp;
  for (Eigen::Index r = 0; r < Ur.rows(); ++r) max_nnz = std::max(max_nnz, Ur.outerIndexPtr()[r + 1] - Ur.outerIndexPtr()[r]);
  const double rest_err = (Pd.apply(c0.V) - fine.V).cwiseAbs().maxCoeff();
  std::printf("  [icosphere level 0 of %d] |U_direct Vc - U_composed Vc| max %.4f m mean %.4f m (coarse mean edge %.4f m); "
              "composed U has up to %d nonzeros per row, direct 3; direct P^0 rest error %.2e m\n",
              L, diff, mean_diff, mean_edge(c0), max_nnz, rest_err);
  EXPECT_LT(rest_err, 1e-12);
  EXPECT_LT(diff, mean_edge(c0));
}

// The one-pass descent (used by build_scene_hierarchy) must give every level exactly what the
// per-level function gives: same face, same barycentric bits, for every finest vertex.
TEST(IntrinsicLocation, AllLevelsAtOnceMatchPerLevelBitForBit) {
  const TriMesh fine = make_cylinder(0.3, 1.0, 40, 20, false);
  const std::vector<Level> levels = build_levels(fine, settings(true, 3, {500, 250, 120}));
  const auto all = locate_finest_on_all_levels(levels);
  ASSERT_EQ(all.size(), levels.size());
  std::size_t compared = 0;
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const auto one = locate_finest_on_level(levels, static_cast<int>(l));
    ASSERT_EQ(all[l].size(), one.size()) << "level " << l;
    for (std::size_t i = 0; i < one.size(); ++i) {
      EXPECT_EQ(all[l][i].face, one[i].face) << "level " << l << " vertex " << i;
      EXPECT_TRUE((all[l][i].bary.array() == one[i].bary.array()).all()) << "level " << l << " vertex " << i;
      ++compared;
    }
  }
  EXPECT_EQ(compared, levels.size() * static_cast<std::size_t>(fine.num_vertices()));
  EXPECT_THROW(locate_finest_on_all_levels(std::vector<Level>{}), std::invalid_argument);
}

TEST(IntrinsicLocation, Deterministic) {
  const TriMesh fine = make_cylinder(0.3, 1.0, 40, 20, false);
  const std::vector<Level> levels = build_levels(fine, settings(true, 2, {300, 120}));
  const auto a = locate_finest_on_level(levels, 0), b = locate_finest_on_level(levels, 0);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].face, b[i].face);
    EXPECT_TRUE((a[i].bary.array() == b[i].bary.array()).all());
  }
}

// A hand-made record the joint flattening does not cover (the decimation never produces it): a
// boundary vertex collapsed into an interior one, which then becomes a boundary vertex, so the
// before and after boundary loops differ by more than `removed`. The collapse takes the 3D
// closest-point fall-back and the locations stay valid and on the (flat) surface.
TEST(IntrinsicLocation, UnsupportedRecordTakesFallBack) {
  const TriMesh fine = make_rectangle(1.0, 1.0, 2, 2);  // 9 vertices, centre 4, bottom middle 1
  const int removed = 1, kept = 4;
  Collapse c;
  c.removed = removed;
  c.kept = kept;
  c.removed_position = fine.V.row(removed).transpose();
  c.kept_position_before = fine.V.row(kept).transpose();
  c.kept_position_after = c.removed_position;
  std::vector<Tri> kept_faces;
  for (int f = 0; f < fine.num_faces(); ++f) {
    const Tri t = canonical_tri(fine.F(f, 0), fine.F(f, 1), fine.F(f, 2));
    const bool r = std::count(t.begin(), t.end(), removed) > 0, k = std::count(t.begin(), t.end(), kept) > 0;
    if (r || k) c.faces_before.push_back(t);
    if (r && k) continue;
    Tri u = t;
    for (int& v : u) v = v == removed ? kept : v;
    if (r || k) c.faces_after.push_back(canonical_tri(u[0], u[1], u[2]));
    kept_faces.push_back(canonical_tri(u[0], u[1], u[2]));
  }
  std::sort(c.faces_before.begin(), c.faces_before.end());
  std::sort(c.faces_after.begin(), c.faces_after.end());
  TriMesh coarse;
  std::vector<int> coarse_to_fine, fine_to_coarse(9, -1);
  for (int v = 0; v < 9; ++v)
    if (v != removed) fine_to_coarse[static_cast<std::size_t>(v)] = static_cast<int>(coarse_to_fine.size()), coarse_to_fine.push_back(v);
  coarse.V.resize(8, 3);
  for (int i = 0; i < 8; ++i) coarse.V.row(i) = fine.V.row(coarse_to_fine[static_cast<std::size_t>(i)]);
  coarse.V.row(fine_to_coarse[kept]) = c.kept_position_after.transpose();
  coarse.F.resize(static_cast<Eigen::Index>(kept_faces.size()), 3);
  for (std::size_t f = 0; f < kept_faces.size(); ++f)
    for (int k = 0; k < 3; ++k) coarse.F(static_cast<Eigen::Index>(f), k) = fine_to_coarse[static_cast<std::size_t>(kept_faces[f][static_cast<std::size_t>(k)])];
  LocationStats st;
  const auto locs = locate_through_collapses(fine, {c}, coarse, coarse_to_fine, &st);
  expect_valid(locs, coarse, fine.num_vertices());
  const Positions P = located_points(locs, coarse);
  EXPECT_EQ(st.fallback_collapses, 1);
  EXPECT_LT(P.col(2).cwiseAbs().maxCoeff(), 1e-15);
  // The removed vertex's own point lands where kept now is (same position); the others stay put.
  EXPECT_LT((P - fine.V).rowwise().norm().maxCoeff(), 0.5);
  for (int v : {0, 2, 6, 7, 8}) EXPECT_LT((P.row(v) - fine.V.row(v)).norm(), 1e-15) << v;
}

TEST(IntrinsicLocation, FinestLevelIsIdentityAndBadLevelThrows) {
  const TriMesh fine = make_rectangle(1.0, 1.0, 8, 8);
  const std::vector<Level> levels = build_levels(fine, settings(false, 1));
  const auto locs = locate_finest_on_level(levels, static_cast<int>(levels.size()) - 1);
  const Positions P = located_points(locs, fine);
  EXPECT_EQ((P - fine.V).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_THROW(locate_finest_on_level(levels, -1), std::invalid_argument);
  EXPECT_THROW(locate_finest_on_level(levels, static_cast<int>(levels.size())), std::invalid_argument);
}

}  // namespace
}  // namespace pd
