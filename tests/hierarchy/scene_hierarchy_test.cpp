// Tests of the scene-wide level hierarchy (hierarchy/scene_hierarchy.h): level counts as configured,
// pinned vertices kept on every level, stacked ids equal to SceneSystem's, the prolongation operators
// recovering the rest shapes to round-off and commuting with rigid motions, the scene-wide collapses
// undoing exactly to the next finer level in vertex-disjoint batches, determinism and the hash, and
// bad input. Meshes stay below ~700 vertices per object so the file runs in a few seconds.
#include "hierarchy/scene_hierarchy.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cstdio>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "progressive/scene_system.h"
#include "util/parallel.h"
#include "scene/scene_test_helpers.h"

namespace pd {
namespace {

using namespace pd::test;  // json, parse, error_of, kFile (scene/scene_test_helpers.h)

// A 1089-vertex sheet pinned at two corners above a 642-vertex sphere obstacle; 4 levels, ratio 4
// (the defaults).
json sheet_and_sphere() {
  return json::parse(R"({
    "format_version": 1, "time_step": 0.01, "frames": 10,
    "contact": {"dhat": 1e-3},
    "objects": [{
      "name": "sheet",
      "mesh": {"type": "rectangle", "size": [1.0, 1.0], "cells": [32, 32]},
      "transform": {"rotation": {"axis": [1, 0, 0], "angle_deg": -90}, "translation": [0, 0.6, 0]},
      "material": {"preset": "cotton"},
      "pins": [{"region": {"min": [-0.6, 0.5, -0.6], "max": [-0.47, 0.7, -0.47]}},
               {"region": {"min": [0.47, 0.5, -0.6], "max": [0.6, 0.7, -0.47]}}]
    }, {
      "name": "ball", "obstacle": true,
      "mesh": {"type": "icosphere", "radius": 0.3, "subdivisions": 3}
    }]
  })");
}

// A pinned 441-vertex sheet with repeated explicit counts over an 8-vertex box kept whole on every
// level.
json sheet_and_box() {
  return json::parse(R"({
    "format_version": 1, "time_step": 0.01, "frames": 10,
    "contact": {"dhat": 1e-3},
    "hierarchy": {"levels": 4},
    "objects": [{
      "name": "sheet",
      "mesh": {"type": "rectangle", "size": [1.0, 1.0], "cells": [20, 20]},
      "material": {"preset": "cotton"},
      "pins": [{"indices": [0, 20, 220]}],
      "hierarchy": {"vertex_counts": [441, 110, 110]}
    }, {
      "name": "crate", "obstacle": true,
      "mesh": {"type": "box", "size": [0.3, 0.2, 0.3], "cells": 1},
      "transform": {"translation": [0.2, 0.3, 0.4]},
      "hierarchy": {"vertex_counts": [8, 8, 8]}
    }]
  })");
}

double bbox_diagonal(const Positions& V) { return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm(); }

double max_row_distance(const Positions& a, const Positions& b) { return (a - b).rowwise().norm().maxCoeff(); }

std::set<Tri> tri_set(const Faces& F) {
  std::set<Tri> s;
  for (Eigen::Index f = 0; f < F.rows(); ++f) s.insert(canonical_tri(F(f, 0), F(f, 1), F(f, 2)));
  return s;
}

// Every row of U: at most 3 non-zeros (one coarse triangle), summing to 1.
void expect_convex_rows(const Eigen::SparseMatrix<double, Eigen::RowMajor>& U) {
  for (Eigen::Index r = 0; r < U.rows(); ++r) {
    int nnz = 0;
    double sum = 0.0;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(U, r); it; ++it) ++nnz, sum += it.value();
    EXPECT_LE(nnz, 3);
    EXPECT_NEAR(sum, 1.0, 1e-14);
  }
}

