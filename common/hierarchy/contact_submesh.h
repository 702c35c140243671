#pragma once
// Contact primitives of part of a mesh, renumbered: what safe upsampling hands to the broad phase,
// CCD and relaxation, which need every vertex to be a point of the surface (vertices not restored
// yet, or far from a patch, must not be).
//
// Conventions: vertex ids 0-based; positions (n, 3) rows in metres.
#include <vector>

#include "geometry/mesh.h"
#include "physics/contact/broad_phase.h"

namespace pd {

struct ContactSubmesh {
  ContactPrimitives prims;    // faces and edges in submesh ids; vertex_object per submesh vertex
  std::vector<int> vertices;  // submesh id -> id in the full numbering, increasing
  int local(int full_id) const;  // submesh id of a vertex of the submesh (binary search)
};

// The submesh of `faces` (full ids): its vertices are those the faces use, in increasing full id;
// edges are the faces' unique edges. vertex_object: per full vertex, or empty for "every vertex is
// object 0"; object_self_contact is copied. Cost O(faces log faces), independent of the full size.
ContactSubmesh contact_submesh(const Faces& faces, const std::vector<int>& vertex_object,
                               const std::vector<char>& object_self_contact);

// Rows `ids` of x, in that order.
Positions gather_rows(const Positions& x, const std::vector<int>& ids);
// x.row(ids[k]) = rows.row(k).
void scatter_rows(const Positions& rows, const std::vector<int>& ids, Positions& x);

}  // namespace pd
