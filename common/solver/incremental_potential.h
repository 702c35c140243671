#pragma once
// The incremental potential of one implicit time step: a sum of EnergyTerms (inertia first, then
// whichever elastic, external and contact terms the scene declares), with Dirichlet dofs held fixed.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "physics/energy_term.h"

namespace pd {

// hessian_product's difference step: the largest coordinate change, m. Far below every length a
// scene resolves (contact distances are 1e-4 m and up, Newton's step tolerance about 1e-5 m) and far
// above the gradient's round-off: at 1 m from the origin an inertia gradient m (x - x~) / h^2 is exact
// to about 1e-16 relative, so the difference keeps about 9 digits.
constexpr double kHessianProductStep = 1e-7;

class IncrementalPotential {
 public:
  void add_term(std::unique_ptr<EnergyTerm> term) { terms_.push_back(std::move(term)); }
  const std::vector<std::unique_ptr<EnergyTerm>>& terms() const { return terms_; }

  // Dofs whose value the solver never changes (pinned vertices, 3 dofs each): 1 = fixed.
  void set_fixed_dofs(std::vector<char> fixed) { fixed_ = std::move(fixed); }
  const std::vector<char>& fixed_dofs() const { return fixed_; }

  void begin_step(const StepStart& step);
  double value(const Eigen::VectorXd& x) const;
  // Gradient with the entries of fixed dofs set to zero.
  Eigen::VectorXd gradient(const Eigen::VectorXd& x) const;
  // The product of the potential's Hessian at x with v (stacked; fixed dofs are held, and their entries
  // of the product are zero), by a
  // forward difference of gradients: out = (gradient(x + e v) - g) / e with g = gradient(x) and
  // e ||v||_inf = kHessianProductStep (each term's add_gradient_near, reference x). For a level whose
  // assembled Hessian is only a model of the potential's (solver/newton.h). Returns false, out
  // unspecified, when x + e v has no finite gradient (a prolonged coarse triangle collapses) or v is
  // zero.
  bool hessian_product(const Eigen::VectorXd& x, const Eigen::VectorXd& g, const Eigen::VectorXd& v,
                       Eigen::VectorXd& out) const;
  // Any term's stand-in Hessian phase ends at the next assembly (EnergyTerm::stand_in_hessian_ends);
  // keep_stand_in_hessian passes the solver's verdict to every term.
  bool stand_in_hessian_ends() const;
  void keep_stand_in_hessian(bool keep) const;
  // Assembles every term's (projected) Hessian; fixed dofs get identity rows and columns.
  void hessian(const Eigen::VectorXd& x, HessianProjection projection, HessianAssembly& out) const;
  // min over terms of their admissible step fraction.
  double max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const;

  // Each term's value, by name; terms sharing a name (one per object) are summed, first-seen order.
  // Terms named `skip` are left out (the stats leave out "inertia", whose target only exists
  // within a step).
  std::vector<std::pair<std::string, double>> term_values(const Eigen::VectorXd& x,
                                                          const std::string& skip = "") const;

 private:
  std::vector<std::unique_ptr<EnergyTerm>> terms_;
  std::vector<char> fixed_;
};

}  // namespace pd
