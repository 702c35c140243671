#include "physics/guide.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "physics/hessian_assembly.h"

namespace pd {

GuideTerm::GuideTerm(Eigen::VectorXd masses) : masses_(std::move(masses)) {
  if (masses_.size() % 3 != 0)
    throw std::invalid_argument("GuideTerm: masses has " + std::to_string(masses_.size()) +
                                " entries, not one per dof (3 per vertex)");
  for (Eigen::Index i = 0; i < masses_.size(); ++i)
    if (!(std::isfinite(masses_[i]) && masses_[i] >= 0.0))
      throw std::invalid_argument("GuideTerm: masses[" + std::to_string(i) + "] is not a finite non-negative mass");
}

void GuideTerm::begin_step(const StepStart& step) {
  if (!(step.h > 0.0)) throw std::invalid_argument("GuideTerm::begin_step: needs a positive time step");
  h_ = step.h;
}

void GuideTerm::set_guide(const Eigen::VectorXd& target, double weight) {
  if (target.size() != masses_.size())
    throw std::invalid_argument("GuideTerm::set_guide: the target has " + std::to_string(target.size()) +
                                " dofs, the masses " + std::to_string(masses_.size()));
  if (!target.allFinite()) throw std::invalid_argument("GuideTerm::set_guide: the target is not finite");
  set_weight(weight);
  target_ = target;
}

void GuideTerm::set_weight(double weight) {
  if (!(std::isfinite(weight) && weight >= 0.0))
    throw std::invalid_argument("GuideTerm::set_weight: the weight must be finite and >= 0");
  weight_ = weight;
}

void GuideTerm::check_state(const Eigen::VectorXd& x) const {
  if (!(h_ > 0.0)) throw std::logic_error("GuideTerm: evaluated before begin_step");
  if (x.size() != masses_.size())
    throw std::invalid_argument("GuideTerm: x has " + std::to_string(x.size()) + " dofs, the masses " +
                                std::to_string(masses_.size()));
}

double GuideTerm::value(const Eigen::VectorXd& x) const {
  check_state(x);
  if (weight_ == 0.0) return 0.0;
  return 0.5 * weight_ / (h_ * h_) * (masses_.array() * (x - target_).array().square()).sum();
}

void GuideTerm::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  check_state(x);
  if (weight_ == 0.0) return;
  grad.array() += weight_ / (h_ * h_) * masses_.array() * (x - target_).array();
}

void GuideTerm::add_hessian(const Eigen::VectorXd& x, HessianProjection /*projection*/,
                            HessianAssembly& hessian) const {
  check_state(x);
  // Added at weight 0 too (as zeros): the diagonal is in every level's pattern already (inertia), and
  // a term whose pattern changes with its weight would make the assembly plan its pattern again.
  hessian.add_diagonal(weight_ / (h_ * h_) * masses_);
}

}  // namespace pd
