#pragma once
// Edge-edge mollifier for nearly parallel edges (IPC, Li et al. 2020; used unchanged by C-IPC,
// Li, Kaufman & Jiang 2021).
//
// Why: as two edges turn parallel the edge-edge distance changes type (line-line is not defined for
// parallel lines, distance.h) and the line-line Hessian grows like 1/sin^2(angle). IPC multiplies
// the edge-edge barrier by a mollifier m(c) that falls smoothly to 0 as the edges turn parallel
// (m ~ 2 c / eps_x ~ sin^2), so the mollified barrier b(d) m(c) stays smooth and its derivatives
// bounded there.
//
//   c(x)  = |(ea1 - ea0) x (eb1 - eb0)|^2                         (m^4)
//   eps_x = 1e-3 |ea1_rest - ea0_rest|^2 |eb1_rest - eb0_rest|^2   (m^4, from the rest positions,
//           so it is a constant of the simulation: c / eps_x ~ 1000 sin^2(angle) for unstretched edges)
//   m(c)  = -c^2 / eps_x^2 + 2 c / eps_x   for c < eps_x,   1 otherwise   (dimensionless)
// m is C^1 at c = eps_x (m = 1, m' = 0 from both sides); m'' jumps from -2/eps_x^2 to 0 there.
// eps_x = 0 (a zero-length rest edge) gives m = 1 everywhere.
//
// Variables: x = (ea0, ea1, eb0, eb1) stacked, metres, as in distance.h. Gradients and Hessians are
// with respect to x (units: m^3 and m^2 for c, m^-1 and m^-2 for m).
#include "geometry/mesh.h"

namespace pd {

inline constexpr double kEdgeEdgeMollifierScale = 1e-3;  // the 1e-3 in eps_x (dimensionless)

// eps_x from the rest positions of the four edge vertices (m^4).
double edge_edge_mollifier_threshold(const Vec3& ea0_rest, const Vec3& ea1_rest, const Vec3& eb0_rest,
                                     const Vec3& eb1_rest);

// c = |ea x eb|^2 (m^4) and its derivatives with respect to x.
double edge_edge_cross_squared_norm(const Vec<12>& x);
Vec<12> edge_edge_cross_squared_norm_gradient(const Vec<12>& x);
Mat<12> edge_edge_cross_squared_norm_hessian(const Vec<12>& x);

// The scalar profile m(c) and its first two derivatives in c (for c >= eps_x: 1, 0, 0).
double edge_edge_mollifier_of(double c, double eps_x);
double edge_edge_mollifier_derivative_of(double c, double eps_x);
double edge_edge_mollifier_second_derivative_of(double c, double eps_x);

// True when the mollifier is below 1 (c < eps_x), i.e. when the barrier must be multiplied by it.
bool edge_edge_mollifier_active(const Vec<12>& x, double eps_x);

// m(c(x)) and its gradient and Hessian with respect to x = (ea0, ea1, eb0, eb1).
double edge_edge_mollifier(const Vec<12>& x, double eps_x);
Vec<12> edge_edge_mollifier_gradient(const Vec<12>& x, double eps_x);
Mat<12> edge_edge_mollifier_hessian(const Vec<12>& x, double eps_x);

}  // namespace pd
