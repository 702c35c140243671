#pragma once
// Inertia term of the incremental potential, lumped masses, kinetic energy.
//
// Implicit Euler is the minimisation of
//   IP(x) = 1/(2 h^2) (x - xhat)^T M (x - xhat) + sum of potentials,   xhat = x_start + h v_start,
// and this term is the first part. M is the lumped (diagonal) mass matrix, one entry per dof.
#include <Eigen/Core>

#include "geometry/mesh.h"
#include "physics/energy_term.h"

namespace pd {

// Per-dof lumped masses (kg, size 3 * rest.rows()): each triangle's mass mass_per_area * area (area
// from the rest shape, m^2; mass_per_area in kg/m^2) is split equally between its three vertices,
// and each vertex's mass is repeated for its x, y and z dofs. Lumping keeps M diagonal, so the
// inertia Hessian M / h^2 costs nothing to assemble and to factor alongside the rest.
Eigen::VectorXd lumped_masses(const Faces& F, const Positions& rest, double mass_per_area);

// 1/2 v^T M v for per-dof masses (kg) and stacked velocities (m/s); J.
double kinetic_energy(const Eigen::VectorXd& masses, const Eigen::VectorXd& v);

class InertiaTerm : public EnergyTerm {
 public:
  // masses: per dof, kg, over every vertex of the scene (size 3n). Pinned dofs keep their masses;
  // the solver removes them from the system. Throws std::invalid_argument for a size that is not a
  // multiple of 3 or a negative or non-finite mass.
  explicit InertiaTerm(Eigen::VectorXd masses);

  std::string name() const override { return "inertia"; }

  // Require begin_step() to have been called (h and xhat come from it; std::logic_error otherwise)
  // and x of the masses' size (std::invalid_argument). J.
  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  // Diagonal M / h^2: positive, so no projection is ever needed whatever `projection` says.
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                   HessianAssembly& hessian) const override;

  // xhat = x_start + h v_start: where the vertices would go with no forces at all. Throws
  // std::invalid_argument for h <= 0, missing or wrongly sized positions or velocities.
  void begin_step(const StepStart& step) override;
  // Replaces xhat for the current step (after begin_step): progressive refinement's momentum comes
  // from the level below (PD eq. 5), not from this level's own x_start + h v_start. Size 3n, m.
  void set_predicted_positions(const Eigen::VectorXd& xhat);

  const Eigen::VectorXd& masses() const { return masses_; }
  const Eigen::VectorXd& predicted_positions() const { return xhat_; }  // xhat, m

 private:
  Eigen::VectorXd masses_;          // kg per dof
  Eigen::VectorXd mass_over_h2_;    // M / h^2, kg/s^2, cached per step for add_hessian
  Eigen::VectorXd xhat_;            // m
  double h_ = 0.0;                  // s
  void check_state(const Eigen::VectorXd& x) const;
};

}  // namespace pd
