#pragma once
// Augmented-Lagrangian pull of scripted (pinned) vertices toward their targets, for the part of a
// step where moving pins cannot simply jump to their scripted positions because contact is in the
// way (IPC, Li et al. 2020, Sec. 4.4 "kinematic collision objects"). While active, the pinned
// vertices are free unknowns and this term adds, per pinned vertex i with target t_i (m),
//   E = sum_i  k/2 |x_i - t_i|^2 - lambda_i . (x_i - t_i)            (J)
// with penalty stiffness k (N/m) and multipliers lambda_i (N). The step alternates Newton solves
// with the multiplier update lambda_i <- lambda_i - k (x_i - t_i) (or a larger k when progress
// stalls) until the pins can be moved the rest of the way without crossing contact; then they are
// fixed again. Inactive, the term is zero and adds nothing, so scenes pay for it only while
// obstacles push.
//
// Variables: stacked positions x (3n, m); pinned vertex indices are global.
#include <vector>

#include "geometry/mesh.h"
#include "physics/energy_term.h"

namespace pd {

class PinTargetTerm : public EnergyTerm {
 public:
  // vertices: global indices of the vertices the term may pull.
  explicit PinTargetTerm(std::vector<int> vertices);

  std::string name() const override { return "pin_target"; }
  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  // k I per pinned vertex (positive definite: no projection needed).
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection, HessianAssembly& hessian) const override;

  // Starts pulling toward targets (stacked like x; only the pinned vertices' entries are read) with
  // stiffness k > 0 and zero multipliers.
  void activate(const Eigen::VectorXd& targets, double k);
  void deactivate() { active_ = false; }
  bool active() const { return active_; }

  // lambda_i <- lambda_i - k (x_i - t_i).
  void update_multipliers(const Eigen::VectorXd& x);
  void set_stiffness(double k) { k_ = k; }
  double stiffness() const { return k_; }

  // max_i |x_i - t_i|, m.
  double max_distance(const Eigen::VectorXd& x) const;
  const std::vector<int>& vertices() const { return vertices_; }

 private:
  std::vector<int> vertices_;
  Eigen::VectorXd targets_;                  // stacked, m
  std::vector<Vec3> lambda_;                 // per pinned vertex, N
  double k_ = 0.0;                           // N/m
  bool active_ = false;
};

}  // namespace pd
