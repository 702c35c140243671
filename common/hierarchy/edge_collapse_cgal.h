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

// Runs edge collapse on `mesh` (already validated: manifold, consistently oriented, no degenerate
// faces, every vertex used) until the vertex count reaches targets.back(), taking a snapshot each
// time it reaches one of `targets` (strictly decreasing, all below the vertex count). Stops early
// when no valid collapse is left. `locked[i]` != 0 marks locked vertices (boundary vertices are
// handled per settings.keep_boundary). Throws std::invalid_argument if the mesh cannot be built as a
// halfedge mesh.
CollapseRun run_edge_collapse(const TriMesh& mesh, const std::vector<char>& locked,
                              const std::vector<int>& targets, const DecimationSettings& settings);

}  // namespace pd::detail
