#pragma once
// Dense evaluations of an EnergyTerm for tests on small meshes.
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

}  // namespace pd::test
