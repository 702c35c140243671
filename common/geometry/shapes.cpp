#include "geometry/shapes.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace pd {
namespace {

void require(bool ok, const char* function, const std::string& problem) {
  if (!ok) throw std::invalid_argument(std::string(function) + ": " + problem);
}

bool positive_finite(double x) { return std::isfinite(x) && x > 0.0; }

// Rejects sizes whose vertex or face count would overflow the int indices of Faces.
void require_fits(long double vertices, long double faces, const char* function) {
  const long double max = std::numeric_limits<int>::max();
  require(vertices <= max && faces <= max, function, "mesh too large for int indices");
}

// Appends the two triangles of the counter-clockwise quad (a, b, c, d). `other_diagonal` false splits
// along a-c, true along b-d; alternating it between neighbouring quads avoids a preferred shear
// direction (a mesh with all diagonals parallel is stiffer in one shear direction than the other).
void add_quad(std::vector<std::array<int, 3>>& faces, int a, int b, int c, int d, bool other_diagonal) {
  if (!other_diagonal) {
    faces.push_back({a, b, c});
    faces.push_back({a, c, d});
  } else {
    faces.push_back({a, b, d});
    faces.push_back({b, c, d});
  }
}

TriMesh to_mesh(const std::vector<Vec3>& points, const std::vector<std::array<int, 3>>& faces) {
  TriMesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t i = 0; i < points.size(); ++i) mesh.V.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
  mesh.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int k = 0; k < 3; ++k) mesh.F(static_cast<Eigen::Index>(f), k) = faces[f][k];
  return mesh;
}

// Coordinate `i` of `n` equal steps across [-size/2, size/2]. i / n is exact at both ends, so the
// extreme vertices land exactly on +-size/2 (no round-off gap at the boundary).
double lerp_centred(double size, int i, int n) {
  return size * (static_cast<double>(i) / n) - 0.5 * size;
}

}  // namespace

TriMesh make_rectangle(double width, double height, int cells_x, int cells_y, GridDiagonals diagonals) {
  require(positive_finite(width) && positive_finite(height), "make_rectangle", "width and height must be > 0");
  require(cells_x >= 1 && cells_y >= 1, "make_rectangle", "cells_x and cells_y must be >= 1");
  require_fits((cells_x + 1.0L) * (cells_y + 1.0L), 2.0L * cells_x * cells_y, "make_rectangle");
  const int nx = cells_x + 1;
  std::vector<Vec3> points;
  points.reserve(static_cast<std::size_t>(nx) * (cells_y + 1));
  for (int j = 0; j <= cells_y; ++j)
    for (int i = 0; i <= cells_x; ++i)
      points.emplace_back(lerp_centred(width, i, cells_x), lerp_centred(height, j, cells_y), 0.0);
  std::vector<std::array<int, 3>> faces;
  faces.reserve(2 * static_cast<std::size_t>(cells_x) * cells_y);
  // The last argument of add_quad selects the (i+1, j)-(i, j+1) diagonal ("down" in shapes.h).
  auto down = [diagonals](int i, int j) {
    switch (diagonals) {
      case GridDiagonals::Checkerboard: return (i + j) % 2 == 1;
      case GridDiagonals::Rows: return j % 2 == 1;
      case GridDiagonals::Uniform: return false;
    }
    return false;
  };
  for (int j = 0; j < cells_y; ++j)
    for (int i = 0; i < cells_x; ++i) {
      const int a = j * nx + i;
      add_quad(faces, a, a + 1, a + 1 + nx, a + nx, down(i, j));
    }
  return to_mesh(points, faces);
}

