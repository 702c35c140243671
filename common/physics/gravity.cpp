#include "physics/gravity.h"

#include <stdexcept>
#include <string>

namespace pd {

GravityTerm::GravityTerm(const Eigen::VectorXd& masses, const Vec3& g) : gradient_(masses.size()) {
  if (masses.size() % 3 != 0)
    throw std::invalid_argument("GravityTerm: masses has " + std::to_string(masses.size()) +
                                " entries, not one per dof (3 per vertex)");
  for (Eigen::Index i = 0; i < masses.size(); ++i) gradient_[i] = -masses[i] * g[i % 3];
}

// -sum m g . x = gradient . x, since the potential is linear and zero at x = 0.
double GravityTerm::value(const Eigen::VectorXd& x) const { return gradient_.dot(x); }

void GravityTerm::add_gradient(const Eigen::VectorXd& /*x*/, Eigen::VectorXd& grad) const {
  grad += gradient_;
}

}  // namespace pd
