#pragma once
// Internal to hierarchy/decimation.cpp: the one translation unit that runs CGAL's edge collapse.
// It is compiled in its own library (pd_hierarchy_cgal, see common/CMakeLists.txt) so that CGAL's
// -frounding-math stays off the rest of pd_common; it uses only header-only parts of pd_common, so
// pd_common can link it without a cycle. Use decimation.h, not this.
#include <vector>

#include "hierarchy/decimation.h"

namespace pd::detail {

// A boundary vertex lies on a straight stretch of boundary when the turn between its two boundary
// edges is below this angle (radians): |e0 x e1| <= tol |e0| |e1| and e0 . e1 > 0.
inline constexpr double kStraightBoundaryTolerance = 1e-3;

// The mesh at one moment of the run: positions indexed by the start mesh's ids (rows of removed
// vertices are stale), alive flags, and the faces (Tri, sorted).
struct CollapseSnapshot {
  int num_collapses = 0;        // records performed before this state
  int num_vertices = 0;
  Positions V;
  std::vector<char> alive;
  std::vector<Tri> faces;
};

struct CollapseRun {
  std::vector<Collapse> collapses;        // start-mesh ids, in order
  std::vector<CollapseSnapshot> reached;  // one per target reached, in target order
  CollapseSnapshot final_state;           // the state when the run ended
};

// Which collapses a run makes, in which order.
enum class CollapseRule {
  // By quadric cost (Garland-Heckbert probabilistic plane quadrics), placement at the quadric's
  // minimiser unless an end is fixed; the hierarchy's default.
  kQuadric,
  // Only onto a locked vertex: a free vertex merges into a locked neighbour, which stays where it is
  // (a free boundary vertex only along a straight boundary edge); two free vertices never merge.
  // Order: the shortest edge first, then the kept neighbour nearest the centre of the mesh's
  // bounding box, then the edge nearest the x axis (OntoLockedCost in the .cpp). On a grid whose
  // kept lines are every other line (LevelSettings::kept_vertices from grid_level_vertices) this
  // first removes the vertices on kept lines, whose kept neighbours along the line are the nearest,
  // which leaves each kept line an edge chain; then the cell centres, each into the corner nearest
  // the centre, leaving the diagonal that points toward it. So a set symmetric about the centre lines
  // gives a mesh that is too. Ordering by the removed vertex's degree did the same on the finest
  // grid, but on the next one, where every vertex has degree 6, the centre vertex absorbed whole
  // cells and fanned out toward the border, and that coarse mesh's own Hessian was a poor stand-in
  // for the preview (docs/performance.md, "A symmetric coarse trampoline"). The quadric order merges
  // free vertices with each other and can leave one inside a polygon of collinear kept vertices that
  // no single collapse removes.
  kOntoLocked,
};

// Runs edge collapse on `mesh` (already validated: manifold, consistently oriented, no degenerate
// faces, every vertex used) until the vertex count reaches targets.back(), taking a snapshot each
// time it reaches one of `targets` (strictly decreasing, all below the vertex count). Stops early
// when no valid collapse is left. `locked[i]` != 0 marks locked vertices (boundary vertices are
// handled per settings.keep_boundary). Throws std::invalid_argument if the mesh cannot be built as a
// halfedge mesh.
CollapseRun run_edge_collapse(const TriMesh& mesh, const std::vector<char>& locked,
                              const std::vector<int>& targets, const DecimationSettings& settings,
                              CollapseRule rule = CollapseRule::kQuadric);

}  // namespace pd::detail
