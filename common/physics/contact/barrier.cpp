#include "physics/contact/barrier.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

namespace pd {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Offset squared quantity s = d^2 - xi^2 (m^2). Computed as written: d2 carries the rounding of
// the distance computation anyway, and xi^2 is exact enough next to it. Its sign is exact, so
// s <= 0 is exactly d2 <= xi^2.
double offset_squared(double d2, double xi) { return d2 - xi * xi; }

// Inactive: d2 >= (xi + dhat)^2, tested in d2 as well as in s because the rounded s of
// d2 = (xi + dhat)^2 may fall an ulp short of s_hat (and vice versa).
bool inactive(double d2, double s, double s_hat, double dhat, double xi) {
  return s >= s_hat || d2 >= barrier_active_squared_distance(dhat, xi);
}

// b''(s) on the open interval (0, s_hat), as a function of r = s_hat / s > 1.
double second_derivative_in_range(double s, double s_hat) {
  const double r = s_hat / s;
  return 2.0 * std::log(r) + r * r + 2.0 * r - 3.0;
}

}  // namespace

double barrier_activation(double dhat, double xi) {
  assert(dhat > 0.0 && xi >= 0.0);
  // (xi + dhat)^2 - xi^2 without the cancellation of the difference of squares.
  return dhat * (dhat + 2.0 * xi);
}

double barrier(double d2, double dhat, double xi) {
  const double s = offset_squared(d2, xi);
  const double s_hat = barrier_activation(dhat, xi);
  if (s <= 0.0) return kInf;
  if (inactive(d2, s, s_hat, dhat, xi)) return 0.0;
  const double diff = s - s_hat;
  return -diff * diff * std::log(s / s_hat);
}

double barrier_first_derivative(double d2, double dhat, double xi) {
  const double s = offset_squared(d2, xi);
  const double s_hat = barrier_activation(dhat, xi);
  if (s <= 0.0) return -kInf;
  if (inactive(d2, s, s_hat, dhat, xi)) return 0.0;
  return (s_hat - s) * (2.0 * std::log(s / s_hat) - s_hat / s + 1.0);
}

double barrier_second_derivative(double d2, double dhat, double xi) {
  const double s = offset_squared(d2, xi);
  const double s_hat = barrier_activation(dhat, xi);
  if (s <= 0.0) return kInf;
  if (inactive(d2, s, s_hat, dhat, xi)) return 0.0;
  return second_derivative_in_range(s, s_hat);
}

BarrierStiffnessBounds barrier_stiffness_bounds(double dhat, double xi, double bbox_diagonal,
                                                double average_mass, double h, double min_scale) {
  assert(dhat > 0.0 && xi >= 0.0 && bbox_diagonal > 0.0 && average_mass > 0.0 && h > 0.0);
  const double s_hat = barrier_activation(dhat, xi);
  // The reference gap: IPC's 1e-8 of the scene size, i.e. a contact that is already very tight.
  const double delta = 1e-8 * bbox_diagonal;          // m
  double s0 = delta * (delta + 2.0 * xi);             // (xi + delta)^2 - xi^2, m^2
  if (s0 >= s_hat) s0 = 0.5 * s_hat;                  // keep the reference inside the active range
  const double d0_squared = s0 + xi * xi;             // m^2
  // Curvature of b(d^2) along the normal per unit kappa: b''(s0) (2 d0)^2, m^2.
  const double normal_curvature = 4.0 * d0_squared * second_derivative_in_range(s0, s_hat);
  BarrierStiffnessBounds bounds;
  // (min_scale * m / h^2) is a stiffness in N/m; divided by m^2 gives J/m^4.
  bounds.kappa_min = min_scale * average_mass / (h * h * normal_curvature);
  bounds.kappa_max = 100.0 * bounds.kappa_min;
  return bounds;
}

double initial_barrier_stiffness(const Eigen::VectorXd& grad_energy,
                                 const Eigen::VectorXd& grad_barrier,
                                 const BarrierStiffnessBounds& bounds) {
  assert(grad_energy.size() == grad_barrier.size());
  const double gb2 = grad_barrier.squaredNorm();
  // No active contact: nothing to balance, start as soft as allowed.
  if (!(gb2 > 0.0)) return bounds.kappa_min;
  // d/dkappa ||gE + kappa gB||^2 = 0  =>  kappa = -gE.gB / gB.gB (negative when the barrier
  // already pushes along the energy's descent: then the clamp takes kappa_min).
  const double kappa = -grad_energy.dot(grad_barrier) / gb2;
  return std::clamp(kappa, bounds.kappa_min, bounds.kappa_max);
}

double update_barrier_stiffness(double prev_min_gap, double min_gap, double dhat, double kappa,
                                double kappa_max, double gap_fraction) {
  const double eps = gap_fraction * dhat;  // m
  // min_gap < prev_min_gap < eps also gives min_gap < eps, IPC's second condition.
  if (prev_min_gap < eps && min_gap < prev_min_gap && kappa < kappa_max)
    return std::min(2.0 * kappa, kappa_max);
  return kappa;
}

}  // namespace pd
