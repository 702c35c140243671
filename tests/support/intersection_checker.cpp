#include "support/intersection_checker.h"

// CGAL calls used (CGAL 5.5, header-only; GMP/MPFR back the exact predicates' fallback arithmetic):
//   Polygon_mesh_processing::is_polygon_soup_a_polygon_mesh  - can F be a Surface_mesh?
//   Euler::add_face on Surface_mesh                          - build it, face by face (to map indices)
//   Polygon_mesh_processing::self_intersections              - all non-adjacent intersecting pairs
//   box_self_intersection_d, collinear, coplanar, coplanar_orientation, do_intersect - the soup path
//
// Adjacency in CGAL's self_intersections (CGAL 5.5, Polygon_mesh_processing/self_intersections.h,
// internal do_faces_intersect): for each pair of faces whose boxes overlap,
//   - faces sharing a halfedge-connected edge intersect iff their four points are coplanar and the
//     two opposite vertices lie on the same side of the shared edge (coplanar_orientation POSITIVE);
//   - faces sharing a vertex (and no edge) intersect iff the edge opposite the shared vertex in one
//     face meets the other triangle (tested both ways);
//   - other faces: exact triangle-triangle do_intersect;
//   - degenerate (collinear) faces get no box and are reported once as the pair (f, f).
// "Sharing" is by vertex and halfedge identity, which here is the index identity of F, because the
// mesh is built from F without merging or splitting vertices. The soup path applies the same rules
// with sharing read from the indices directly (any two shared vertices of two triangles are a
// shared edge), so it also works where a Surface_mesh cannot be built.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/Euler_operations.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/intersections.h>

#include <algorithm>
#include <array>
#include <iterator>
#include <stdexcept>
#include <string>

namespace pd::test {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
// Exact predicates (the orientation tests that decide intersection are exact), inexact
// constructions (none are needed).
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;

void check_input(const Positions& V, const Faces& F) {
  if (!V.allFinite()) throw std::invalid_argument("find_intersections: non-finite coordinate");
  for (Eigen::Index c = 0; c < F.size(); ++c)
    if (F.data()[c] < 0 || F.data()[c] >= V.rows())
      throw std::invalid_argument("find_intersections: face " + std::to_string(c / 3) +
                                  " references missing vertex " + std::to_string(F.data()[c]));
}

std::vector<Point> points_of(const Positions& V) {
  std::vector<Point> P;
  P.reserve(static_cast<std::size_t>(V.rows()));
  for (Eigen::Index i = 0; i < V.rows(); ++i) P.emplace_back(V(i, 0), V(i, 1), V(i, 2));
  return P;
}

// Puts pairs in canonical form (f < g, sorted, unique) and fills the counts.
IntersectionReport make_report(std::vector<std::pair<int, int>> pairs, std::vector<int> degenerate,
                               bool soup) {
  for (auto& p : pairs)
    if (p.first > p.second) std::swap(p.first, p.second);
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  std::sort(degenerate.begin(), degenerate.end());
  degenerate.erase(std::unique(degenerate.begin(), degenerate.end()), degenerate.end());
  IntersectionReport r;
  r.intersecting_pairs = static_cast<int>(pairs.size());
  r.face_pairs = std::move(pairs);
  r.degenerate_faces = std::move(degenerate);
  r.triangle_soup = soup;
  return r;
}

// The Surface_mesh path. Returns false (and leaves `out` alone) if F is not a valid polygon mesh.
bool check_as_mesh(const std::vector<Point>& P, const Faces& F, IntersectionReport& out) {
  const int m = static_cast<int>(F.rows());
  std::vector<std::array<std::size_t, 3>> polygons(static_cast<std::size_t>(m));
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) polygons[f][k] = static_cast<std::size_t>(F(f, k));
  // Rejects non-manifold edges and vertices, inconsistent orientation and repeated vertices, all of
  // which Surface_mesh cannot represent.
  if (!PMP::is_polygon_soup_a_polygon_mesh(polygons)) return false;

  // Built by hand rather than with polygon_soup_to_polygon_mesh, which returns no face map: face
  // descriptor -> row of F is needed to report rows. Every vertex is added, used or not.
  Mesh mesh;
  std::vector<Mesh::Vertex_index> vertex;
  vertex.reserve(P.size());
  for (const Point& p : P) vertex.push_back(mesh.add_vertex(p));
  std::vector<int> row_of_face;
  for (int f = 0; f < m; ++f) {
    const std::array<Mesh::Vertex_index, 3> corners = {vertex[F(f, 0)], vertex[F(f, 1)], vertex[F(f, 2)]};
    const Mesh::Face_index face = CGAL::Euler::add_face(corners, mesh);
    if (face == Mesh::null_face()) return false;  // not expected after the check above
    if (row_of_face.size() <= face.idx()) row_of_face.resize(face.idx() + 1, -1);
    row_of_face[face.idx()] = f;
  }

