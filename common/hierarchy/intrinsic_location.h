#pragma once
// Locations of fine vertices on a coarser level of the hierarchy by successive self-parameterization
// through the recorded edge collapses (PSQ 4.2-4.3; Liu et al. 2021, "Surface Multigrid via Intrinsic
// Prolongation"). The result feeds ShellProlongation (hierarchy/shell_prolongation.h).
//
// Method. Every fine vertex starts as a tracked point: barycentric (1, 0, 0) at itself in the
// lowest-numbered fine face that contains it. The collapses are replayed in order. For a collapse,
// every tracked point whose current face is in faces_before is moved into faces_after:
//  1. Joint flattening. The after-patch (faces_after) boundary loop is put on the unit circle, in the
//     loop's orientation (counter-clockwise), at angles proportional to 3D arc length. The
//     before-patch has the same boundary loop, except when `removed` lies on it (a straight-boundary
//     collapse, keep_boundary = false): then `removed` goes onto the chord between its two loop
//     neighbours, at the fraction given by its 3D distances to them, so both patches cover exactly
//     the same convex polygon. Interior vertices (kept and/or removed before, kept after) are placed
//     by Tutte's embedding with mean-value weights computed from the 3D one-rings (for `kept` after
//     the collapse: at kept_position_after).
//  2. Each point's 2D image in the before-flattening is located in the after-flattening: the
//     after-face where the point's smallest barycentric is largest (so points on shared edges and
//     vertices are handled without special cases), negative weights clamped to 0, renormalised.
// Why this flattening. Mean-value weights are positive for any 3D one-ring, and Floater's theorem
// (Tutte with positive weights, boundary on a convex polygon) guarantees both flattenings are
// embeddings, so the before->after map is a piecewise-linear bijection of the patch that is the
// identity on its boundary: points never leave the patch, never jump to another sheet (the patch is
// defined by connectivity, not by 3D proximity), and the composed map over all collapses is continuous
// and bijective. Boundary patches (an open fan: kept and/or removed on the mesh boundary) are handled
// by the same construction, since their boundary loop runs through kept (and removed) along the mesh
// boundary edges; mesh-boundary edges map to themselves. A conformal (LSCM) flattening would have
// lower angle distortion but needs pinning and can fold for boundary fans; distortion matters little
// here because the before and after patches share one flattening of the boundary.
// Fall-back. If a patch is not a disk with one simple boundary loop (e.g. the last collapses of a
// tiny closed mesh) or the two loops do not match, or a flattening is not an embedding (never
// observed), the points are placed at the closest point of the after-patch in 3D, and counted in
// LocationStats::fallback_collapses.
// Deterministic (ordered containers only). Cost: O(points moved + patch size) per collapse.
#include <vector>

#include "hierarchy/decimation.h"
#include "hierarchy/shell_prolongation.h"

namespace pd {

struct LocationStats {
  int collapses = 0;           // collapses replayed
  int moved_points = 0;        // point relocations done (a point counts once per collapse it meets)
  int fallback_collapses = 0;  // collapses that used the 3D closest-point fall-back
  double worst_negative = 0.0; // most negative barycentric clamped to 0 in 2D point location
};

// Location of every vertex of `fine` on `coarse`, tracked through `collapses` (fine ids, in the order
// performed, e.g. Decimation::collapses or Level::collapses of the coarser level), starting from
// fine.V. coarse_to_fine maps coarse vertex ids to fine ids (Decimation/Level::coarse_to_fine). The
// result has one entry per fine vertex: a row of coarse.F and weights in that row's vertex order,
// each >= 0, summing to 1. Throws std::invalid_argument when the records do not fit the meshes (a
// tracked face ends up not being a face of `coarse`, ids out of range).
std::vector<SurfaceLocation> locate_through_collapses(const TriMesh& fine,
                                                      const std::vector<Collapse>& collapses,
                                                      const TriMesh& coarse,
                                                      const std::vector<int>& coarse_to_fine,
                                                      LocationStats* stats = nullptr);

// Direct locations of the FINEST vertices (levels.back()) on levels[level].mesh, tracked through all
// collapses from the finest level down to `level` (for the direct operators P^l, PSQ 4.3.1). For
// level == levels.size() - 1 every vertex sits at itself. Throws std::invalid_argument for a level out
// of range or inconsistent levels.
std::vector<SurfaceLocation> locate_finest_on_level(const std::vector<Level>& levels, int level,
                                                    LocationStats* stats = nullptr);

// locate_finest_on_level for every level at once: result[l] == locate_finest_on_level(levels, l),
// bit for bit. Why: the finest vertices are tracked down the levels once (each level's collapses
// once) instead of once per level (the finest level's collapses L times).
std::vector<std::vector<SurfaceLocation>> locate_finest_on_all_levels(const std::vector<Level>& levels);

}  // namespace pd
