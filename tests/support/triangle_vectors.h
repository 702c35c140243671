#pragma once
// One triangle's stacked vertices (x0, x1, x2: 9 entries, metres), for the triangle-energy tests.
#include "geometry/mesh.h"

namespace pd::test {

inline Vec<9> stack(const Vec3& a, const Vec3& b, const Vec3& c) {
  Vec<9> x;
  x << a, b, c;
  return x;
}
inline Vec3 vertex(const Vec<9>& x, int v) { return x.segment<3>(3 * v); }
inline double area_of(const Vec<9>& x) {
  return 0.5 * (vertex(x, 1) - vertex(x, 0)).cross(vertex(x, 2) - vertex(x, 0)).norm();
}

}  // namespace pd::test