  std::vector<std::pair<Mesh::Face_index, Mesh::Face_index>> found;
  PMP::self_intersections(mesh, std::back_inserter(found));  // Sequential_tag; kernel from Point
  std::vector<std::pair<int, int>> pairs;
  std::vector<int> degenerate;
  for (const auto& [a, b] : found) {
    if (a == b)
      degenerate.push_back(row_of_face[a.idx()]);
    else
      pairs.emplace_back(row_of_face[a.idx()], row_of_face[b.idx()]);
  }
  out = make_report(std::move(pairs), std::move(degenerate), false);
  return true;
}

// Whether faces a and b (non-degenerate rows of F) meet beyond the vertices and edge they share by
// index: the rules stated at the top of the file.
bool faces_meet(const std::vector<Point>& P, const Faces& F, int a, int b) {
  const std::array<int, 3> va = {F(a, 0), F(a, 1), F(a, 2)}, vb = {F(b, 0), F(b, 1), F(b, 2)};
  std::vector<int> shared;  // positions k in a whose vertex is also in b
  for (int k = 0; k < 3; ++k)
    if (std::find(vb.begin(), vb.end(), va[k]) != vb.end()) shared.push_back(k);
  auto not_in = [](const std::array<int, 3>& v, int x, int y) {  // the corner of v other than x, y
    for (int c : v)
      if (c != x && c != y) return c;
    return -1;
  };
  const Kernel::Triangle_3 ta(P[va[0]], P[va[1]], P[va[2]]), tb(P[vb[0]], P[vb[1]], P[vb[2]]);

  switch (shared.size()) {
    case 3:  // the same triangle twice (either orientation): full overlap
      return true;
    case 2: {
      const int p = va[shared[0]], q = va[shared[1]];
      const Point &P0 = P[p], &P1 = P[q], &r = P[not_in(va, p, q)], &s = P[not_in(vb, p, q)];
      return CGAL::coplanar(P0, P1, r, s) && CGAL::coplanar_orientation(P0, P1, r, s) == CGAL::POSITIVE;
    }
    case 1: {
      const int v = va[shared[0]];
      std::array<int, 2> oa{}, ob{};  // the edges opposite v
      int i = 0, j = 0;
      for (int k = 0; k < 3; ++k) {
        if (va[k] != v) oa[i++] = va[k];
        if (vb[k] != v) ob[j++] = vb[k];
      }
      return CGAL::do_intersect(ta, Kernel::Segment_3(P[ob[0]], P[ob[1]])) ||
             CGAL::do_intersect(tb, Kernel::Segment_3(P[oa[0]], P[oa[1]]));
    }
    default:
      return CGAL::do_intersect(ta, tb);
  }
}

}  // namespace

IntersectionReport find_intersections_in_soup(const Positions& V, const Faces& F) {
  check_input(V, F);
  const std::vector<Point> P = points_of(V);
  using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, int>;  // info: row of F
  std::vector<Box> boxes;
  std::vector<int> degenerate;
  for (int f = 0; f < static_cast<int>(F.rows()); ++f) {
    const Point &p = P[F(f, 0)], &q = P[F(f, 1)], &r = P[F(f, 2)];
    if (CGAL::collinear(p, q, r))  // includes repeated indices and coincident points
      degenerate.push_back(f);
    else
      boxes.emplace_back(p.bbox() + q.bbox() + r.bbox(), f);  // exact: the bbox of doubles is exact
  }
  std::vector<std::pair<int, int>> pairs;
  // Closed boxes (the default topology), so touching faces are tested too.
  CGAL::box_self_intersection_d(boxes.begin(), boxes.end(), [&](const Box& a, const Box& b) {
    if (faces_meet(P, F, a.info(), b.info())) pairs.emplace_back(a.info(), b.info());
  });
  return make_report(std::move(pairs), std::move(degenerate), true);
}

IntersectionReport find_intersections(const Positions& V, const Faces& F) {
  check_input(V, F);
  IntersectionReport report;
  if (check_as_mesh(points_of(V), F, report)) return report;
  return find_intersections_in_soup(V, F);
}

int intersections_outside_obstacles(const Positions& V, const Faces& F, const std::vector<int>& face_offsets,
                                    const std::vector<char>& obstacle) {
  const IntersectionReport r = find_intersections(V, F);
  const auto object_of = [&](int f) {
    std::size_t k = 0;
    while (k + 1 < face_offsets.size() && face_offsets[k + 1] <= f) ++k;
    return k;
  };
  int count = static_cast<int>(r.degenerate_faces.size());
  for (const auto& [f, g] : r.face_pairs) {
    const std::size_t a = object_of(f), b = object_of(g);
    if (!(a == b && a < obstacle.size() && obstacle[a])) ++count;
  }
  return count;
}

bool intersection_free(const Positions& V, const Faces& F) {
  const IntersectionReport r = find_intersections(V, F);
  return r.intersecting_pairs == 0 && r.degenerate_faces.empty();
}

}  // namespace pd::test
