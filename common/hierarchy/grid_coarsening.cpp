#include "hierarchy/grid_coarsening.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace pd {

namespace {

// Whether coordinate c of an axis with `cells` cells is kept k levels down. Both sides always are.
// With an even count the lines at a multiple of 2^k cells from the centre line are kept, so the
// centre line is on every level and no cell straddles it (such a cell would have to pick a diagonal
// across the centre, which no symmetry allows). With an odd count the centre falls mid-cell, and
// the lines at a multiple of 2^k cells from the nearer side are kept.
bool kept_coordinate(int c, int cells, int k) {
  if (c == 0 || c == cells) return true;
  const long long step = 1LL << std::min(k, 62);
  if (cells % 2 == 0) return std::abs(2 * c - cells) / 2 % step == 0;
  return std::min(c, cells - c) % step == 0;
}

}  // namespace

GridLattice lattice_of(const Positions& V, const std::array<int, 3>& cells) {
  GridLattice lattice;
  lattice.cells = cells;
  lattice.coords.resize(static_cast<std::size_t>(V.rows()));
  for (int a = 0; a < 3; ++a) {
    if (cells[static_cast<std::size_t>(a)] < 0) throw std::invalid_argument("lattice_of: negative cell count");
    if (cells[static_cast<std::size_t>(a)] == 0 || V.rows() == 0) continue;
    const double lo = V.col(a).minCoeff(), hi = V.col(a).maxCoeff();
    const double cell = (hi - lo) / cells[static_cast<std::size_t>(a)];
    if (!(cell > 0.0)) throw std::invalid_argument("lattice_of: the mesh has no extent along an axis with cells");
    for (Eigen::Index v = 0; v < V.rows(); ++v) {
      const double x = (V(v, a) - lo) / cell;
      const double c = std::round(x);
      if (std::abs(x - c) > 1e-6)
        throw std::invalid_argument("lattice_of: vertex " + std::to_string(v) + " is off the lattice along axis " +
                                    std::to_string(a));
      lattice.coords[static_cast<std::size_t>(v)][static_cast<std::size_t>(a)] = static_cast<int>(c);
    }
  }
  return lattice;
}

std::vector<std::vector<int>> grid_level_vertices(const GridLattice& lattice, int coarser_levels) {
  if (coarser_levels < 0) throw std::invalid_argument("grid_level_vertices: coarser_levels must be >= 0");
  std::vector<std::vector<int>> sets;
  for (int k = 1; k <= coarser_levels; ++k) {
    std::vector<int> ids;
    for (std::size_t v = 0; v < lattice.coords.size(); ++v) {
      bool kept = true;
      for (std::size_t a = 0; a < 3; ++a)
        if (lattice.cells[a] > 0) kept = kept && kept_coordinate(lattice.coords[v][a], lattice.cells[a], k);
      if (kept) ids.push_back(static_cast<int>(v));
    }
    sets.push_back(std::move(ids));
  }
  return sets;
}

}  // namespace pd
