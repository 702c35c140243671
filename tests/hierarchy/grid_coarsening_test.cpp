#include "hierarchy/grid_coarsening.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <stdexcept>

#include "geometry/shapes.h"

namespace pd {
namespace {

GridLattice rectangle_lattice(int cx, int cy) {
  return lattice_of(make_rectangle(2.0, 1.0, cx, cy, GridDiagonals::Checkerboard).V, {cx, cy, 0});
}

TEST(LatticeOf, RectangleVertexIJHasLatticeCoordinatesIJ) {
  const GridLattice g = rectangle_lattice(5, 3);
  ASSERT_EQ(g.coords.size(), 24u);
  for (int j = 0; j <= 3; ++j)
    for (int i = 0; i <= 5; ++i) {
      const auto& c = g.coords[static_cast<std::size_t>(j * 6 + i)];
      EXPECT_EQ(c[0], i);
      EXPECT_EQ(c[1], j);
      EXPECT_EQ(c[2], 0);
    }
}

TEST(LatticeOf, AVertexOffTheLatticeThrows) {
  Positions V = make_rectangle(1.0, 1.0, 4, 4, GridDiagonals::Checkerboard).V;
  V(6, 0) += 0.01;
  EXPECT_THROW(lattice_of(V, {4, 4, 0}), std::invalid_argument);
}

TEST(GridLevelVertices, TwentyCellsKeepEveryOtherLineThenEveryFourthFromTheCentreAndTheSides) {
  const GridLattice g = rectangle_lattice(20, 20);
  const auto sets = grid_level_vertices(g, 2);
  ASSERT_EQ(sets.size(), 2u);
  EXPECT_EQ(sets[0].size(), 11u * 11u);  // lines 0, 2, ..., 20
  EXPECT_EQ(sets[1].size(), 7u * 7u);    // lines 0, 2, 6, 10, 14, 18, 20
  for (int id : sets[1])
    for (int a = 0; a < 2; ++a) {
      const int c = g.coords[static_cast<std::size_t>(id)][static_cast<std::size_t>(a)];
      EXPECT_TRUE(c == 0 || c == 20 || (c - 10) % 4 == 0) << c;
    }
}

TEST(GridLevelVertices, AnOddCountKeepsLinesCountedFromTheSides) {
  const GridLattice g = rectangle_lattice(9, 1);  // lines 0..9 along x
  const auto sets = grid_level_vertices(g, 2);
  std::vector<int> columns;
  for (int id : sets[1])
    if (g.coords[static_cast<std::size_t>(id)][1] == 0) columns.push_back(g.coords[static_cast<std::size_t>(id)][0]);
  EXPECT_EQ(columns, (std::vector<int>{0, 4, 5, 9}));
}

TEST(GridLevelVertices, SetsAreNestedIncreasingAndMirrorSymmetricForOddAndEvenCounts) {
  int checked = 0;
  for (const auto& [cx, cy] : {std::pair{20, 20}, std::pair{21, 12}, std::pair{7, 30}, std::pair{1, 1}}) {
    const auto sets = grid_level_vertices(rectangle_lattice(cx, cy), 4);
    ASSERT_EQ(sets.size(), 4u);
    for (std::size_t k = 0; k < sets.size(); ++k) {
      const std::vector<int>& s = sets[k];
      EXPECT_TRUE(std::is_sorted(s.begin(), s.end()));
      if (k > 0) {
        EXPECT_TRUE(std::includes(sets[k - 1].begin(), sets[k - 1].end(), s.begin(), s.end()));
      }
      for (int corner : {0, cx, cy * (cx + 1), cy * (cx + 1) + cx})
        EXPECT_TRUE(std::binary_search(s.begin(), s.end(), corner)) << cx << "x" << cy << " corner " << corner;
      for (int id : s) {
        const int i = id % (cx + 1), j = id / (cx + 1);
        EXPECT_TRUE(std::binary_search(s.begin(), s.end(), j * (cx + 1) + (cx - i)));  // mirrored in x
        EXPECT_TRUE(std::binary_search(s.begin(), s.end(), (cy - j) * (cx + 1) + i));  // mirrored in y
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 200);
}

TEST(GridLevelVertices, ABoxOfThreeCellsKeepsItsEightCorners) {
  const TriMesh box = make_box(Vec3(0.2, 0.2, 0.2), 3);
  const auto sets = grid_level_vertices(lattice_of(box.V, {3, 3, 3}), 2);
  ASSERT_EQ(sets.size(), 2u);
  for (const auto& s : sets) {
    ASSERT_EQ(s.size(), 8u);
    for (int v : s)
      for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(std::abs(box.V(v, a)), 0.1);
  }
}

TEST(GridLevelVertices, NoCoarserLevelGivesNoSetAndBadArgumentsThrow) {
  EXPECT_TRUE(grid_level_vertices(rectangle_lattice(4, 4), 0).empty());
  EXPECT_THROW(grid_level_vertices(rectangle_lattice(4, 4), -1), std::invalid_argument);
  EXPECT_THROW(lattice_of(make_rectangle(1.0, 1.0, 4, 4, GridDiagonals::Checkerboard).V, {4, 4, 1}),
               std::invalid_argument);  // no extent along z
}

}  // namespace
}  // namespace pd
