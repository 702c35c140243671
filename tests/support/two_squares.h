#pragma once
// Two small squares for contact tests: the second 0.12 m above the first, tilted and shifted, so
// that point-triangle and edge-edge pairs of several closest-point types are active at a dhat of
// 0.1 to 0.2 m. Object 0 is the lower square, object 1 the upper; self-contact off.
#include <Eigen/Geometry>

#include "geometry/shapes.h"
#include "geometry/topology.h"
#include "physics/contact/broad_phase.h"

namespace pd::test {

struct TwoSquares {
  ContactPrimitives prims;
  Positions rest;
  Eigen::VectorXd x;
  TwoSquares() {
    const TriMesh a = make_rectangle(1.0, 1.0, 2, 2);
    TriMesh b = make_rectangle(0.6, 0.6, 2, 2);
    const Mat3 R = Eigen::AngleAxisd(0.15, Vec3(1, 2, 0.5).normalized()).toRotationMatrix();
    for (int i = 0; i < b.num_vertices(); ++i) b.V.row(i) = (R * b.V.row(i).transpose() + Vec3(0.07, -0.05, 0.12)).transpose();
    rest.resize(a.num_vertices() + b.num_vertices(), 3);
    rest << a.V, b.V;
    prims.faces.resize(a.num_faces() + b.num_faces(), 3);
    prims.faces << a.F, (b.F.array() + a.num_vertices()).matrix();
    for (auto e : build_topology(a).edges) prims.edges.push_back(e);
    for (auto e : build_topology(b).edges) prims.edges.push_back({e[0] + a.num_vertices(), e[1] + a.num_vertices()});
    prims.vertex_object.assign(rest.rows(), 0);
    for (int v = a.num_vertices(); v < rest.rows(); ++v) prims.vertex_object[v] = 1;
    prims.object_self_contact = {0, 0};
    x = stacked(rest);
  }
};

}  // namespace pd::test