TriMesh make_rectangle_equilateral(double width, double height, int cells_x) {
  require(positive_finite(width) && positive_finite(height), "make_rectangle_equilateral",
          "width and height must be > 0");
  require(cells_x >= 1, "make_rectangle_equilateral", "cells_x must be >= 1");
  const double cell = width / cells_x;
  const double target_rows = height / (0.5 * std::sqrt(3.0) * cell);
  require(target_rows < 1e9, "make_rectangle_equilateral", "height too large for the cell size");
  const int rows = std::max(1, static_cast<int>(std::lround(target_rows)));
  require_fits((rows + 1.0L) * (cells_x + 1.0L) + (rows + 1) / 2, rows * (2.0L * cells_x + 1),
               "make_rectangle_equilateral");

  // Row layout (see shapes.h): even rows are the cell corners, odd rows sit half a cell over and carry
  // an extra end vertex so the left and right edges stay straight.
  auto row_start = [cells_x](int j) { return j * (cells_x + 1) + j / 2; };
  std::vector<Vec3> points;
  for (int j = 0; j <= rows; ++j) {
    const double y = lerp_centred(height, j, rows);
    if (j % 2 == 0) {
      for (int i = 0; i <= cells_x; ++i) points.emplace_back(lerp_centred(width, i, cells_x), y, 0.0);
    } else {
      points.emplace_back(-0.5 * width, y, 0.0);
      for (int i = 1; i <= cells_x; ++i)
        points.emplace_back(width * ((i - 0.5) / cells_x) - 0.5 * width, y, 0.0);
      points.emplace_back(0.5 * width, y, 0.0);
    }
  }

  // Each strip between rows j and j+1 holds 2 * cells_x + 1 triangles, listed left to right and all
  // counter-clockwise seen from +z. A_i are the even row's vertices, B_k the odd row's; B_k (1 <= k <=
  // cells_x) lies halfway between A_{k-1} and A_k.
  std::vector<std::array<int, 3>> faces;
  faces.reserve(static_cast<std::size_t>(rows) * (2 * cells_x + 1));
  for (int j = 0; j < rows; ++j) {
    const bool lower_even = j % 2 == 0;
    const int a0 = row_start(lower_even ? j : j + 1);  // even row
    const int b0 = row_start(lower_even ? j + 1 : j);  // odd row
    if (lower_even) {
      faces.push_back({a0, b0 + 1, b0});  // left half triangle
      for (int i = 0; i < cells_x; ++i) {
        faces.push_back({a0 + i, a0 + i + 1, b0 + i + 1});                         // pointing up
        if (i + 1 < cells_x) faces.push_back({a0 + i + 1, b0 + i + 2, b0 + i + 1});  // pointing down
      }
      faces.push_back({a0 + cells_x, b0 + cells_x + 1, b0 + cells_x});  // right half triangle
    } else {
      faces.push_back({b0, b0 + 1, a0});  // left half triangle
      for (int k = 1; k <= cells_x; ++k) {
        faces.push_back({b0 + k, a0 + k, a0 + k - 1});                     // pointing down
        if (k < cells_x) faces.push_back({b0 + k, b0 + k + 1, a0 + k});  // pointing up
      }
      faces.push_back({b0 + cells_x, b0 + cells_x + 1, a0 + cells_x});  // right half triangle
    }
  }
  return to_mesh(points, faces);
}

