#pragma once
// Independent intersection check of a whole scene's triangles, for tests that verify no stored frame
// intersects. Built on CGAL only (exact predicates), never on the project's contact/distance code, so
// a bug there cannot hide itself.
//
// What counts as an intersection: two faces whose closed triangles share a point, except when the
// only common points are a vertex or an edge the two faces share by index (adjacent faces). Adjacent
// faces still count when they genuinely overlap beyond the shared sub-simplex:
//   - sharing an edge: only when the two triangles are exactly coplanar and on the same side of the
//     edge (folded flat onto each other); coplanar on opposite sides (a flat sheet) or folded to any
//     nonzero angle, however small, is not an intersection (they meet only along the edge);
//   - sharing one vertex: when the edge opposite the vertex in either face meets the other triangle.
// Faces that merely touch (distinct vertex indices at the same point, a vertex on another face) do
// intersect: the simulator must keep a positive gap. Predicates are exact on the double coordinates,
// so any positive gap (1e-6 m in the tests) is seen as one.
//
// Faces sharing all three vertices (duplicates) intersect. Degenerate faces (collinear or repeated
// vertices, zero area) cannot be tested as triangles by CGAL; they are listed in `degenerate_faces`
// and skipped by the pair test.
//
// Method: the whole scene is one mesh. If the faces form a valid polygon mesh (edge-manifold,
// vertex-manifold, consistently oriented per component: CGAL's is_polygon_soup_a_polygon_mesh), it is
// built as a CGAL::Surface_mesh and checked with CGAL::Polygon_mesh_processing::self_intersections,
// whose adjacency semantics are the ones above (read from CGAL 5.5's implementation; CGAL documents
// "the intersection is not an edge nor a vertex incident to both faces"). Otherwise (non-manifold
// soups, flipped faces, repeated vertices) a triangle-soup path is used: CGAL::box_self_intersection_d
// on face boxes, then the same rules with CGAL's exact predicates, with adjacency read from the
// vertex indices. Both paths use Exact_predicates_inexact_constructions_kernel and give the same
// answer on valid meshes (tested).
#include <utility>
#include <vector>

#include "geometry/mesh.h"

namespace pd::test {

struct IntersectionReport {
  int intersecting_pairs = 0;                    // == face_pairs.size()
  std::vector<std::pair<int, int>> face_pairs;   // (f, g) rows of F, f < g, sorted, unique
  std::vector<int> degenerate_faces;             // zero-area faces (not tested), sorted
  bool triangle_soup = false;                    // true if the soup path was used (not a valid mesh)
};

// All intersecting face pairs of the scene V (n, 3) metres, F (m, 3) 0-based. Works for any number
// of objects (connected components). Throws std::invalid_argument if F indexes a missing vertex or a
// coordinate is not finite.
IntersectionReport find_intersections(const Positions& V, const Faces& F);

// The triangle-soup path alone, whatever F is (for tests that compare it with the mesh path).
IntersectionReport find_intersections_in_soup(const Positions& V, const Faces& F);

// Intersecting face pairs of a scene frame that count against the contact promise: every pair but
// those inside one obstacle (an animated body's arm may pass through its torso, as captured bodies'
// do), plus the degenerate faces (which cannot be certified). face_offsets: object k owns faces
// [face_offsets[k], face_offsets[k + 1]) of F; obstacle: one flag per object.
int intersections_outside_obstacles(const Positions& V, const Faces& F, const std::vector<int>& face_offsets,
                                    const std::vector<char>& obstacle);

// True when the check is complete and found nothing: no intersecting pair and no degenerate face
// (a degenerate face could pass through another face unseen, so it cannot be certified free).
bool intersection_free(const Positions& V, const Faces& F);

}  // namespace pd::test
