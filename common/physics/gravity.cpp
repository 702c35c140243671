#include "physics/gravity.h"

#include <cassert>

namespace pd {

GravityTerm::GravityTerm(const Eigen::VectorXd& masses, const Vec3& g) : gradient_(masses.size()) {
  assert(masses.size() % 3 == 0);
  for (Eigen::Index i = 0; i < masses.size(); ++i) gradient_[i] = -masses[i] * g[i % 3];
}

// -sum m g . x = gradient . x, since the potential is linear and zero at x = 0.
double GravityTerm::value(const Eigen::VectorXd& x) const { return gradient_.dot(x); }

void GravityTerm::add_gradient(const Eigen::VectorXd& /*x*/, Eigen::VectorXd& grad) const {
  grad += gradient_;
}

}  // namespace pd
