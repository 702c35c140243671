#include "physics/contact/ground_barrier.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "physics/contact/barrier.h"

namespace pd {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Two orthonormal vectors perpendicular to the unit vector n. Crossing n with the coordinate axis it
// is least aligned with keeps the cross product well away from zero (|n x e| >= sqrt(2/3)).
Eigen::Matrix<double, 3, 2> tangent_basis_of(const Vec3& n) {
  int k = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(n[i]) < std::abs(n[k])) k = i;
  const Vec3 t1 = n.cross(Vec3::Unit(k)).normalized();
  Eigen::Matrix<double, 3, 2> T;
  T.col(0) = t1;
  T.col(1) = n.cross(t1);  // unit: n and t1 are orthonormal
  return T;
}

}  // namespace

GroundBarrier::GroundBarrier(std::vector<int> vertices, const Vec3& normal, double height,
                             const ContactSettings& settings, double mu)
    : vertices_(std::move(vertices)), height_(height), settings_(settings), mu_(mu) {
  const double length = normal.norm();
  if (!normal.allFinite() || !(length > 0.0) || !std::isfinite(length))
    throw std::invalid_argument("GroundBarrier: the normal must be finite and non-zero");
  if (!std::isfinite(height)) throw std::invalid_argument("GroundBarrier: the height must be finite");
  if (!(settings_.dhat > 0.0) || !std::isfinite(settings_.dhat) || !(settings_.offset >= 0.0) ||
      !std::isfinite(settings_.offset) || !(settings_.kappa >= 0.0))
    throw std::invalid_argument("GroundBarrier: need dhat > 0, offset >= 0, kappa >= 0 (finite)");
  if (!(mu_ >= 0.0) || !std::isfinite(mu_))
    throw std::invalid_argument("GroundBarrier: the friction coefficient must be finite and >= 0");
  for (int v : vertices_)
    if (v < 0) throw std::invalid_argument("GroundBarrier: negative vertex id " + std::to_string(v));
  // Sorted and unique: a duplicate would double the barrier of that vertex, and ascending ids make
  // every output (friction contacts, vertices_below) come out in a fixed order.
  std::sort(vertices_.begin(), vertices_.end());
  vertices_.erase(std::unique(vertices_.begin(), vertices_.end()), vertices_.end());
  normal_ = normal / length;
  tangents_ = tangent_basis_of(normal_);
}

double GroundBarrier::signed_distance(const Eigen::VectorXd& x, int v) const {
  if (3 * static_cast<Eigen::Index>(v) + 2 >= x.size())
    throw std::out_of_range("GroundBarrier: vertex " + std::to_string(v) + " is not in the positions");
  return normal_.dot(x.segment<3>(3 * v)) - height_;
}

template <class F>
void GroundBarrier::for_each_near_vertex(const Eigen::VectorXd& x, F&& f) const {
  const double reach = settings_.offset + settings_.dhat;  // d below which the barrier acts, m
  for (int v : vertices_) {
    const double d = signed_distance(x, v);
    if (d < reach) f(v, d);
  }
}

double GroundBarrier::value(const Eigen::VectorXd& x) const {
  const double dhat = settings_.dhat, xi = settings_.offset;
  double e = 0.0;
  bool infeasible = false;
  for_each_near_vertex(x, [&](int, double d) {
    // Tested on d itself: below the plane d^2 grows again and would read as "far away".
    if (d <= xi)
      infeasible = true;
    else
      e += barrier(d * d, dhat, xi);
  });
  return infeasible ? kInf : settings_.kappa * e;
}

Eigen::VectorXd GroundBarrier::unit_stiffness_gradient(const Eigen::VectorXd& x) const {
  const double dhat = settings_.dhat, xi = settings_.offset;
  Eigen::VectorXd g = Eigen::VectorXd::Zero(x.size());
  for_each_near_vertex(x, [&](int v, double d) {
    // d(d^2)/dx_v = 2 d n. An infeasible vertex gets b'(0) = -inf: a non-finite gradient, as the
    // mesh barrier gives for a pair within its offset.
    const double db = barrier_first_derivative(d > xi ? d * d : 0.0, dhat, xi);
    g.segment<3>(3 * v) += (db * 2.0 * d) * normal_;
  });
  return g;
}

