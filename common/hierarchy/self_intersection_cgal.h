#pragma once
// Whether a triangle mesh intersects itself: CGAL's self_intersections on the faces as one polygon
// mesh (adjacent faces count only where they cross beyond what they share), exact predicates.
//
// Why in the library: safe upsampling must return an intersection-free state, and a vertical start
// whose upsampled state is not must be refused, not solved from (the barrier cannot see a crossing
// that is already there, and every frame after it keeps it: seen on drape-sphere's level 2 at
// frame 40 of a farm job, 3 crossing face pairs in frames 41-50). Compiled in pd_hierarchy_cgal (see
// edge_collapse_cgal.h) so that CGAL's -frounding-math stays off the rest of pd_common. The tests'
// checker (tests/support/intersection_checker.h) stays the independent one.
#include "geometry/mesh.h"

namespace pd {

// The number of intersecting face pairs; -1 when the faces do not form a polygon mesh (a
// non-manifold vertex or edge, a face listed twice: then no answer is given).
int count_self_intersections(const Positions& V, const Faces& F);

}  // namespace pd
