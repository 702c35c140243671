#pragma once
// Nested vertex sets for the coarser levels of a generated rectangle or box (scene key
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

// Grading next to fixed sides. A side whose vertices are all fixed (a sheet pinned along its edge)
// keeps every vertex on every level, and from depth 2 on the coarse sheet would join it to the first
// kept line (2^k cells apart along it) by fans of 2^k and more thin triangles. The coarse mesh's own
// Hessian, which the preview uses as a stand-in for the finest one for a step's first iterates
// (progressive/prolonged_term.h), is then a poor one: cube-trampoline's preview took 550 Newton
// iterations in 60 frames against 318 with grading (docs/performance.md). So from depth 2 on, the
// first kept line off a fixed side also keeps the points depth k-1 keeps, halving the fans. The
// stand-in stays poorer than the lagged Galerkin Hessian even so (1 111 against 636 iterations over
// the scene's 200 frames), which is why cube-trampoline also sets solver.preview_hessian "lagged".

// Finest vertex ids kept on each coarser level, level L-1 (k = 1) first, for `coarser_levels` levels;
// ids increasing. `fixed`: per vertex, whether it is fixed anyway (pins, the boundary when it is
// kept), or empty for none; it only decides which sides are fixed, and the caller adds the fixed
// vertices to the sets. Requires coarser_levels >= 0; throws std::invalid_argument otherwise or for
// a `fixed` of another size than the lattice's.
std::vector<std::vector<int>> grid_level_vertices(const GridLattice& lattice, int coarser_levels,
                                                  const std::vector<char>& fixed = {});

}  // namespace pd
