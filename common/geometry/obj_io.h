#pragma once
// Wavefront OBJ reading and writing (vertices and triangular faces only).
#include <cstddef>
#include <cstdint>
#include <string>

#include "geometry/mesh.h"
#include "util/input_error.h"

namespace pd {

// What read_obj accepts before it allocates more (defaults far above any scene's limits).
struct ObjLimits {
  std::uintmax_t max_bytes = std::uintmax_t{1} << 30;  // file size, checked by stat before opening (1 GiB)
  long long max_vertices = 50000000;                   // `v` lines
  long long max_faces = 100000000;                     // triangles after fan triangulation
  std::size_t max_line_bytes = 65536;                  // one line (a real `f` line of 1000 corners is 20 KB)
};

// Reads `path`. Accepts `v x y z` and `f` lines with 3 or more indices (v, v/vt, v/vt/vn, v//vn;
// negative indices are relative); polygons with more than 3 vertices are fan-triangulated. Ignores
// vt, vn, comments, groups and materials. Throws InputError naming the file, and the line where
// there is one, for: a path that is not a regular file (directory, FIFO, device, socket: refused by
// stat before it is opened, so nothing blocks), a file over `limits.max_bytes`, a missing or
// unreadable file, malformed numbers, out-of-range indices, more vertices, faces or bytes per line
// than `limits` allows (stopped at the line that crosses the limit), no faces.
TriMesh read_obj(const std::string& path, const ObjLimits& limits = {});

// Writes vertices and faces (1-based in the file). Throws InputError when the file cannot be written.
void write_obj(const std::string& path, const Positions& V, const Faces& F);

}  // namespace pd
