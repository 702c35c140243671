#pragma once
// Start-state intersection check, run on a scene's initial positions before simulating.
//
// IPC can only keep an intersection-free state intersection-free: if the start state already has
// two primitives within the contact offset, the barrier is infinite there and no line search can
// recover. Distances alone are not enough to find a bad start: an edge that pierces a large
// triangle's interior, far from that triangle's vertices and edges, is close to no vertex-triangle
// or edge-edge pair. So the check does two things over the contact primitives, with the broad
// phase's exclusions (pairs sharing a vertex are skipped; pairs within one object only if that
// object's self-contact is on):
//   (a) point-triangle and edge-edge pairs whose distance (distance.h, as the barrier evaluates it)
//       is <= offset, i.e. exactly the pairs whose barrier is infinite (d^2 <= offset^2), touching
//       at exactly the offset included;
//   (b) edge-triangle piercing: a mesh edge that meets a triangle it shares no vertex with
//       (segment against closed triangle, see start_check.cpp for the tolerance).
// Not detected, by design: a closed surface entirely inside another (shells have no inside, so a
// cloth inside a balloon is a valid scene).
#include <array>
#include <string>
#include <vector>

#include "physics/contact/broad_phase.h"

namespace pd {

struct StartViolation {
  enum class Kind { PointTriangle, EdgeEdge, EdgeTriangle };
  Kind kind = Kind::PointTriangle;
  // Global indices into the primitives (the scene's stacked numbering):
  //   PointTriangle: a = vertex, b = face;  EdgeEdge: a, b = edges (a < b);
  //   EdgeTriangle:  a = edge,   b = face.
  int a = -1, b = -1;
  int object_a = -1, object_b = -1;  // object ids of a and b (ContactPrimitives::vertex_object)
  double distance = 0.0;  // m: the pair's distance for PointTriangle / EdgeEdge; 0 for EdgeTriangle
  double offset = 0.0;    // m: the contact offset the pair was checked against
  // The same primitives numbered within their objects (0-based: the index among the earlier
  // vertices / faces of the same object, i.e. the index in that object's own mesh when objects are
  // stacked in order), for messages a user can look up:
  //   a vertex: {local vertex, -1};  an edge: {local endpoint 0, local endpoint 1};
  //   a face:   {local face, -1}.
  std::array<int, 2> a_local{{-1, -1}}, b_local{{-1, -1}};
};

// The violations at positions V (n, 3), m, for contact offset `offset` >= 0 (m), in a deterministic
// order: point-triangle pairs sorted by (vertex, face), then edge-edge pairs by (edge, edge), then
// edge-triangle pairs by (edge, face). At most max_reports (>= 0) are returned; total_found, if
// given, receives how many there are in all (computing it means testing every pair; without it the
// search stops at max_reports). Throws std::invalid_argument for offset < 0 or non-finite,
// max_reports < 0, and for the broad phase's input errors (sizes, indices, non-finite positions).
std::vector<StartViolation> find_start_violations(const ContactPrimitives& prims, const Positions& V,
                                                  double offset, int max_reports = 16,
                                                  int* total_found = nullptr);

// A one-line message naming both objects (object_names indexed by object id; an id without a name
// prints as "#k"), with object-local indices and distances in mm, e.g.
//   object 'cloth' vertex 12 is 0 mm from object 'sphere' face 40 (contact offset 0.5 mm)
//   object 'cloth' edge (3, 4) is 0.21 mm from object 'sphere' edge (7, 9) (contact offset 0.5 mm)
//   object 'cloth' edge (3, 4) passes through object 'sphere' face 40
std::string describe(const StartViolation& violation, const std::vector<std::string>& object_names);

}  // namespace pd
