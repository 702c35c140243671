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
//
// Classification rule (point_triangle_type, edge_edge_type). Both problems minimise a convex
// quadratic over a convex parameter set (the triangle's barycentric simplex, the unit square of the
// two edge parameters), so:
//  1. If the unconstrained minimiser lies in the set, the interior type is the answer (P_T, EA_EB).
//     This is tested only when the two spanning vectors are not (nearly) parallel:
//       |u x v|^2 > kParallelSin2Threshold |u|^2 |v|^2     (sin^2 of their angle, dimensionless),
//     u, v = (t1 - t0, t2 - t0) for the triangle, (ea1 - ea0, eb1 - eb0) for the edges. Below it the
//     plane / line-line formula divides by ~0 and is skipped: a zero-area triangle is its boundary,
//     and parallel edges always have an endpoint among their closest points (so an endpoint case is
//     chosen, whichever orientation, parallel or anti-parallel, the edges have).
//  2. Otherwise the minimum is on the boundary of the set, i.e. on one of the triangle's three edges,
//     or at an endpoint of one edge against the other segment (four candidates). Each candidate is a
//     point-segment problem whose clamped parameter gives endpoint or interior; the smallest squared
//     distance wins (ties: the first candidate in the order t-edges 0,1,2 / ea0, ea1, eb0, eb1).
//     A zero-length segment always gives its endpoint, so zero-length edges and coincident points
//     never reach a formula that divides by their length.
// The squared distance is continuous in the positions (types switch where their formulas agree),
// except at the parallel threshold of step 1: a triangle or edge pair with sin^2 <= 1e-14 whose
// interior minimiser lies inside is given its boundary distance instead, larger by at most about
// 1e-7 * (edge length) in distance. (C-IPC's edge-edge mollifier, edge_edge_mollifier.h, switches the
// edge-edge barrier off smoothly long before that, at sin^2 < 1e-3 relative to the rest edges.)
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

// ---- Additions ------------------------------------------------------------------------------

// sin^2 of the angle between two spanning vectors below which they count as parallel (see above).
inline constexpr double kParallelSin2Threshold = 1e-14;

// The same classification from the stacked vectors above.
PointTriangleType point_triangle_type(const Vec<12>& x);  // x = (p, t0, t1, t2)
EdgeEdgeType edge_edge_type(const Vec<12>& x);            // x = (ea0, ea1, eb0, eb1)
const char* to_string(PointTriangleType type);
const char* to_string(EdgeEdgeType type);

// The smooth function of a given type (no classification), scattered into the 12 variables of the
// stacked vector; entries of vertices the type does not involve are zero. For callers that
// classify once and evaluate several times, and for tests that compare types at their boundaries.
double point_triangle_squared_distance(const Vec<12>& x, PointTriangleType type);
Vec<12> point_triangle_squared_distance_gradient(const Vec<12>& x, PointTriangleType type);
Mat<12> point_triangle_squared_distance_hessian(const Vec<12>& x, PointTriangleType type);
double edge_edge_squared_distance(const Vec<12>& x, EdgeEdgeType type);
Vec<12> edge_edge_squared_distance_gradient(const Vec<12>& x, EdgeEdgeType type);
Mat<12> edge_edge_squared_distance_hessian(const Vec<12>& x, EdgeEdgeType type);

// Per-type smooth squared distances (m^2), gradients (m) and Hessians (dimensionless), each in the
// variable order of its arguments. These are exact for every input where they are defined; the
// classification above only calls them where they equal the distance between the primitives.
//   point-point (p, q):                   |p - q|^2
double point_point_squared_distance(const Vec3& p, const Vec3& q);
Vec<6> point_point_squared_distance_gradient(const Vec3& p, const Vec3& q);
Mat<6> point_point_squared_distance_hessian(const Vec3& p, const Vec3& q);
//   point-line (p, e0, e1), infinite line through e0, e1 (requires e0 != e1):
//                                         |(p - e0) x (e1 - e0)|^2 / |e1 - e0|^2
double point_line_squared_distance(const Vec3& p, const Vec3& e0, const Vec3& e1);
Vec<9> point_line_squared_distance_gradient(const Vec3& p, const Vec3& e0, const Vec3& e1);
Mat<9> point_line_squared_distance_hessian(const Vec3& p, const Vec3& e0, const Vec3& e1);
//   point-plane (p, t0, t1, t2), plane through the triangle (requires a nonzero normal):
//                                         ((p - t0) . n)^2 / |n|^2,  n = (t1 - t0) x (t2 - t0)
double point_plane_squared_distance(const Vec3& p, const Vec3& t0, const Vec3& t1, const Vec3& t2);
Vec<12> point_plane_squared_distance_gradient(const Vec3& p, const Vec3& t0, const Vec3& t1,
                                              const Vec3& t2);
Mat<12> point_plane_squared_distance_hessian(const Vec3& p, const Vec3& t0, const Vec3& t1,
                                             const Vec3& t2);
//   line-line (ea0, ea1, eb0, eb1), infinite lines (requires non-parallel edges):
//                                         ((ea0 - eb0) . n)^2 / |n|^2,  n = (ea1 - ea0) x (eb1 - eb0)
double line_line_squared_distance(const Vec3& ea0, const Vec3& ea1, const Vec3& eb0, const Vec3& eb1);
Vec<12> line_line_squared_distance_gradient(const Vec3& ea0, const Vec3& ea1, const Vec3& eb0,
                                            const Vec3& eb1);
Mat<12> line_line_squared_distance_hessian(const Vec3& ea0, const Vec3& ea1, const Vec3& eb0,
                                           const Vec3& eb1);

}  // namespace pd
