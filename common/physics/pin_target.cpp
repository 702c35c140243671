#include "physics/pin_target.h"

#include <algorithm>
#include <stdexcept>

namespace pd {

PinTargetTerm::PinTargetTerm(std::vector<int> vertices) : vertices_(std::move(vertices)) {
  lambda_.assign(vertices_.size(), Vec3::Zero());
}

void PinTargetTerm::activate(const Eigen::VectorXd& targets, double k) {
  if (!(k > 0)) throw std::invalid_argument("PinTargetTerm::activate: need k > 0");
  targets_ = targets;
  k_ = k;
  std::fill(lambda_.begin(), lambda_.end(), Vec3::Zero());
  active_ = true;
}

double PinTargetTerm::value(const Eigen::VectorXd& x) const {
  if (!active_) return 0.0;
  double e = 0.0;
  for (size_t j = 0; j < vertices_.size(); ++j) {
    const Vec3 d = x.segment<3>(3 * vertices_[j]) - targets_.segment<3>(3 * vertices_[j]);
    e += 0.5 * k_ * d.squaredNorm() - lambda_[j].dot(d);
  }
  return e;
}

void PinTargetTerm::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  if (!active_) return;
  for (size_t j = 0; j < vertices_.size(); ++j) {
    const int v = vertices_[j];
    grad.segment<3>(3 * v) += k_ * (x.segment<3>(3 * v) - targets_.segment<3>(3 * v)) - lambda_[j];
  }
}

void PinTargetTerm::add_hessian(const Eigen::VectorXd& /*x*/, HessianProjection /*projection*/,
                                HessianAssembly& hessian) const {
  if (!active_) return;
  const Mat3 H = k_ * Mat3::Identity();
  for (int v : vertices_) hessian.add<1>({v}, H);
}

void PinTargetTerm::update_multipliers(const Eigen::VectorXd& x) {
  for (size_t j = 0; j < vertices_.size(); ++j) {
    const int v = vertices_[j];
    lambda_[j] -= k_ * (x.segment<3>(3 * v) - targets_.segment<3>(3 * v));
  }
}

double PinTargetTerm::max_distance(const Eigen::VectorXd& x) const {
  double d = 0.0;
  for (int v : vertices_) d = std::max(d, (x.segment<3>(3 * v) - targets_.segment<3>(3 * v)).norm());
  return d;
}

}  // namespace pd