// The properties every built hierarchy must have, checked level by level; `worst` gets the largest
// |P^l(rest_l) - rest_L| over the levels (m).
void check_hierarchy(const Scene& scene, const SceneHierarchy& h, const std::vector<int>& expected_counts_per_level,
                     double& worst) {
  const int L = h.finest();
  EXPECT_EQ(h.num_levels(), scene.hierarchy.levels);
  EXPECT_EQ(static_cast<int>(h.objects.size()), static_cast<int>(scene.objects.size()));
  const SceneLevel& finest = h.levels[static_cast<std::size_t>(L)];
  const double diag = bbox_diagonal(finest.rest.V);

  // The finest level is SceneSystem's mesh with SceneSystem's ids.
  const SceneSystem sys = build_scene_system(scene);
  EXPECT_EQ(finest.vertex_offsets, sys.object_offsets);
  EXPECT_EQ(finest.face_offsets, sys.object_face_offsets);
  EXPECT_TRUE(finest.rest.V == sys.rest.V);
  EXPECT_TRUE(finest.rest.F == sys.rest.F);

  worst = 0.0;
  for (int l = 0; l <= L; ++l) {
    SCOPED_TRACE("level " + std::to_string(l));
    const SceneLevel& s = h.levels[static_cast<std::size_t>(l)];
    EXPECT_EQ(s.rest.num_vertices(), expected_counts_per_level[static_cast<std::size_t>(l)]);
    // Offsets: each object's block is its own level mesh, its faces use only its own vertices, and
    // its vertices map into its own finest block.
    ASSERT_EQ(s.vertex_offsets.size(), scene.objects.size() + 1);
    ASSERT_EQ(static_cast<int>(s.to_finest.size()), s.rest.num_vertices());
    for (std::size_t k = 0; k < scene.objects.size(); ++k) {
      const Level& lv = h.objects[k].levels[static_cast<std::size_t>(l)];
      EXPECT_EQ(s.vertex_offsets[k + 1] - s.vertex_offsets[k], lv.mesh.num_vertices());
      EXPECT_EQ(s.face_offsets[k + 1] - s.face_offsets[k], lv.mesh.num_faces());
      for (int f = s.face_offsets[k]; f < s.face_offsets[k + 1]; ++f)
        for (int j = 0; j < 3; ++j) {
          EXPECT_GE(s.rest.F(f, j), s.vertex_offsets[k]);
          EXPECT_LT(s.rest.F(f, j), s.vertex_offsets[k + 1]);
        }
      for (int v = s.vertex_offsets[k]; v < s.vertex_offsets[k + 1]; ++v) {
        const int g = s.to_finest[static_cast<std::size_t>(v)];
        EXPECT_GE(g, finest.vertex_offsets[k]);
        EXPECT_LT(g, finest.vertex_offsets[k + 1]);
      }
    }
    // Pinned vertices of simulated objects: on this level, at their finest rest positions exactly.
    const std::set<int> level_vertices(s.to_finest.begin(), s.to_finest.end());
    for (std::size_t k = 0; k < scene.objects.size(); ++k) {
      if (scene.objects[k].obstacle) continue;
      for (const PinGroup& g : scene.objects[k].pins)
        for (int v : g.vertices) {
          const int global = finest.vertex_offsets[k] + v;
          const auto it = std::find(s.to_finest.begin(), s.to_finest.end(), global);
          ASSERT_NE(it, s.to_finest.end()) << "pinned vertex " << global << " missing";
          const auto at = static_cast<Eigen::Index>(it - s.to_finest.begin());
          EXPECT_TRUE(s.rest.V.row(at) == finest.rest.V.row(global));
        }
    }
    // Operators: P^l(rest_l) = rest_L and P_{l+1}^l(rest_l) = rest_{l+1} to round-off.
    ASSERT_TRUE(s.to_finest_prolongation.has_value());
    const double err = max_row_distance(s.to_finest_prolongation->apply(s.rest.V), finest.rest.V);
    EXPECT_LT(err, 1e-12 * diag);
    worst = std::max(worst, err);
    if (l < L) {
      ASSERT_TRUE(s.to_next.has_value());
      EXPECT_LT(max_row_distance(s.to_next->apply(s.rest.V), h.levels[static_cast<std::size_t>(l) + 1].rest.V), 1e-12 * diag);
    } else {
      EXPECT_FALSE(s.to_next.has_value());
    }
    // U of P^l and of P_{l+1}^l: convex rows with at most 3 non-zeros.
    ASSERT_EQ(s.to_finest_prolongation->U().rows(), finest.rest.num_vertices());
    ASSERT_EQ(s.to_finest_prolongation->U().cols(), s.rest.num_vertices());
    expect_convex_rows(s.to_finest_prolongation->U());
    if (s.to_next) expect_convex_rows(s.to_next->U());
    // The full P commutes with a rigid motion: P(Q X + c) = Q P(X) + c.
    std::mt19937 rng(1234u + static_cast<unsigned>(l));
    std::normal_distribution<double> normal;
    const Eigen::Quaterniond q = Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)).normalized();
    const Mat3 Q = q.toRotationMatrix();
    const Eigen::RowVector3d c(normal(rng), normal(rng), normal(rng));
    const Positions moved = (s.rest.V * Q.transpose()).rowwise() + c;
    const Positions expected = (s.to_finest_prolongation->apply(s.rest.V) * Q.transpose()).rowwise() + c;
    EXPECT_LT(max_row_distance(s.to_finest_prolongation->apply(moved), expected), 1e-12 * (diag + c.norm()));
  }
}