TriMesh make_icosphere(double radius, int subdivisions) {
  require(positive_finite(radius), "make_icosphere", "radius must be > 0");
  require(subdivisions >= 0 && subdivisions <= 10, "make_icosphere", "subdivisions must be in [0, 10]");

  // Icosahedron: the cyclic permutations of (0, +-1, +-t), t the golden ratio. Its faces are the
  // triples of mutually adjacent vertices (edge length 2); finding them by distance and orienting
  // each by its centroid avoids a hand-typed face table that could hide a flipped triangle.
  const double t = 0.5 * (1.0 + std::sqrt(5.0));
  std::vector<Vec3> corners;
  for (int axis = 0; axis < 3; ++axis)
    for (double s1 : {-1.0, 1.0})
      for (double s2 : {-t, t}) {
        Vec3 p = Vec3::Zero();
        p[(axis + 1) % 3] = s1;
        p[(axis + 2) % 3] = s2;
        corners.push_back(p);
      }
  auto adjacent = [&](int a, int b) { return std::abs((corners[a] - corners[b]).squaredNorm() - 4.0) < 1e-9; };
  std::vector<std::array<int, 3>> faces;
  for (int a = 0; a < 12; ++a)
    for (int b = a + 1; b < 12; ++b)
      for (int c = b + 1; c < 12; ++c) {
        if (!adjacent(a, b) || !adjacent(b, c) || !adjacent(a, c)) continue;
        const Vec3 n = (corners[b] - corners[a]).cross(corners[c] - corners[a]);
        if (n.dot(corners[a] + corners[b] + corners[c]) > 0.0) faces.push_back({a, b, c});
        else faces.push_back({a, c, b});
      }
  std::vector<Vec3> unit;  // vertices on the unit sphere; scaled by the radius at the end
  for (const Vec3& p : corners) unit.push_back(p.normalized());

  for (int level = 0; level < subdivisions; ++level) {
    // One new vertex per edge, shared by both triangles on it; keyed by the ordered vertex pair.
    std::unordered_map<long long, int> midpoint;
    midpoint.reserve(faces.size() * 3 / 2);
    const long long n = static_cast<long long>(unit.size());
    auto mid = [&](int a, int b) {
      const long long key = std::min(a, b) * n + std::max(a, b);
      const auto found = midpoint.find(key);
      if (found != midpoint.end()) return found->second;
      const int index = static_cast<int>(unit.size());
      unit.push_back((unit[a] + unit[b]).normalized());
      midpoint.emplace(key, index);
      return index;
    };
    std::vector<std::array<int, 3>> finer;
    finer.reserve(faces.size() * 4);
    for (const auto& f : faces) {
      const int ab = mid(f[0], f[1]), bc = mid(f[1], f[2]), ca = mid(f[2], f[0]);
      // Corner triangles keep the parent's corner order, so orientation carries over.
      finer.push_back({f[0], ab, ca});
      finer.push_back({f[1], bc, ab});
      finer.push_back({f[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    faces.swap(finer);
  }
  // Every vertex is a normalized vector times the radius: at the radius to round-off.
  for (Vec3& p : unit) p *= radius;
  return to_mesh(unit, faces);
}

TriMesh make_box(const Vec3& size, int cells) {
  require(positive_finite(size.x()) && positive_finite(size.y()) && positive_finite(size.z()), "make_box",
          "all sides must be > 0");
  require(cells >= 1, "make_box", "cells must be >= 1");
  require_fits(6.0L * cells * cells + 2, 12.0L * cells * cells, "make_box");

  // Vertices live on the integer lattice [0, cells]^3 (surface points only). Welding by lattice
  // coordinates is exact: the shared edges and corners of neighbouring sides get one vertex each,
  // with no floating-point tolerance involved.
  const long long n1 = cells + 1;
  std::unordered_map<long long, int> index_of;
  std::vector<Vec3> points;
  auto vertex = [&](const std::array<int, 3>& lattice) {
    const long long key = (lattice[0] * n1 + lattice[1]) * n1 + lattice[2];
    const auto found = index_of.find(key);
    if (found != index_of.end()) return found->second;
    const int index = static_cast<int>(points.size());
    points.emplace_back(lerp_centred(size.x(), lattice[0], cells), lerp_centred(size.y(), lattice[1], cells),
                        lerp_centred(size.z(), lattice[2], cells));
    index_of.emplace(key, index);
    return index;
  };

  std::vector<std::array<int, 3>> faces;
  faces.reserve(12 * static_cast<std::size_t>(cells) * cells);
  for (int axis = 0; axis < 3; ++axis) {
    // (u, v, axis) is a right-handed cyclic triple, so a quad counter-clockwise in (u, v) faces +axis.
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      for (int j = 0; j < cells; ++j)
        for (int i = 0; i < cells; ++i) {
          auto at = [&](int di, int dj) {
            std::array<int, 3> lattice{};
            lattice[axis] = side * cells;
            lattice[u] = i + di;
            lattice[v] = j + dj;
            return vertex(lattice);
          };
          const int a = at(0, 0), b = at(1, 0), c = at(1, 1), d = at(0, 1);
          // The +axis side keeps (a, b, c, d); the -axis side reverses it to face outward.
          if (side == 1) add_quad(faces, a, b, c, d, (i + j) % 2 == 1);
          else add_quad(faces, a, d, c, b, (i + j) % 2 == 1);
        }
    }
  }
  return to_mesh(points, faces);
}

namespace {

// Prism around the y axis from y = -height/2 to +height/2: `segments` outline points around,
// point s at angle theta = 2 pi s / segments and distance radius_of(s) (metres) from the axis,
// repeated on `rings` + 1 levels. Vertex (s, r) has index r * segments + s; the bottom centre (if
// `bottom_cap`) and then the top centre (if `top_cap`) follow. The outline must be star-shaped
// around the axis (theta increasing, radius > 0) so the cap fans are valid and all normals point out.
// One construction for cylinder, cup and gear keeps their indexing and winding identical.
template <class Radius>
TriMesh make_prism(double height, int segments, int rings, bool bottom_cap, bool top_cap, Radius radius_of) {
  // Angle theta runs around y with x = r cos(theta), z = -r sin(theta): then d/dtheta x d/dy points
  // outward, so quads counter-clockwise in (theta, y) have outward normals.
  const double two_pi = 2.0 * std::acos(-1.0);
  std::vector<Vec3> points;
  points.reserve(static_cast<std::size_t>(segments) * (rings + 1) + 2);
  for (int r = 0; r <= rings; ++r) {
    const double y = lerp_centred(height, r, rings);
    for (int s = 0; s < segments; ++s) {
      const double theta = two_pi * s / segments;
      const double radius = radius_of(s);
      points.emplace_back(radius * std::cos(theta), y, -radius * std::sin(theta));
    }
  }
  auto at = [segments](int s, int r) { return r * segments + s % segments; };  // wraps around
  std::vector<std::array<int, 3>> faces;
  faces.reserve(2 * static_cast<std::size_t>(segments) * (rings + 1));
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s)
      add_quad(faces, at(s, r), at(s + 1, r), at(s + 1, r + 1), at(s, r + 1), (s + r) % 2 == 1);
  const int bottom = static_cast<int>(points.size());
  if (bottom_cap) points.emplace_back(0.0, -0.5 * height, 0.0);
  const int top = static_cast<int>(points.size());
  if (top_cap) points.emplace_back(0.0, 0.5 * height, 0.0);
  // Bottom and top fan triangles interleave per segment (the face order make_cylinder always had).
  for (int s = 0; s < segments; ++s) {
    if (bottom_cap) faces.push_back({bottom, at(s + 1, 0), at(s, 0)});  // normal -y
    if (top_cap) faces.push_back({top, at(s, rings), at(s + 1, rings)});  // normal +y
  }
  return to_mesh(points, faces);
}

}  // namespace

TriMesh make_cylinder(double radius, double height, int segments, int rings, bool capped) {
  require(positive_finite(radius) && positive_finite(height), "make_cylinder", "radius and height must be > 0");
  require(segments >= 3 && rings >= 1, "make_cylinder", "segments must be >= 3 and rings >= 1");
  require_fits(segments * (rings + 1.0L) + 2, 2.0L * segments * (rings + 1), "make_cylinder");
  return make_prism(height, segments, rings, capped, capped, [radius](int) { return radius; });
}

TriMesh make_cup(double radius, double height, int segments, int rings) {
  require(positive_finite(radius) && positive_finite(height), "make_cup", "radius and height must be > 0");
  require(segments >= 3 && rings >= 1, "make_cup", "segments must be >= 3 and rings >= 1");
  require_fits(segments * (rings + 1.0L) + 1, segments * (2.0L * rings + 1), "make_cup");
  return make_prism(height, segments, rings, true, false, [radius](int) { return radius; });
}

TriMesh make_gear(double radius, double root_radius, int teeth, double thickness) {
  require(positive_finite(radius) && positive_finite(root_radius) && positive_finite(thickness), "make_gear",
          "radius, root_radius and thickness must be > 0");
  require(root_radius < radius, "make_gear", "root_radius must be < radius");
  require(teeth >= 3, "make_gear", "teeth must be >= 3");
  require_fits(8.0L * teeth + 2, 16.0L * teeth, "make_gear");
  // Outline point s belongs to tooth s / 4; within a tooth, points 0 and 3 (root start and end) sit
  // on the root circle and points 1 and 2 (tip start and end) on the tip circle.
  return make_prism(thickness, 4 * teeth, 1, true, true,
                    [radius, root_radius](int s) { return s % 4 == 1 || s % 4 == 2 ? radius : root_radius; });
}

}  // namespace pd
