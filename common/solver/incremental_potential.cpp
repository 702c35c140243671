#include "solver/incremental_potential.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pd {

void IncrementalPotential::begin_step(const StepStart& step) {
  for (auto& t : terms_) t->begin_step(step);
}

double IncrementalPotential::value(const Eigen::VectorXd& x) const {
  double e = 0.0;
  for (const auto& t : terms_) e += t->value(x);
  return e;
}

Eigen::VectorXd IncrementalPotential::gradient(const Eigen::VectorXd& x) const {
  Eigen::VectorXd g = Eigen::VectorXd::Zero(x.size());
  for (const auto& t : terms_) t->add_gradient(x, g);
  for (size_t i = 0; i < fixed_.size(); ++i)
    if (fixed_[i]) g[static_cast<Eigen::Index>(i)] = 0.0;
  return g;
}

bool IncrementalPotential::hessian_product(const Eigen::VectorXd& x, const Eigen::VectorXd& g,
                                           const Eigen::VectorXd& v, Eigen::VectorXd& out) const {
  const double largest = v.lpNorm<Eigen::Infinity>();
  if (!(largest > 0.0) || !std::isfinite(largest)) return false;
  const double e = kHessianProductStep / largest;
  // Fixed dofs are not unknowns: they stay where they are (a direction of the solver is zero there).
  Eigen::VectorXd near = x + e * v;
  for (size_t i = 0; i < fixed_.size(); ++i)
    if (fixed_[i]) near[static_cast<Eigen::Index>(i)] = x[static_cast<Eigen::Index>(i)];
  out = Eigen::VectorXd::Zero(x.size());
  try {
    for (const auto& t : terms_) t->add_gradient_near(x, near, out);
  } catch (const std::domain_error&) {
    return false;  // no prolonged shape at `near` (DegenerateProlongationTriangle)
  }
  for (size_t i = 0; i < fixed_.size(); ++i)
    if (fixed_[i]) out[static_cast<Eigen::Index>(i)] = 0.0;
  out = (out - g) / e;
  return out.allFinite();
}

void IncrementalPotential::hessian(const Eigen::VectorXd& x, HessianProjection projection,
                                   HessianAssembly& out) const {
  out.begin(static_cast<int>(x.size()));
  out.set_fixed_dofs(fixed_);
  for (const auto& t : terms_) t->add_hessian(x, projection, out);
}

double IncrementalPotential::max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const {
  double alpha = 1.0;
  for (const auto& t : terms_) alpha = std::min(alpha, t->max_step(x, dx));
  return alpha;
}

bool IncrementalPotential::stand_in_hessian_ends() const {
  for (const auto& t : terms_)
    if (t->stand_in_hessian_ends()) return true;
  return false;
}

void IncrementalPotential::keep_stand_in_hessian(bool keep) const {
  for (const auto& t : terms_) t->keep_stand_in_hessian(keep);
}

std::vector<std::pair<std::string, double>> IncrementalPotential::term_values(const Eigen::VectorXd& x,
                                                                                const std::string& skip) const {
  std::vector<std::pair<std::string, double>> out;
  for (const auto& t : terms_) {
    if (t->name() == skip) continue;  // not evaluated at all (inertia's target is a step's)
    for (const auto& [n, v] : t->named_values(x)) {
      if (n == skip) continue;
      auto it = std::find_if(out.begin(), out.end(), [&](const auto& p) { return p.first == n; });
      if (it == out.end()) out.emplace_back(n, v);
      else it->second += v;
    }
  }
  return out;
}

}  // namespace pd