// Replays scene_collapses(h, l) backwards from level l's stacked mesh: must give level l+1's faces
// and positions exactly; the batches must cover every collapse once with vertex-disjoint patches.
void check_scene_collapses(const SceneHierarchy& h, int l) {
  SCOPED_TRACE("collapses of level " + std::to_string(l));
  const SceneLevel& coarse = h.levels[static_cast<std::size_t>(l)];
  const SceneLevel& fine = h.levels[static_cast<std::size_t>(l) + 1];
  const SceneCollapses sc = scene_collapses(h, l);
  ASSERT_EQ(static_cast<int>(sc.coarse_to_fine.size()), coarse.rest.num_vertices());
  EXPECT_EQ(static_cast<int>(sc.collapses.size()), fine.rest.num_vertices() - coarse.rest.num_vertices());

  std::set<Tri> faces;
  for (Eigen::Index f = 0; f < coarse.rest.F.rows(); ++f) {
    const auto up = [&](int j) { return sc.coarse_to_fine[static_cast<std::size_t>(coarse.rest.F(f, j))]; };
    faces.insert(canonical_tri(up(0), up(1), up(2)));
  }
  Positions V = Positions::Constant(fine.rest.num_vertices(), 3, std::nan(""));
  for (std::size_t i = 0; i < sc.coarse_to_fine.size(); ++i)
    V.row(sc.coarse_to_fine[i]) = coarse.rest.V.row(static_cast<Eigen::Index>(i));
  for (auto it = sc.collapses.rbegin(); it != sc.collapses.rend(); ++it) {
    ASSERT_TRUE(V.row(it->kept).transpose() == it->kept_position_after);
    for (const Tri& t : it->faces_after) ASSERT_EQ(faces.erase(t), 1u) << "face not present before the split";
    for (const Tri& t : it->faces_before) faces.insert(t);
    V.row(it->removed) = it->removed_position.transpose();
    V.row(it->kept) = it->kept_position_before.transpose();
  }
  EXPECT_EQ(faces, tri_set(fine.rest.F));
  EXPECT_TRUE(V == fine.rest.V);  // bit for bit (NaN rows would fail too)

  std::vector<int> seen(sc.collapses.size(), 0);
  for (const auto& batch : sc.batches) {
    std::set<int> used;
    for (int i : batch) {
      ASSERT_GE(i, 0);
      ASSERT_LT(i, static_cast<int>(sc.collapses.size()));
      ++seen[static_cast<std::size_t>(i)];
      std::set<int> patch;
      for (const Tri& t : sc.collapses[static_cast<std::size_t>(i)].faces_before) patch.insert(t.begin(), t.end());
      for (int v : patch) EXPECT_TRUE(used.insert(v).second) << "batches share vertex " << v;
    }
  }
  for (int count : seen) EXPECT_EQ(count, 1);
}

