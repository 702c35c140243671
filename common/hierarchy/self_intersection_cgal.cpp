#include "hierarchy/self_intersection_cgal.h"

#include <array>
#include <iterator>
#include <utility>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

namespace pd {

namespace {
namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
}  // namespace

int count_self_intersections(const Positions& V, const Faces& F) {
  std::vector<Point> points;
  points.reserve(static_cast<std::size_t>(V.rows()));
  for (Eigen::Index v = 0; v < V.rows(); ++v) points.emplace_back(V(v, 0), V(v, 1), V(v, 2));
  std::vector<std::array<std::size_t, 3>> polygons;
  polygons.reserve(static_cast<std::size_t>(F.rows()));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    polygons.push_back({static_cast<std::size_t>(F(f, 0)), static_cast<std::size_t>(F(f, 1)),
                        static_cast<std::size_t>(F(f, 2))});
  if (!PMP::is_polygon_soup_a_polygon_mesh(polygons)) return -1;
  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  std::vector<std::pair<Mesh::Face_index, Mesh::Face_index>> pairs;
  PMP::self_intersections(mesh, std::back_inserter(pairs));
  return static_cast<int>(pairs.size());
}

}  // namespace pd
