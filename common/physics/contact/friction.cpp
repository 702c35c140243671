#include "physics/contact/friction.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <stdexcept>

#include "geometry/mesh.h"

namespace pd {

double friction_f0(double y, double eps_u) {
  if (y >= eps_u) return y;
  return -y * y * y / (3.0 * eps_u * eps_u) + y * y / eps_u + eps_u / 3.0;
}

double friction_f1(double y, double eps_u) {
  if (y >= eps_u) return 1.0;
  return -y * y / (eps_u * eps_u) + 2.0 * y / eps_u;
}

// f1(y)/y written without the division, so that it is finite (2/eps_u) at y = 0.
double friction_f1_over_y(double y, double eps_u) {
  if (y >= eps_u) return 1.0 / y;
  return -y / (eps_u * eps_u) + 2.0 / eps_u;
}

namespace {

// d2D/du2 / (mu lambda) = f1/y I + (f1/y)'/y u u^T, 1/m. The second term, written per branch so that
// it has no 1/|u| at u = 0:
//   |u| <  eps_u: (f1/y)' = -1/eps_u^2  ->  -u u^T / (eps_u^2 |u|)  (-> 0 as u -> 0)
//   |u| >= eps_u: (f1/y)' = -1/y^2      ->  -u u^T / |u|^3
Eigen::Matrix2d unit_hessian_in_u(const Eigen::Vector2d& u, double eps_u) {
  const double y = u.norm();
  Eigen::Matrix2d H = friction_f1_over_y(y, eps_u) * Eigen::Matrix2d::Identity();
  if (y > 0.0) {
    const double c = y < eps_u ? -1.0 / (eps_u * eps_u * y) : -1.0 / (y * y * y);
    H += c * u * u.transpose();
  }
  return H;
}

}  // namespace

FrictionTerm::FrictionTerm(double eps_v) : eps_v_(eps_v) {
  if (!(eps_v > 0.0) || !std::isfinite(eps_v))
    throw std::invalid_argument("FrictionTerm: eps_v must be > 0 and finite (m/s)");
}

void FrictionTerm::add_source(const FrictionSource* source) {
  if (!source) throw std::invalid_argument("FrictionTerm: null friction source");
  sources_.push_back(source);
}

void FrictionTerm::begin_step(const StepStart& step) {
  if (!step.x || !(step.h > 0.0))
    throw std::invalid_argument("FrictionTerm::begin_step: need positions and h > 0");
  x_start_ = *step.x;
  h_ = step.h;
  contacts_.clear();
  for (const FrictionSource* s : sources_) s->friction_contacts(x_start_, contacts_);
  // A malformed contact would index outside x below; sources are code, so this is a logic error.
  const int n = static_cast<int>(x_start_.size() / 3);
  for (const FrictionContact& c : contacts_) {
    if (c.count < 1 || c.count > 4) throw std::logic_error("FrictionTerm: contact stencil size not in 1..4");
    for (int k = 0; k < c.count; ++k)
      if (c.vertices[k] < 0 || c.vertices[k] >= n) throw std::logic_error("FrictionTerm: contact vertex out of range");
  }
}

Eigen::Vector2d FrictionTerm::tangential_displacement(const FrictionContact& c, const Eigen::VectorXd& x) const {
  Vec3 dx = Vec3::Zero();  // sum_k w_k (x_k - x_k^t), m
  for (int k = 0; k < c.count; ++k) {
    const int v = c.vertices[k];
    dx += c.weights[k] * (x.segment<3>(3 * v) - x_start_.segment<3>(3 * v));
  }
  return c.basis.transpose() * dx;
}

double FrictionTerm::max_tangential_step(const Eigen::VectorXd& p) const {
  assert(contacts_.empty() || p.size() == x_start_.size());
  double worst = 0.0;
  for (const FrictionContact& c : contacts_) {
    Vec3 dp = Vec3::Zero();
    for (int k = 0; k < c.count; ++k) dp += c.weights[k] * p.segment<3>(3 * c.vertices[k]);
    worst = std::max(worst, (c.basis.transpose() * dp).norm());
  }
  return worst;
}

double FrictionTerm::value(const Eigen::VectorXd& x) const {
  assert(contacts_.empty() || x.size() == x_start_.size());
  const double eps_u = this->eps_u();
  double D = 0.0;
  for (const FrictionContact& c : contacts_)
    D += c.mu * c.normal_force * friction_f0(tangential_displacement(c, x).norm(), eps_u);
  return D;
}

void FrictionTerm::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  assert(contacts_.empty() || x.size() == x_start_.size());
  const double eps_u = this->eps_u();
  for (const FrictionContact& c : contacts_) {
    const Eigen::Vector2d u = tangential_displacement(c, x);
    // dD/du = mu lambda f1(|u|)/|u| u (N); the friction force on vertex k is -w_k T dD/du.
    const Vec3 g = c.basis * (c.mu * c.normal_force * friction_f1_over_y(u.norm(), eps_u) * u);
    for (int k = 0; k < c.count; ++k) grad.segment<3>(3 * c.vertices[k]) += c.weights[k] * g;
  }
}

// Element Hessian Gamma H_u Gamma^T with Gamma (3N x 2) = du^T/dx_stencil, block k = w_k T.
template <int N>
void FrictionTerm::add_contact_hessian(const FrictionContact& c, const Eigen::Matrix2d& H_u,
                                       HessianAssembly& hessian) const {
  Eigen::Matrix<double, 3 * N, 2> gamma;
  std::array<int, N> verts;
  for (int k = 0; k < N; ++k) {
    gamma.template block<3, 2>(3 * k, 0) = c.weights[k] * c.basis;
    verts[k] = c.vertices[k];
  }
  const Mat<3 * N> H = gamma * H_u * gamma.transpose();
  hessian.add<N>(verts, H);
}

void FrictionTerm::add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                               HessianAssembly& hessian) const {
  assert(contacts_.empty() || x.size() == x_start_.size());
  const double eps_u = this->eps_u();
  for (const FrictionContact& c : contacts_) {
    const Eigen::Vector2d u = tangential_displacement(c, x);
    // Projecting the 2x2 H_u is enough: for any v, v^T Gamma H_u Gamma^T v = (Gamma^T v)^T H_u
    // (Gamma^T v) >= 0 when H_u is PSD, so the lifted element Hessian is PSD too, at the cost of a
    // 2x2 instead of a 12x12 eigenproblem. With IPC's f0, H_u is in fact PSD in exact arithmetic
    // (eigenvalues mu lambda f1'(|u|) >= 0 along u and mu lambda f1(|u|)/|u| > 0 across it, i.e.
    // D is convex in x), so the projection only removes round-off.
    const Eigen::Matrix2d H_u =
        project_hessian<2>(Eigen::Matrix2d(c.mu * c.normal_force * unit_hessian_in_u(u, eps_u)), projection);
    switch (c.count) {
      case 1: add_contact_hessian<1>(c, H_u, hessian); break;
      case 2: add_contact_hessian<2>(c, H_u, hessian); break;
      case 3: add_contact_hessian<3>(c, H_u, hessian); break;
      case 4: add_contact_hessian<4>(c, H_u, hessian); break;
      default: assert(false && "stencil size checked in begin_step");
    }
  }
}

}  // namespace pd