TEST(SceneHierarchy, SheetAndSphereLevelsPinsOffsetsAndOperatorsAreConsistent) {
  const Scene scene = parse(sheet_and_sphere());
  std::vector<HierarchyLevelReport> report;
  const SceneHierarchy h = build_scene_hierarchy(scene, &report);
  ASSERT_EQ(h.num_levels(), 4);
  // Default ratio 4: round(1089 / 4^k) and round(642 / 4^k).
  const std::vector<int> sheet = {17, 68, 272, 1089}, ball = {10, 40, 160, 642};
  std::vector<int> expected;
  for (int l = 0; l < 4; ++l) {
    // A level may end up to floor(2% of its target) above it (DecimationSettings::count_tolerance).
    int total = 0;
    for (std::size_t k = 0; k < 2; ++k) {
      const int target = (k == 0 ? sheet : ball)[static_cast<std::size_t>(l)];
      const int got = h.objects[k].levels[static_cast<std::size_t>(l)].mesh.num_vertices();
      EXPECT_GE(got, target) << "object " << k << " level " << l;
      EXPECT_LE(got, target + target / 50) << "object " << k << " level " << l;
      total += got;
    }
    expected.push_back(total);
  }
  double worst = 0.0;
  check_hierarchy(scene, h, expected, worst);
  for (int l = 0; l < 3; ++l) check_scene_collapses(h, l);
  ASSERT_EQ(report.size(), 4u);
  for (int l = 0; l < 4; ++l) {
    const HierarchyLevelReport& r = report[static_cast<std::size_t>(l)];
    EXPECT_EQ(r.vertices, expected[static_cast<std::size_t>(l)]);
    EXPECT_EQ(r.triangles, h.levels[static_cast<std::size_t>(l)].rest.num_faces());
    EXPECT_GE(r.build_seconds, 0.0);
    EXPECT_LE(r.rest_prolongation_error, worst);
    std::printf("  [sheet+sphere] level %d: %d vertices, %d triangles, %.4f s, rest error %.3g m\n", l, r.vertices,
                r.triangles, r.build_seconds, r.rest_prolongation_error);
  }
  std::printf("  [sheet+sphere] worst rest error %.3g m (bbox diagonal %.3g m), hash %s\n", worst,
              bbox_diagonal(h.levels.back().rest.V), h.hash.c_str());
}

TEST(SceneHierarchy, RepeatedVertexCountsKeepTheMeshAndGiveIdentityOperators) {
  const Scene scene = parse(sheet_and_box());
  const SceneHierarchy h = build_scene_hierarchy(scene);
  ASSERT_EQ(h.num_levels(), 4);
  const std::vector<int> sheet = {110, 110, 441, 441};
  std::vector<int> expected;
  for (int l = 0; l < 4; ++l) {
    EXPECT_EQ(h.objects[0].levels[static_cast<std::size_t>(l)].mesh.num_vertices(), sheet[static_cast<std::size_t>(l)]);
    EXPECT_EQ(h.objects[1].levels[static_cast<std::size_t>(l)].mesh.num_vertices(), 8);
    expected.push_back(sheet[static_cast<std::size_t>(l)] + 8);
  }
  double worst = 0.0;
  check_hierarchy(scene, h, expected, worst);
  for (int l = 0; l < 3; ++l) check_scene_collapses(h, l);
  std::printf("  [sheet+box] worst rest error %.3g m\n", worst);

  // The box never changes: no collapses, identity maps, and its rows of every U are unit rows at
  // the vertex itself.
  for (int l = 0; l < 3; ++l) {
    const Level& box = h.objects[1].levels[static_cast<std::size_t>(l)];
    EXPECT_TRUE(box.collapses.empty());
    EXPECT_TRUE(h.objects[1].batches[static_cast<std::size_t>(l)].empty());
    for (int i = 0; i < 8; ++i) {
      EXPECT_EQ(box.coarse_to_fine[static_cast<std::size_t>(i)], i);
      EXPECT_EQ(box.fine_to_coarse[static_cast<std::size_t>(i)], i);
    }
    const SceneLevel& s = h.levels[static_cast<std::size_t>(l)];
    const Eigen::SparseMatrix<double, Eigen::RowMajor> U = s.to_next->U();
    for (int i = 0; i < 8; ++i) {
      const int row = h.levels[static_cast<std::size_t>(l) + 1].vertex_offsets[1] + i;
      EXPECT_EQ(U.row(row).nonZeros(), 1);
      EXPECT_EQ(U.coeff(row, s.vertex_offsets[1] + i), 1.0);
    }
  }
  // The sheet's repeated levels (3 -> 2 and 1 -> 0) have no collapses; 2 -> 1 has them all.
  EXPECT_TRUE(h.objects[0].levels[2].collapses.empty());
  EXPECT_TRUE(h.objects[0].levels[0].collapses.empty());
  EXPECT_EQ(static_cast<int>(h.objects[0].levels[1].collapses.size()), 441 - 110);
  EXPECT_TRUE(scene_collapses(h, 0).collapses.empty());
  EXPECT_TRUE(scene_collapses(h, 0).batches.empty());
}

TEST(SceneHierarchy, SceneCollapsesRejectsLevelsOutOfRange) {
  json s = sheet_and_box();
  s["hierarchy"]["levels"] = 2;
  s["objects"][0]["hierarchy"]["vertex_counts"] = {110};
  s["objects"][1]["hierarchy"]["vertex_counts"] = {8};
  const SceneHierarchy h = build_scene_hierarchy(parse(s));
  EXPECT_NO_THROW(scene_collapses(h, 0));
  EXPECT_THROW(scene_collapses(h, 1), std::invalid_argument);
  EXPECT_THROW(scene_collapses(h, -1), std::invalid_argument);
}

