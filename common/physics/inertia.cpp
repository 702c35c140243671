#include "physics/inertia.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace pd {

Eigen::VectorXd lumped_masses(const Faces& F, const Positions& rest, double mass_per_area) {
  Eigen::VectorXd m = Eigen::VectorXd::Zero(3 * rest.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Vec3 p0 = rest.row(F(f, 0)).transpose();
    const Vec3 e1 = rest.row(F(f, 1)).transpose() - p0;
    const Vec3 e2 = rest.row(F(f, 2)).transpose() - p0;
    const double third = mass_per_area * 0.5 * e1.cross(e2).norm() / 3.0;  // kg
    for (int a = 0; a < 3; ++a)
      for (int k = 0; k < 3; ++k) m[3 * F(f, a) + k] += third;
  }
  return m;
}

double kinetic_energy(const Eigen::VectorXd& masses, const Eigen::VectorXd& v) {
  return 0.5 * (masses.array() * v.array().square()).sum();
}

InertiaTerm::InertiaTerm(Eigen::VectorXd masses) : masses_(std::move(masses)) {
  if (masses_.size() % 3 != 0)
    throw std::invalid_argument("InertiaTerm: masses has " + std::to_string(masses_.size()) +
                                " entries, not one per dof (3 per vertex)");
  for (Eigen::Index i = 0; i < masses_.size(); ++i)
    if (!(std::isfinite(masses_[i]) && masses_[i] >= 0.0))
      throw std::invalid_argument("InertiaTerm: masses[" + std::to_string(i) + "] is " + std::to_string(masses_[i]) +
                                  " kg, not a finite non-negative mass");
}

// Checked in every build, not only where NDEBUG is off (a wrongly sized mass vector gave garbage in
// a Release build): once per step, and one comparison per evaluation.
void InertiaTerm::begin_step(const StepStart& step) {
  if (!(step.h > 0.0) || !step.x || !step.v)
    throw std::invalid_argument("InertiaTerm::begin_step: needs a positive time step and start positions and velocities");
  if (step.x->size() != masses_.size() || step.v->size() != masses_.size())
    throw std::invalid_argument("InertiaTerm::begin_step: positions have " + std::to_string(step.x->size()) +
                                " dofs and velocities " + std::to_string(step.v->size()) + ", the masses " +
                                std::to_string(masses_.size()));
  h_ = step.h;
  xhat_ = *step.x + h_ * *step.v;
  mass_over_h2_ = masses_ / (h_ * h_);
}

void InertiaTerm::set_predicted_positions(const Eigen::VectorXd& xhat) {
  if (xhat.size() != masses_.size())
    throw std::invalid_argument("InertiaTerm::set_predicted_positions: xhat needs one entry per dof");
  xhat_ = xhat;
}

void InertiaTerm::check_state(const Eigen::VectorXd& x) const {
  if (!(h_ > 0.0)) throw std::logic_error("InertiaTerm: evaluated before begin_step");
  if (x.size() != masses_.size())
    throw std::invalid_argument("InertiaTerm: x has " + std::to_string(x.size()) + " dofs, the masses " +
                                std::to_string(masses_.size()));
}

double InertiaTerm::value(const Eigen::VectorXd& x) const {
  check_state(x);
  return 0.5 * (mass_over_h2_.array() * (x - xhat_).array().square()).sum();
}

void InertiaTerm::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  check_state(x);
  grad.array() += mass_over_h2_.array() * (x - xhat_).array();
}

void InertiaTerm::add_hessian(const Eigen::VectorXd& x, HessianProjection /*projection*/,
                              HessianAssembly& hessian) const {
  check_state(x);
  hessian.add_diagonal(mass_over_h2_);
}

}  // namespace pd
