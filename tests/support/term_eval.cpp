#include "support/term_eval.h"

#include <cmath>

namespace pd::test {

Eigen::VectorXd term_gradient(const EnergyTerm& term, const Eigen::VectorXd& x) {
  Eigen::VectorXd g = Eigen::VectorXd::Zero(x.size());
  term.add_gradient(x, g);
  return g;
}

Eigen::MatrixXd symmetric_from_lower(const HessianAssembly::SparseMatrix& lower) {
  const Eigen::MatrixXd L(lower);
  Eigen::MatrixXd S = L + L.transpose();
  S.diagonal() = L.diagonal();
  return S;
}

Eigen::MatrixXd term_hessian(const EnergyTerm& term, const Eigen::VectorXd& x, HessianProjection p) {
  HessianAssembly assembly;
  assembly.begin(static_cast<int>(x.size()));
  term.add_hessian(x, p, assembly);
  return symmetric_from_lower(assembly.finish(nullptr));
}

Eigen::VectorXd wavy(Eigen::Index n, double a, double b) {
  return Eigen::VectorXd::NullaryExpr(n, [=](Eigen::Index i) { return std::sin(a * double(i) + b); });
}

}  // namespace pd::test
