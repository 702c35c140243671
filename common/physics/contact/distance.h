#pragma once
// Squared distances between surface primitives for IPC contact, with closed-form derivatives.
//
// Variables are stacked vertex positions in metres, in the order stated on each function:
//   point-triangle: (p, t0, t1, t2)      -> Vec<12>
//   edge-edge:      (ea0, ea1, eb0, eb1) -> Vec<12>
// The closest-point *type* (which sub-simplices are closest) is classified first; the squared
// distance, gradient and Hessian are then those of the smooth function for that type (point-point,
// point-edge, point-plane, edge-edge lines), as in IPC. Squared distances avoid the square root's
// singular derivative at contact.
#include "geometry/mesh.h"

namespace pd {

enum class PointTriangleType { P_T0, P_T1, P_T2, P_E0, P_E1, P_E2, P_T };
//   P_Ti: closest to vertex t_i; P_Ei: closest to edge (t_i, t_{(i+1)%3}); P_T: to the interior.

enum class EdgeEdgeType { EA0_EB0, EA0_EB1, EA1_EB0, EA1_EB1, EA_EB0, EA_EB1, EA0_EB, EA1_EB, EA_EB };
//   EAi_EBj: endpoints closest; EA_EBj: edge a to endpoint b_j; EAi_EB: endpoint a_i to edge b;
//   EA_EB: the two lines (interiors). Parallel edges never give EA_EB (an endpoint case is chosen).

PointTriangleType point_triangle_type(const Vec3& p, const Vec3& t0, const Vec3& t1, const Vec3& t2);
EdgeEdgeType edge_edge_type(const Vec3& ea0, const Vec3& ea1, const Vec3& eb0, const Vec3& eb1);

// x = (p, t0, t1, t2)
double point_triangle_squared_distance(const Vec<12>& x);
Vec<12> point_triangle_squared_distance_gradient(const Vec<12>& x);
Mat<12> point_triangle_squared_distance_hessian(const Vec<12>& x);

// x = (ea0, ea1, eb0, eb1)
double edge_edge_squared_distance(const Vec<12>& x);
Vec<12> edge_edge_squared_distance_gradient(const Vec<12>& x);
Mat<12> edge_edge_squared_distance_hessian(const Vec<12>& x);

}  // namespace pd
