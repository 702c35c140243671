#pragma once
// An irregular, Delaunay triangulation of a rectangle, for tests that must not depend on a grid's
// symmetry (bending on irregular meshes): a grid of points, each moved by a seeded random fraction
// of a cell, triangulated along one diagonal and then made Delaunay by Lawson edge flips.
#include <array>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"

namespace pd::test {

// (cells_x + 1) x (cells_y + 1) points on [-width/2, width/2] x [-height/2, height/2] (vertex (i, j)
// has index j (cells_x + 1) + i, as make_rectangle's), each inner coordinate moved by up to `jitter`
// cells (uniform, from `seed`). Boundary points stay on their side; the first and last `straight`
// columns keep their x and rows their y, so that pinned rows and columns are straight. Faces
// counter-clockwise seen from +z; every inner edge locally Delaunay. jitter <= 0.2 keeps the initial
// diagonal split valid.
inline TriMesh make_delaunay_rectangle(double width, double height, int cells_x, int cells_y, unsigned seed,
                                       double jitter = 0.2, int straight = 2) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-jitter, jitter);
  const double dx = width / cells_x, dy = height / cells_y;
  std::vector<Eigen::Vector2d> p;
  for (int j = 0; j <= cells_y; ++j)
    for (int i = 0; i <= cells_x; ++i) {
      const double ux = U(rng), uy = U(rng);  // drawn for every point, so the layout does not shift
      const bool keep_x = i < straight || i > cells_x - straight, keep_y = j < straight || j > cells_y - straight;
      p.emplace_back(-0.5 * width + i * dx + (keep_x ? 0.0 : ux * dx),
                     -0.5 * height + j * dy + (keep_y ? 0.0 : uy * dy));
    }
  std::vector<std::array<int, 3>> f;
  for (int j = 0; j < cells_y; ++j)
    for (int i = 0; i < cells_x; ++i) {
      const int a = j * (cells_x + 1) + i, b = a + 1, c = b + cells_x + 1, d = a + cells_x + 1;
      f.push_back({a, b, c});
      f.push_back({a, c, d});
    }
  // Positive when d lies inside the circumcircle of the counter-clockwise triangle (a, b, c).
  const auto incircle = [&](int a, int b, int c, int d) {
    const Eigen::Vector2d A = p[a] - p[d], B = p[b] - p[d], C = p[c] - p[d];
    return A.squaredNorm() * (B.x() * C.y() - B.y() * C.x()) - B.squaredNorm() * (A.x() * C.y() - A.y() * C.x()) +
           C.squaredNorm() * (A.x() * B.y() - A.y() * B.x());
  };
  for (bool flipped = true; flipped;) {
    flipped = false;
    std::map<std::pair<int, int>, std::pair<int, int>> half;  // directed edge -> (face, opposite vertex)
    for (int t = 0; t < static_cast<int>(f.size()); ++t)
      for (int k = 0; k < 3; ++k) half[{f[t][k], f[t][(k + 1) % 3]}] = {t, f[t][(k + 2) % 3]};
    std::vector<char> touched(f.size(), 0);
    for (const auto& [edge, face] : half) {
      const auto other = half.find({edge.second, edge.first});
      if (edge.first > edge.second || other == half.end()) continue;
      const int t1 = face.first, t2 = other->second.first;
      if (touched[t1] || touched[t2]) continue;  // flip each face once per pass: the map is stale after
      const int u = edge.first, v = edge.second, a = face.second, b = other->second.second;
      const double scale = (p[u] - p[v]).squaredNorm();
      if (incircle(u, v, a, b) > 1e-10 * scale * scale) {  // a margin, so cocircular quads do not cycle
        f[t1] = {a, b, v};
        f[t2] = {b, a, u};
        touched[t1] = touched[t2] = 1;
        flipped = true;
      }
    }
  }
  TriMesh m;
  m.V.resize(static_cast<int>(p.size()), 3);
  for (size_t i = 0; i < p.size(); ++i) m.V.row(static_cast<int>(i)) << p[i].x(), p[i].y(), 0.0;
  m.F.resize(static_cast<int>(f.size()), 3);
  for (size_t t = 0; t < f.size(); ++t) m.F.row(static_cast<int>(t)) << f[t][0], f[t][1], f[t][2];
  return m;
}

}  // namespace pd::test
