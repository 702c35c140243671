// Vertex-split batches: every collapse in exactly one batch, vertex-disjoint patches within a batch,
// and undoing the batches in order (each batch in any order) gives back the finer level's faces.
#include "hierarchy/split_batches.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <set>

#include "geometry/shapes.h"

namespace pd {
namespace {

std::set<int> patch(const Collapse& c) {
  std::set<int> v;
  for (const Tri& t : c.faces_before) v.insert(t.begin(), t.end());
  return v;
}

// Undoes `coarse`'s collapses batch by batch, each batch in increasing collapse index (the opposite
// of a sequential undo), and compares the faces with `finer`'s.
void expect_batches_reproduce_finer(const Level& coarse, const Level& finer) {
  const auto batches = split_batches(coarse.collapses);
  std::vector<int> seen(coarse.collapses.size(), 0);
  for (const auto& batch : batches) {
    std::set<int> used;
    for (int k : batch) {
      ++seen[static_cast<std::size_t>(k)];
      for (int v : patch(coarse.collapses[static_cast<std::size_t>(k)]))
        EXPECT_TRUE(used.insert(v).second) << "two splits of one batch share vertex " << v;
    }
  }
  for (size_t k = 0; k < seen.size(); ++k) EXPECT_EQ(seen[k], 1) << "collapse " << k;

  std::set<Tri> faces;
  for (int f = 0; f < coarse.mesh.num_faces(); ++f) {
    auto fine = [&](int j) { return coarse.coarse_to_fine[static_cast<std::size_t>(coarse.mesh.F(f, j))]; };
    faces.insert(canonical_tri(fine(0), fine(1), fine(2)));
  }
  for (const auto& batch : batches) {
    for (auto it = batch.rbegin(); it != batch.rend(); ++it) {
      const Collapse& c = coarse.collapses[static_cast<std::size_t>(*it)];
      for (const Tri& t : c.faces_after) ASSERT_EQ(faces.erase(t), 1u) << "split " << *it << " ran too early";
      for (const Tri& t : c.faces_before) ASSERT_TRUE(faces.insert(t).second);
    }
  }
  EXPECT_EQ(std::vector<Tri>(faces.begin(), faces.end()), sorted_tris(finer.mesh.F));
  std::printf("%zu collapses in %zu batches\n", coarse.collapses.size(), batches.size());
}

TEST(SplitBatches, BatchesOfASphereHierarchyAreDisjointAndReproduceEachFinerLevel) {
  const auto levels = build_levels(make_icosphere(1.0, 4));  // 2562 vertices, ratio 4
  for (size_t l = 0; l + 1 < levels.size(); ++l) {
    SCOPED_TRACE("level " + std::to_string(l));
    expect_batches_reproduce_finer(levels[l], levels[l + 1]);
  }
}

TEST(SplitBatches, BatchesOfASheetWithBoundaryReproduceEachFinerLevel) {
  LevelSettings s;
  s.decimation.keep_boundary = false;
  const auto levels = build_levels(make_rectangle(1.0, 1.0, 30, 30), s);
  for (size_t l = 0; l + 1 < levels.size(); ++l) {
    SCOPED_TRACE("level " + std::to_string(l));
    expect_batches_reproduce_finer(levels[l], levels[l + 1]);
  }
}

TEST(SplitBatches, OverlappingCollapsesGoInSuccessiveBatchesLastFirst) {
  // Three collapses on a strip of vertices: 0 and 2 overlap through vertex 5, 1 is apart.
  std::vector<Collapse> c(3);
  c[0].faces_before = {Tri{1, 2, 5}};
  c[1].faces_before = {Tri{10, 11, 12}};
  c[2].faces_before = {Tri{5, 6, 7}};
  const auto batches = split_batches(c);
  ASSERT_EQ(batches.size(), 2u);
  EXPECT_EQ(batches[0], (std::vector<int>{2, 1}));  // last collapse first, the independent one too
  EXPECT_EQ(batches[1], (std::vector<int>{0}));
  EXPECT_TRUE(split_batches({}).empty());
}

}  // namespace
}  // namespace pd
