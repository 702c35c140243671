#pragma once
// Relaxations of a few free vertices of a large mesh (safe upsampling's: a batch's patches are a tiny
// part of the mesh), run on a submesh around them and then followed in the whole mesh.
//
// Why a submesh: the solves of patch_relaxation.h cost O(their mesh) per Newton iteration. The
// submesh holds the faces within two rings of the free vertices plus every face with a vertex within
// about 2 `scale` of a free vertex (or of its aim, for a pull): the geometry they may meet.
// Why follow the path: what the submesh leaves out (the rest of the mesh) must still be respected.
// The solve's accepted Newton iterates are replayed in the whole mesh as straight segments, each
// capped by CCD against the whole mesh and the ground (follow_path), so the result is
// intersection-free whatever the submesh missed; a segment cut short leaves the next one to start
// from there.
//
// Conventions: positions (n, 3) rows in metres, 0-based ids into them; every vertex is used by a
// face (compact meshes); `rest` = the rest (or intermediate rest) shape of the same vertices.
#include <vector>

#include "geometry/mesh.h"
#include "hierarchy/patch_relaxation.h"
#include "hierarchy/safe_advance.h"
#include "physics/contact/broad_phase.h"

namespace pd {

// Marks every vertex of a face that has a marked vertex (one ring of growth). marked: per vertex.
std::vector<char> grow_by_faces(const Faces& F, const std::vector<char>& marked);

// Moves x along `path` (whole-mesh positions, in order), one straight segment at a time, each capped
// by the barrier's CCD over every pair of `prims` (thickness = `offset` for pairs beyond it, 0 for
// pairs within it at the start; every approach keeps 10% of its gap) and by the ground.
// Why not the safe advancement (safe_advance.h): its ratio rules (keep 99.9% of a close pair's gap,
// stop after a pair turns a vertex) are made for motions nobody has checked; they stopped relaxed
// patches centimetres short of a path that the relaxation's own CCD-capped line search had
// certified on the submesh (measured on a cloth draped over a box: misses of 1.5-8.7 cm).
void follow_path(const ContactPrimitives& prims, const Positions& rest, double offset, const GroundPlane* ground,
                 const std::vector<Positions>& path, Positions& x);

// relax_gaps (PSQ 4.4.3) of the free vertices on a submesh, followed in the whole mesh.
// min_gap (m, > 0) as GapRelaxationSettings::min_gap, 8 stiffness rounds.
RelaxationReport relax_gaps_on_submesh(const ContactPrimitives& prims, const Positions& rest,
                                       const std::vector<int>& free, double offset, double min_gap, double scale,
                                       const GroundPlane* ground, Positions& x);

// relax_toward of the free vertices toward `aim` (whole-mesh rows) on a submesh, followed in the
// whole mesh: pulls vertices the safe advancement stopped (a vertex whose straight line runs into a
// collider stops for good, PSQ's Algorithm 3 too, even when its aim lies beside the collider) along
// the contact toward their aims.
RelaxationReport pull_toward_aims(const ContactPrimitives& prims, const Positions& rest, const std::vector<int>& free,
                                  const Positions& aim, double offset, double scale, const GroundPlane* ground,
                                  Positions& x);

}  // namespace pd
