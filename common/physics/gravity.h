#pragma once
// Gravity: potential  -sum_i m_i g . x_i  (J), with m_i the lumped vertex masses.
//
// The potential is linear in x, so its gradient -M g is constant and its Hessian is zero:
// add_hessian adds nothing (not even zeros, which would only grow the sparsity pattern).
#include <Eigen/Core>

#include "geometry/mesh.h"
#include "physics/energy_term.h"

namespace pd {

class GravityTerm : public EnergyTerm {
 public:
  // masses: per dof, kg (as lumped_masses returns, size 3n; std::invalid_argument otherwise);
  // g: acceleration, m/s^2.
  GravityTerm(const Eigen::VectorXd& masses, const Vec3& g);

  std::string name() const override { return "gravity"; }

  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  void add_hessian(const Eigen::VectorXd& /*x*/, HessianProjection /*projection*/,
                   HessianAssembly& /*hessian*/) const override {}

  // The (constant) gradient -M g, N per dof; minus the gravity force on each dof.
  const Eigen::VectorXd& gradient() const { return gradient_; }

 private:
  Eigen::VectorXd gradient_;  // -m_i g_k at dof 3i+k, N
};

}  // namespace pd
