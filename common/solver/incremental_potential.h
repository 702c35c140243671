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
