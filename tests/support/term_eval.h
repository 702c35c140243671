#pragma once
// Dense evaluations of an EnergyTerm for tests on small meshes.
#include <Eigen/Core>

#include "physics/energy_term.h"

namespace pd::test {

// The term's gradient alone (add_gradient into zeros).
Eigen::VectorXd term_gradient(const EnergyTerm& term, const Eigen::VectorXd& x);

// The term's assembled Hessian as a full dense matrix (the assembly stores the lower triangle).
Eigen::MatrixXd term_hessian(const EnergyTerm& term, const Eigen::VectorXd& x, HessianProjection p);

// Full symmetric matrix from a stored lower triangle.
Eigen::MatrixXd symmetric_from_lower(const HessianAssembly::SparseMatrix& lower);

// A smooth, deterministic "random-looking" vector: entries sin(a i + b).
Eigen::VectorXd wavy(Eigen::Index n, double a, double b);

}  // namespace pd::test
