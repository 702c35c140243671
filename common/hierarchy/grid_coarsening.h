#pragma once
// Nested vertex sets for the coarser levels of a generated rectangle grid (scene key
// `hierarchy.coarsening: "grid"`), symmetric about the grid's centre lines.
//
// Why: the quadric decimation picks its collapses by cost, and on a flat grid every cost is nearly
// equal, so its coarse levels come out irregular. A coarse sheet that is not symmetric pushes a
// load that lands on its centre sideways: on cube-trampoline the preview's irregular 100-vertex sheet
// tips the landing cube by 40 degrees while the finest grid keeps it level within 1.3
// (docs/progressive.md). These sets keep the coarse vertices on the grid, mirror-symmetric in x and y,
// so a symmetric load stays symmetric on every level.
//
// Rule. The mesh's vertices sit on an integer lattice with `cells[a]` cells along axis a (a
// generated `rectangle`: (i, j, 0) with cells (cells_x, cells_y, 0); a `box`: its surface points of
// [0, cells]^3). k levels below the finest, a vertex is kept when along every axis with cells its
// coordinate is kept: the two sides always; with an even cell count, the lines a multiple of 2^k
// cells from the centre line (so the centre line is on every level, and no coarse cell straddles
// it); with an odd count, the lines a multiple of 2^k cells from the nearer side. Either way each set
// is mirror-symmetric, contains the next coarser one, and keeps the corners.
#include <array>
#include <vector>

#include "geometry/mesh.h"

namespace pd {

struct GridLattice {
  std::array<int, 3> cells{0, 0, 0};         // per axis; 0 for an axis the mesh does not span
  std::vector<std::array<int, 3>> coords;    // per vertex, in 0..cells[a]
};

// Lattice coordinates of a generated mesh's vertices from their positions before any transform:
// coordinate a of vertex v is round((V(v, a) - min_a) / (max_a - min_a) * cells[a]).
// Throws std::invalid_argument when a vertex is off the lattice by more than 1e-6 of a cell.
GridLattice lattice_of(const Positions& V, const std::array<int, 3>& cells);

// Finest vertex ids kept on each coarser level, level L-1 (k = 1) first, for `coarser_levels` levels;
// ids increasing. The caller adds the vertices that are fixed anyway (pins, and the boundary when it
// is kept). Requires coarser_levels >= 0.
std::vector<std::vector<int>> grid_level_vertices(const GridLattice& lattice, int coarser_levels);

}  // namespace pd