TEST(SceneHierarchy, OneLevelMeansOnlyTheFinestMeshWithIdentityOperator) {
  json s = sheet_and_box();
  s["hierarchy"]["levels"] = 1;
  s["objects"][0].erase("hierarchy");
  s["objects"][1].erase("hierarchy");
  const Scene scene = parse(s);
  const SceneHierarchy h = build_scene_hierarchy(scene);
  ASSERT_EQ(h.num_levels(), 1);
  double worst = 0.0;
  check_hierarchy(scene, h, {441 + 8}, worst);
  EXPECT_EQ(worst, 0.0);  // every vertex located at itself
}

void expect_same_operator(const ShellProlongation& a, const ShellProlongation& b) {
  const Eigen::SparseMatrix<double>& A = a.U();
  const Eigen::SparseMatrix<double>& B = b.U();
  ASSERT_EQ(A.rows(), B.rows());
  ASSERT_EQ(A.cols(), B.cols());
  ASSERT_EQ(A.nonZeros(), B.nonZeros());
  for (Eigen::Index c = 0; c < A.outerSize(); ++c) {
    Eigen::SparseMatrix<double>::InnerIterator ia(A, c), ib(B, c);
    for (; ia && ib; ++ia, ++ib) {
      EXPECT_EQ(ia.row(), ib.row());
      EXPECT_EQ(ia.value(), ib.value());  // bit for bit
    }
    EXPECT_FALSE(ia || ib);
  }
  EXPECT_EQ(a.normal_offsets(), b.normal_offsets());
  ASSERT_EQ(a.tangent_offsets().size(), b.tangent_offsets().size());
  for (std::size_t i = 0; i < a.tangent_offsets().size(); ++i) EXPECT_TRUE(a.tangent_offsets()[i] == b.tangent_offsets()[i]);
}

// The second build runs its parallel parts (the two objects' decimations, the location and batch
// tasks, the operators) on two threads, the first on one: nothing may depend on the thread count.
TEST(SceneHierarchy, BuildsOnOneAndTwoThreadsAreBitIdenticalAndTheHashMatches) {
  const Scene scene = parse(sheet_and_sphere());
  const int saved = element_threads();
  set_element_threads(1);
  const SceneHierarchy a = build_scene_hierarchy(scene);
  set_element_threads(2);
  const SceneHierarchy b = build_scene_hierarchy(scene);
  set_element_threads(saved);
  EXPECT_EQ(a.hash.size(), 16u);
  EXPECT_EQ(a.hash.find_first_not_of("0123456789abcdef"), std::string::npos);
  EXPECT_EQ(a.hash, b.hash);
  EXPECT_EQ(hierarchy_hash(scene), a.hash);
  ASSERT_EQ(a.num_levels(), b.num_levels());
  for (int l = 0; l < a.num_levels(); ++l) {
    SCOPED_TRACE("level " + std::to_string(l));
    const SceneLevel& x = a.levels[static_cast<std::size_t>(l)];
    const SceneLevel& y = b.levels[static_cast<std::size_t>(l)];
    EXPECT_TRUE(x.rest.V == y.rest.V);
    EXPECT_TRUE(x.rest.F == y.rest.F);
    EXPECT_EQ(x.vertex_offsets, y.vertex_offsets);
    EXPECT_EQ(x.face_offsets, y.face_offsets);
    EXPECT_EQ(x.to_finest, y.to_finest);
    expect_same_operator(*x.to_finest_prolongation, *y.to_finest_prolongation);
    if (x.to_next) expect_same_operator(*x.to_next, *y.to_next);
    for (std::size_t k = 0; k < a.objects.size(); ++k)
      EXPECT_EQ(a.objects[k].batches[static_cast<std::size_t>(l)], b.objects[k].batches[static_cast<std::size_t>(l)]);
  }
}

