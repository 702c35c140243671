#pragma once
// A guide: a mass-weighted spring pulling every vertex toward a target state,
//   E(x) = 1/2 w sum_dof m_dof (x_dof - y_dof)^2 / h^2          (J)
// with m the lumped masses (kg per dof), y the target (m), h the time step (s) and w >= 0 a
// dimensionless weight: w = 1 is as stiff as the inertia term (M / h^2).
//
// Why: stitching two time subsets of a refinement level (progressive/level_task.h, "stitch"). The
// later subset's frames y(t) are solutions of the level's own step problems, which (PD eq. 5) do not
// depend on the level's own past: y(t + 1) is a stationary point of the step energy whatever
// branch the earlier subset is on, and so of the step energy plus this guide toward y(t + 1) at
// any weight. Ramping w from 0 to large over a few frames therefore carries the earlier subset's
// trajectory into the later one's through the level's own dynamics and contact (every iterate
// intersection-free), instead of blending positions.
//
// Convex and separable: the Hessian is the constant diagonal w M / h^2 (no projection needed).
// Units: energy J, gradient N, Hessian N/m.
#include <Eigen/Core>

#include "physics/energy_term.h"

namespace pd {

class GuideTerm : public EnergyTerm {
 public:
  // masses: per dof, kg (size 3n); std::invalid_argument for a size that is not a multiple of 3 or a
  // negative or non-finite mass. Starts with weight 0 (no force) and the target unset.
  explicit GuideTerm(Eigen::VectorXd masses);

  std::string name() const override { return "guide"; }

  // Require begin_step() (for h; std::logic_error otherwise) and x of the masses' size
  // (std::invalid_argument). With weight 0: value 0, nothing added.
  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection, HessianAssembly& hessian) const override;

  // Takes h from the step (std::invalid_argument for h <= 0).
  void begin_step(const StepStart& step) override;
  // The target y (m, size 3n) and weight w (finite, >= 0) for the steps that follow, until set again.
  // std::invalid_argument otherwise.
  void set_guide(const Eigen::VectorXd& target, double weight);
  // The weight alone, the target kept (finite, >= 0; std::invalid_argument otherwise).
  void set_weight(double weight);

  double weight() const { return weight_; }

 private:
  void check_state(const Eigen::VectorXd& x) const;

  Eigen::VectorXd masses_;  // kg per dof
  Eigen::VectorXd target_;  // y, m (empty until set)
  double weight_ = 0.0;
  double h_ = 0.0;          // s, from begin_step
};

}  // namespace pd
