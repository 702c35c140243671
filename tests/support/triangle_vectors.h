#pragma once
// One triangle's stacked vertices (x0, x1, x2: 9 entries, metres), for the triangle-energy tests.
#include <random>

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

// Random triangle with coordinates in [-1, 1] m and area at least 0.1 m^2 (resampled otherwise).
inline Vec<9> random_triangle(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vec<9> x;
  do {
    for (int i = 0; i < 9; ++i) x[i] = u(rng);
  } while (area_of(x) < 0.1);
  return x;
}

}  // namespace pd::test
