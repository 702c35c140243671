#pragma once
// Wavefront OBJ reading and writing (vertices and triangular faces only).
#include <string>

#include "geometry/mesh.h"
#include "util/input_error.h"

namespace pd {

// Reads `path`. Accepts `v x y z` and `f` lines with 3 or more indices (v, v/vt, v/vt/vn, v//vn;
// negative indices are relative); polygons with more than 3 vertices are fan-triangulated. Ignores
// vt, vn, comments, groups and materials. Throws InputError naming the file and line for: missing or
// unreadable file, malformed numbers, out-of-range indices, no faces.
TriMesh read_obj(const std::string& path);

// Writes vertices and faces (1-based in the file). Throws InputError when the file cannot be written.
void write_obj(const std::string& path, const Positions& V, const Faces& F);

}  // namespace pd