TEST(SceneHierarchy, HashChangesWithRatioCountsPinsAndRestShape) {
  const Scene base = parse(sheet_and_box());
  const std::string h0 = hierarchy_hash(base);
  EXPECT_EQ(hierarchy_hash(base), h0);

  Scene ratio = base;
  ratio.hierarchy.ratio = 3.0;
  EXPECT_NE(hierarchy_hash(ratio), h0);

  Scene counts = base;
  counts.objects[0].hierarchy.vertex_counts[2] = 109;
  EXPECT_NE(hierarchy_hash(counts), h0);

  Scene pin = base;
  pin.objects[0].pins[0].vertices.push_back(440);
  EXPECT_NE(hierarchy_hash(pin), h0);

  Scene moved = base;
  moved.objects[0].rest.V(5, 1) += 1e-9;
  EXPECT_NE(hierarchy_hash(moved), h0);

  Scene boundary = base;
  boundary.objects[0].hierarchy.keep_boundary = true;
  EXPECT_NE(hierarchy_hash(boundary), h0);

  // The initial positions and the object's name do not enter the build.
  Scene posed = base;
  posed.objects[0].initial(3, 0) += 0.5;
  posed.objects[0].name = "renamed";
  EXPECT_EQ(hierarchy_hash(posed), h0);
}

// The InputError of building `scene`, checked to name the file, the object and each of `parts`.
void expect_build_error(const Scene& scene, int k, std::initializer_list<std::string> parts) {
  const std::string message = error_of([&] { build_scene_hierarchy(scene); });
  EXPECT_EQ(message.rfind(kFile + ": objects[" + std::to_string(k) + "] (" + scene.objects[static_cast<std::size_t>(k)].name + "): ", 0), 0u)
      << message;
  for (const std::string& part : parts) EXPECT_NE(message.find(part), std::string::npos) << "'" << part << "' not in: " << message;
}

TEST(SceneHierarchy, TooSmallObjectForTheDefaultRatioNamesObjectAndLevel) {
  json s = sheet_and_sphere();
  s["objects"][0]["mesh"]["cells"] = {3, 3};  // 16 vertices: 4, then 1 at level 1
  s["objects"][0]["pins"] = json::array();
  expect_build_error(parse(s), 0, {"level 1", "too few"});
}

TEST(SceneHierarchy, RepeatedCountLevelsAreNamedInSceneLevelsInErrors) {
  // Counts 110, 3, 3 for a pinned sheet: 3 vertices cannot be reached (3 pins and 4 corners stay).
  // build_levels sees two coarser levels and fails at its "level 0 (coarsest)"; the message must name
  // scene level 1 (the first level with 3 vertices; level 0 is its copy).
  json s = sheet_and_box();
  s["objects"][0]["hierarchy"]["vertex_counts"] = {110, 3, 3};
  const Scene scene = parse(s);
  expect_build_error(scene, 0, {"level 1: target of 3", "cannot be reached"});
  EXPECT_EQ(error_of([&] { build_scene_hierarchy(scene); }).find("coarsest"), std::string::npos);
}

TEST(SceneHierarchy, NonManifoldObjectNamesObjectAndFinestLevel) {
  Scene scene = parse(sheet_and_box());
  // Two 4-vertex fans touching at one vertex: manifold edges, non-manifold vertex 0.
  TriMesh bowtie;
  bowtie.V.resize(7, 3);
  bowtie.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, -1, 0, 0, -1, -1, 0, 0, -1, 0;
  bowtie.F.resize(4, 3);
  bowtie.F << 0, 1, 2, 0, 2, 3, 0, 4, 5, 0, 5, 6;
  scene.objects[1].rest = bowtie;
  scene.objects[1].initial = bowtie.V;
  scene.objects[1].hierarchy.vertex_counts = {7, 7, 6};
  expect_build_error(scene, 1, {"level 3 (finest)", "non-manifold"});
}

TEST(SceneHierarchy, BadVertexCountsInCodeBuiltScenesNameObjectAndKey) {
  const Scene base = parse(sheet_and_box());
  Scene wrong_length = base;
  wrong_length.objects[1].hierarchy.vertex_counts = {8, 8};
  expect_build_error(wrong_length, 1, {"hierarchy.vertex_counts", "need 3"});
  Scene increasing = base;
  increasing.objects[0].hierarchy.vertex_counts = {200, 300, 100};
  expect_build_error(increasing, 0, {"hierarchy.vertex_counts", "level 1"});
  Scene above = base;
  above.objects[0].hierarchy.vertex_counts = {500, 300, 100};
  expect_build_error(above, 0, {"hierarchy.vertex_counts", "level 2"});
  Scene too_small = base;
  too_small.objects[1].hierarchy.vertex_counts = {8, 8, 2};
  expect_build_error(too_small, 1, {"hierarchy.vertex_counts", "level 0"});
}

}  // namespace
}  // namespace pd
