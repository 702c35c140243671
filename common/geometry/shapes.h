#pragma once
// Procedural meshes for scenes and tests. All are centred at the origin, in metres.
// Invalid arguments (non-positive or non-finite sizes, too few cells) throw std::invalid_argument:
// they are programming errors here, as scene parsing validates user input with its own key paths.
#include "geometry/mesh.h"

namespace pd {

// How the quads of a rectangle grid are split into triangles. Cell (i, j) is split along
// (i, j)-(i+1, j+1) ("up") or (i+1, j)-(i, j+1) ("down"):
//   Checkerboard: up when i + j is even. No preferred shear direction for the membrane, but discrete
//     hinge bending of a strip with free long edges relaxes into non-cylindrical shapes and comes out
//     up to 1.25x too soft (measured on a clamped cantilever; see bending_hinge.h).
//   Rows: up on even rows j, down on odd rows. Hinge bending along the grid is exact for strips
//     (cantilever within 0.1% of plate theory); use it for beams and strips.
//   Uniform: always up. Twist couples to bending (1.21x too soft a strip); for comparisons only.
enum class GridDiagonals { Checkerboard, Rows, Uniform };

// Rectangle in the x-y plane (z = 0), width along x, height along y, with `cells_x` by `cells_y`
// quads split as `diagonals` says. Vertex (i, j) (i along x, j along y) has index
// j * (cells_x + 1) + i. Normals point along +z. (cells_x + 1) * (cells_y + 1) vertices,
// 2 * cells_x * cells_y faces.
TriMesh make_rectangle(double width, double height, int cells_x, int cells_y,
                       GridDiagonals diagonals = GridDiagonals::Checkerboard);

// Icosphere of the given radius: an icosahedron subdivided `subdivisions` times (each time every
// triangle splits in four) with vertices pushed to the sphere. 12 vertices at 0, 10*4^s + 2 after s.
// Outward normals. 0 <= subdivisions <= 10.
TriMesh make_icosphere(double radius, int subdivisions);

// Closed box surface with sides (sx, sy, sz), each face a grid of `cells` x `cells` quads
// (shared edges welded). Outward normals. 6 * cells^2 + 2 vertices, 12 * cells^2 faces.
TriMesh make_box(const Vec3& size, int cells);

// Cylinder of the given radius around the y axis from y = -height/2 to +height/2, `segments` around
// and `rings` along; `capped` closes both ends with triangle fans around a centre vertex.
// Outward normals. Vertex (s, r) (s around, r along +y) has index r * segments + s; the bottom and
// top centres (capped only) follow. segments * (rings + 1) (+ 2 if capped) vertices,
// 2 * segments * rings (+ 2 * segments if capped) faces. segments >= 3, rings >= 1.
TriMesh make_cylinder(double radius, double height, int segments, int rings, bool capped);

// Cup: make_cylinder's wall (same vertex indexing) closed at the bottom (y = -height/2) by a triangle
// fan around a centre vertex, which is the last vertex, and open at the top. One consistently oriented
// surface whose normals point away from the axis on the wall and along -y on the bottom; its only
// boundary is the rim at y = +height/2. segments * (rings + 1) + 1 vertices,
// 2 * segments * rings + segments faces. segments >= 3, rings >= 1.
TriMesh make_cup(double radius, double height, int segments, int rings);

// Closed spur-gear-like prism around the y axis from y = -thickness/2 to +thickness/2 (a sharp
// obstacle). The outline in the x-z plane has 4 * teeth points at angles theta = 2 pi s / (4 teeth)
// (x = rho cos(theta), z = -rho sin(theta)); tooth t owns s = 4t .. 4t + 3: root start, tip start, tip
// end, root end, with rho = root_radius at the root points and radius at the tip points. Vertex s of
// the bottom outline has index s, of the top outline 4 * teeth + s; the bottom and top centres are
// 8 * teeth and 8 * teeth + 1, and the caps are triangle fans around them. Outward normals.
// 8 * teeth + 2 vertices, 16 * teeth faces. teeth >= 3, 0 < root_radius < radius, thickness > 0.
TriMesh make_gear(double radius, double root_radius, int teeth, double thickness);

// Rectangle in the x-y plane (z = 0), width along x, height along y, meshed with near-equilateral
// triangles, normals along +z. The cell (triangle side) is c = width / cells_x. Rows of vertices
// run along x; the number of row gaps is rows = max(1, round(height / (sqrt(3)/2 * c))) and the gaps
// are exactly height / rows (so the rectangle is met exactly and triangles stay near-equilateral).
// Even rows j hold cells_x + 1 vertices at x = -width/2 + i*c; odd rows are offset by half a cell and
// get a vertex at each end, x = -width/2, -width/2 + (i - 1/2)*c for i = 1..cells_x, +width/2
// (cells_x + 2 vertices), so the left and right boundaries are straight (half triangles there).
// Row j starts at vertex index j * (cells_x + 1) + j / 2 (integer division).
// (rows + 1) * (cells_x + 1) + ceil(rows / 2) vertices, rows * (2 * cells_x + 1) faces.
TriMesh make_rectangle_equilateral(double width, double height, int cells_x);

}  // namespace pd
