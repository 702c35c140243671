#pragma once
// IPC log barrier on squared distances, with the thickness offset of codimensional IPC (C-IPC; Li,
// Kaufman & Jiang 2021), and IPC's adaptive barrier stiffness (Li et al. 2020, supplement).
//
// Formula (C-IPC convention). Contact happens at distance xi >= 0 from the mid-surfaces (xi is the
// thickness offset, m). The barrier is IPC's clamped log barrier applied to the offset squared
// quantity s = d^2 - xi^2 (m^2), with its activation value s_hat the s at distance xi + dhat:
//
//   s     = d^2 - xi^2                               (m^2)
//   s_hat = (xi + dhat)^2 - xi^2 = dhat^2 + 2 xi dhat (m^2)
//   b(s)  = -(s - s_hat)^2 ln(s / s_hat)   for 0 < s < s_hat      (m^4)
//   b     = 0                              for s >= s_hat  (d >= xi + dhat: inactive)
//   b     = +infinity                      for s <= 0      (d <= xi: at or inside the offset)
//
// so the barrier activates when the *gap* d - xi drops below dhat, and diverges when the gap
// reaches zero. Why on squared quantities rather than on the gap d - xi itself: d^2 - xi^2 =
// (d - xi)(d + xi) vanishes exactly where d - xi does, and d^2 is what distance.h differentiates
// (d = sqrt(d^2) has a singular derivative where d^2 = 0, e.g. xi = 0 contact), so no square root
// enters the barrier's derivatives. This is the form C-IPC's reference implementation evaluates
// (barrier of dist2 - xi^2 with activation dhat^2 + 2 xi dhat); with xi = 0 it is IPC's
// b(d^2, dhat^2).
//
// Derivatives are taken with respect to d^2 (ds/d(d^2) = 1), so a caller chains them with the
// squared-distance gradient/Hessian of distance.h:
//   b'(s)  = (s_hat - s) (2 ln(s / s_hat) - s_hat / s + 1)           (m^2)
//   b''(s) = 2 ln(r) + r^2 + 2 r - 3,   r = s_hat / s                (dimensionless)
// b, b' and b'' all vanish at s = s_hat, so the clamped barrier is C^2 there; b' < 0 and b'' > 0 on
// (0, s_hat) (monotone decreasing, convex in s).
//
// Units: with the contact energy E_c = kappa * sum_k b(d_k^2) in joules, kappa is in J/m^4.
#include <Eigen/Core>

namespace pd {

// s_hat = dhat^2 + 2 xi dhat (m^2): the value of d^2 - xi^2 at which the barrier switches on.
double barrier_activation(double dhat, double xi);

// d^2 below which the barrier is active: (xi + dhat)^2, m^2 (use it to cull candidate pairs).
inline double barrier_active_squared_distance(double dhat, double xi) {
  return (xi + dhat) * (xi + dhat);
}

// d2: squared distance between the two primitives' mid-surfaces (m^2); dhat > 0 (m); xi >= 0 (m).
// Value b (m^4): 0 for d2 >= (xi + dhat)^2, +infinity for d2 <= xi^2.
double barrier(double d2, double dhat, double xi);
// db/d(d2) (m^2): 0 for d2 >= (xi + dhat)^2; -infinity (its limit) for d2 <= xi^2.
double barrier_first_derivative(double d2, double dhat, double xi);
// d^2 b/d(d2)^2 (dimensionless): 0 for d2 >= (xi + dhat)^2; +infinity (its limit) for d2 <= xi^2.
// Infinite derivatives only occur if a solver steps into an infeasible state, which ACCD prevents.
double barrier_second_derivative(double d2, double dhat, double xi);

// ---- Adaptive stiffness (IPC supplement, Sec. "Adaptive barrier stiffness") ----
//
// This library's incremental potential is in joules (inertia is (x - xhat)^T M (x - xhat) / 2h^2),
// whereas IPC states its rule for the potential multiplied by h^2. The bounds below therefore take
// the time step h and divide IPC's mass term by h^2; kappa comes out in J/m^4 as above.
struct BarrierStiffnessBounds {
  double kappa_min = 0.0;  // J/m^4
  double kappa_max = 0.0;  // J/m^4, = 100 kappa_min (IPC)
};

// kappa_min makes the barrier's curvature along the contact normal, at a gap of
// delta = 1e-8 * bbox_diagonal, equal to min_scale * average_mass / h^2 (N/m):
//   kappa_min = min_scale * m_avg / (h^2 * 4 (xi + delta)^2 * b''(s0)),  s0 = (xi + delta)^2 - xi^2
// since d2 = d^2 has gradient 2 d n, so d^2/dx^2 of b(d^2) along n is b'' (2 d)^2 + 2 b' and IPC
// keeps only the first term. If s0 >= s_hat (dhat tiny against the scene), s0 = s_hat / 2.
// dhat, xi, bbox_diagonal in m; average_mass in kg (mean lumped vertex mass); h in s;
// min_scale dimensionless (IPC uses 1e11).
BarrierStiffnessBounds barrier_stiffness_bounds(double dhat, double xi, double bbox_diagonal,
                                                double average_mass, double h,
                                                double min_scale = 1e11);

// Initial kappa: the minimiser of ||grad_energy + kappa * grad_barrier||, i.e.
//   kappa = -grad_energy . grad_barrier / ||grad_barrier||^2,
// clamped to [kappa_min, kappa_max]; kappa_min when grad_barrier is zero (no active contact).
// grad_energy: gradient of the incremental potential without contact, J/m (N);
// grad_barrier: gradient of sum_k b(d_k^2) (kappa not applied), m^3. Both over the same dofs.
double initial_barrier_stiffness(const Eigen::VectorXd& grad_energy,
                                 const Eigen::VectorXd& grad_barrier,
                                 const BarrierStiffnessBounds& bounds);

// Update after a Newton iteration / time step (IPC): doubles kappa, capped at kappa_max, when the
// smallest gap keeps decreasing while already below gap_fraction * dhat:
//   prev_min_gap < eps  and  min_gap < prev_min_gap,   eps = gap_fraction * dhat.
// Otherwise (or if kappa >= kappa_max already) kappa is returned unchanged. Gaps are
// min over contact pairs of (d - xi), m; dhat m. The default 1e-6 matches IPC's eps = 1e-9 * bbox
// diagonal at its default dhat = 1e-3 * bbox diagonal.
double update_barrier_stiffness(double prev_min_gap, double min_gap, double dhat, double kappa,
                                double kappa_max, double gap_fraction = 1e-6);

}  // namespace pd