void GroundBarrier::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  if (settings_.kappa == 0.0) return;
  grad += settings_.kappa * unit_stiffness_gradient(x);
}

void GroundBarrier::add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                                HessianAssembly& hessian) const {
  const double dhat = settings_.dhat, xi = settings_.offset, kappa = settings_.kappa;
  for_each_near_vertex(x, [&](int v, double d) {
    const double d2 = d > xi ? d * d : 0.0;
    const double db = barrier_first_derivative(d2, dhat, xi);
    const double ddb = barrier_second_derivative(d2, dhat, xi);
    // d^2 has gradient 2 d n and Hessian 2 n n^T, so b(d^2) has Hessian (4 d^2 b'' + 2 b') n n^T.
    // The coefficient is the curvature of b(d^2) as a function of d; sampled over the whole active
    // range for offset / dhat from 0 to 1e3 it stayed positive (b' < 0 never outweighs 4 d^2 b''),
    // so the projection normally returns the block unchanged; it is applied anyway, as the caller asks.
    const Mat3 H = (kappa * (4.0 * d2 * ddb + 2.0 * db)) * (normal_ * normal_.transpose());
    hessian.add<1>({v}, project_hessian<3>(H, projection));
  });
}

double GroundBarrier::max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const {
  if (dx.size() != x.size()) throw std::invalid_argument("GroundBarrier::max_step: x and dx differ in size");
  // The fraction of the remaining gap a step may consume, clamped as ACCD clamps its ratio.
  const double eta = std::clamp(settings_.ccd_ratio, 0.01, 0.99);
  double alpha = 1.0;
  for (int v : vertices_) {
    const double gap = signed_distance(x, v) - settings_.offset;  // m
    const double rate = -normal_.dot(dx.segment<3>(3 * v));      // approach speed, m per unit alpha
    if (!std::isfinite(gap) || !std::isfinite(rate) || !(gap > 0.0)) return 0.0;
    // The gap at alpha is gap - alpha * rate; keeping it >= (1 - eta) gap bounds alpha by eta gap / rate.
    if (rate > 0.0) alpha = std::min(alpha, eta * gap / rate);
  }
  return alpha;
}

void GroundBarrier::friction_contacts(const Eigen::VectorXd& x, std::vector<FrictionContact>& out) const {
  if (!(mu_ > 0.0)) return;  // FrictionSource reports only contacts with a positive coefficient
  const double dhat = settings_.dhat, xi = settings_.offset;
  for_each_near_vertex(x, [&](int v, double d) {
    if (d <= xi) return;  // infeasible: no finite normal force to lag
    FrictionContact c;
    c.vertices = {v, -1, -1, -1};
    c.count = 1;
    c.weights = {1.0, 0.0, 0.0, 0.0};  // the ground does not move: u = T^T (x_v - x_v^t)
    c.basis = tangents_;
    // lambda = |dE_g/dd| = -kappa b'(d^2) 2 d (b' <= 0 on the active range), N.
    c.normal_force = -settings_.kappa * barrier_first_derivative(d * d, dhat, xi) * 2.0 * d;
    c.mu = mu_;
    out.push_back(c);
  });
}

ContactStats GroundBarrier::stats(const Eigen::VectorXd& x) const {
  ContactStats s;
  s.min_gap = kInf;
  for (int v : vertices_) {
    const double gap = signed_distance(x, v) - settings_.offset;
    s.min_gap = std::min(s.min_gap, gap);
    if (gap > 0.0 && gap < settings_.dhat) ++s.active_point_triangle;
  }
  return s;
}

std::vector<int> GroundBarrier::vertices_below(const Eigen::VectorXd& x) const {
  std::vector<int> out;
  for (int v : vertices_)
    if (signed_distance(x, v) <= settings_.offset) out.push_back(v);
  return out;
}

}  // namespace pd
