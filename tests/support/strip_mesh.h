#pragma once
// A strip of n x 2 vertices and its 2 (n - 1) triangles: the frame-store tests' small mesh
// (vertex 2 i and 2 i + 1 form column i).
#include "geometry/mesh.h"

namespace pd::test {

inline Faces strip_faces(int n) {
  Faces F(2 * (n - 1), 3);
  for (int i = 0; i + 1 < n; ++i) {
    F.row(2 * i) << 2 * i, 2 * i + 1, 2 * i + 2;
    F.row(2 * i + 1) << 2 * i + 1, 2 * i + 3, 2 * i + 2;
  }
  return F;
}

}  // namespace pd::test
