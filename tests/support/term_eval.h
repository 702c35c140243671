#pragma once
// Dense evaluations of an EnergyTerm for tests on small meshes.
#include <functional>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "physics/energy_term.h"
#include "support/finite_difference.h"

namespace pd::test {

// The term's gradient alone (add_gradient into zeros).
Eigen::VectorXd term_gradient(const EnergyTerm& term, const Eigen::VectorXd& x);

// The term's assembled Hessian as a full dense matrix (the assembly stores the lower triangle).
Eigen::MatrixXd term_hessian(const EnergyTerm& term, const Eigen::VectorXd& x, HessianProjection p);

// Full symmetric matrix from a stored lower triangle.
Eigen::MatrixXd symmetric_from_lower(const HessianAssembly::SparseMatrix& lower);

// A smooth, deterministic "random-looking" vector: entries sin(a i + b).
Eigen::VectorXd wavy(Eigen::Index n, double a, double b);

// Finite-difference check of a term's gradient (against its value) and exact Hessian (against its
// gradient) at x, with projection off.
struct TermFdCheck {
  FdResult gradient, hessian;
  Eigen::MatrixXd H;  // the term's exact assembled Hessian at x
};
TermFdCheck check_term_derivatives(const EnergyTerm& term, const Eigen::VectorXd& x);

// GoogleTest expectations on a TermFdCheck: both checks ran, and each agreed at two or more step
// sizes to within its tolerance.
void expect_derivatives_match(const TermFdCheck& check, double gradient_tolerance, double hessian_tolerance);

// A term's value (J), gradient (J/m) and assembled Hessian values (J/m^2, projected as `p` says),
// evaluated with `threads` element threads (util/parallel.h), for bit-for-bit comparisons.
struct TermBits {
  double value = 0.0;
  Eigen::VectorXd gradient;
  std::vector<double> hessian;  // the stored lower triangle's values, in storage order
};
TermBits term_bits(const EnergyTerm& term, const Eigen::VectorXd& x, HessianProjection p, int threads);

// Expects a and b to hold the same bytes (value, every gradient entry, every Hessian value) and
// returns how many doubles were compared (a caller asserts it is large enough to mean something).
long expect_same_bits(const TermBits& a, const TermBits& b);

// A term that keeps per-element results and their sum from value() for a gradient or a second
// value() at the same x (util/state_key.h) against `twin`, the same term built again that never
// evaluated a value: after value(x) the gradient at x (reuse) and at y (no reuse), then after
// value(y) the same, and after each value() the values at that state (reuse) and at the other one,
// all equal to the twin's bit for bit. x and y must have different gradients and values (asserted),
// so stale reuse cannot pass.
void expect_reuse_after_value_is_fresh(const EnergyTerm& term, const EnergyTerm& twin, const Eigen::VectorXd& x,
                                       const Eigen::VectorXd& y);

// Expects terms built by make() to give `energy` and `gradient` at x bit for bit: the value, the
// gradient after it (per-element results reused) and the gradient of a term that evaluated no value,
// each on one and two element threads. Returns the doubles compared (4 gradients and 2 values).
long expect_value_and_gradient_bits(const std::function<std::unique_ptr<EnergyTerm>()>& make, const Eigen::VectorXd& x,
                                    double energy, const Eigen::VectorXd& gradient);

}  // namespace pd::test
