#include "solver/cholmod_solver.h"

#include <gtest/gtest.h>

#include "support/term_eval.h"

#include <vector>

namespace pd {
namespace {

// 1D Laplacian plus diagonal shift: SPD, tridiagonal; lower triangle only.
CholmodSolver::SparseMatrix laplacian_lower(int n, double shift) {
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2.0 + shift);
    if (i + 1 < n) t.emplace_back(i + 1, i, -1.0);
  }
  CholmodSolver::SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}


TEST(CholmodSolver, SolvesSpdSystemToRoundOff) {
  const auto A = laplacian_lower(200, 0.01);
  CholmodSolver s;
  ASSERT_TRUE(s.factorize(A, true));
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(200, -1, 1);
  const Eigen::VectorXd x = s.solve(b);
  EXPECT_LT((test::symmetric_from_lower(A) * x - b).norm(), 1e-10 * b.norm());
  EXPECT_EQ(s.last_shift(), 0.0);
}

TEST(CholmodSolver, ReusesSymbolicAnalysisWhilePatternIsUnchanged) {
  CholmodSolver s;
  ASSERT_TRUE(s.factorize(laplacian_lower(50, 0.1), true));
  ASSERT_TRUE(s.factorize(laplacian_lower(50, 0.2), false));
  ASSERT_TRUE(s.factorize(laplacian_lower(50, 0.3), false));
  EXPECT_EQ(s.analyses(), 1);
  const auto A = laplacian_lower(50, 0.3);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(50);
  EXPECT_LT((test::symmetric_from_lower(A) * s.solve(b) - b).norm(), 1e-10);
  ASSERT_TRUE(s.factorize(laplacian_lower(60, 0.3), true));
  EXPECT_EQ(s.analyses(), 2);
}

TEST(CholmodSolver, IndefiniteMatrixIsShiftedUntilFactorizable) {
  CholmodSolver s;
  const auto A = laplacian_lower(30, -3.0);  // eigenvalues in (-3, 1): indefinite
  ASSERT_TRUE(s.factorize(A, true));
  EXPECT_GT(s.last_shift(), 0.0);
}

}  // namespace
}  // namespace pd
