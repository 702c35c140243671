#include "solver/exact_curvature_step.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <Eigen/SparseCore>

namespace pd {
namespace {

using SparseMatrix = CholmodSolver::SparseMatrix;

// The lower triangle of a symmetric tridiagonal matrix: `diagonal` on the diagonal, -1 beside it.
SparseMatrix tridiagonal_lower(const Eigen::VectorXd& diagonal) {
  const int n = static_cast<int>(diagonal.size());
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, diagonal[i]);
    if (i + 1 < n) t.emplace_back(i + 1, i, -1.0);
  }
  SparseMatrix m(n, n);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

double full_quadratic(const SparseMatrix& lower, const Eigen::VectorXd& v) {
  return v.dot(lower.selfadjointView<Eigen::Lower>() * v);
}

// A "clamped" preconditioner C = H + N, N >= 0 large on a few dofs: the soft modes there are the
// ones the clamped step gets wrong.
struct System {
  SparseMatrix exact, clamped;
  Eigen::VectorXd g;
};

System soft_system(double soft_diagonal) {
  const int n = 40;
  Eigen::VectorXd d = Eigen::VectorXd::Constant(n, 2.5);
  Eigen::VectorXd c = d;
  for (int i : {5, 17, 30}) {
    d[i] = soft_diagonal;  // the exact curvature there
    c[i] = 10.0;           // the clamped model's
  }
  System s{tridiagonal_lower(d), tridiagonal_lower(c), Eigen::VectorXd::LinSpaced(n, -1.0, 2.0)};
  return s;
}

TEST(ExactCurvatureStep, OnAPositiveDefiniteExactHessianItReachesTheExactNewtonStep) {
  const System s = soft_system(2.1);  // H positive definite (diagonal 2.1 beside off-diagonals of -1)
  CholmodSolver clamped;
  ASSERT_TRUE(clamped.factorize(s.clamped, true, false));
  const Eigen::VectorXd clamped_step = -clamped.solve(s.g);
  const ExactCurvatureStep r = exact_curvature_step(s.exact, clamped, s.g, clamped_step, 50, 1e-10);

  CholmodSolver exact;
  ASSERT_TRUE(exact.factorize(s.exact, true, false));
  const Eigen::VectorXd newton = -exact.solve(s.g);
  EXPECT_GT((clamped_step - newton).norm(), 0.1 * newton.norm()) << "the clamped step is far from Newton's";
  EXPECT_FALSE(r.negative_curvature);
  EXPECT_LT((r.step - newton).norm(), 1e-8 * newton.norm());
  // Three modified dofs: C^{-1} H is the identity plus a rank-3 change, so CG needs about four.
  EXPECT_GE(r.iterations, 2);
  EXPECT_LE(r.iterations, 8);
}

TEST(ExactCurvatureStep, NegativeCurvatureAlongTheClampedStepKeepsTheClampedStep) {
  System s = soft_system(2.1);
  s.exact = tridiagonal_lower(Eigen::VectorXd::Constant(40, -3.0));  // negative definite
  CholmodSolver clamped;
  ASSERT_TRUE(clamped.factorize(s.clamped, true, false));
  const Eigen::VectorXd clamped_step = -clamped.solve(s.g);
  const ExactCurvatureStep r = exact_curvature_step(s.exact, clamped, s.g, clamped_step, 50, 1e-10);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_TRUE(r.negative_curvature);
  EXPECT_TRUE(r.step == clamped_step);
}

// H indefinite (one negative diagonal entry) but positive along the clamped step: CG takes steps
// until it meets the negative curvature and keeps its last iterate, a descent direction that lowers
// the quadratic model more than the clamped step does.
TEST(ExactCurvatureStep, StopsAtNegativeCurvatureWithADescentStepThatBeatsTheClampedOne) {
  System s = soft_system(2.1);
  Eigen::VectorXd d = Eigen::VectorXd::Constant(40, 2.5);
  d[5] = d[30] = 2.1;
  d[17] = -0.5;
  s.exact = tridiagonal_lower(d);
  s.g[17] = 1e-3;  // the negative direction barely appears in the first direction
  CholmodSolver clamped;
  ASSERT_TRUE(clamped.factorize(s.clamped, true, false));
  const Eigen::VectorXd clamped_step = -clamped.solve(s.g);
  ASSERT_GT(full_quadratic(s.exact, clamped_step), 0.0);
  const ExactCurvatureStep r = exact_curvature_step(s.exact, clamped, s.g, clamped_step, 50, 1e-10);
  EXPECT_TRUE(r.negative_curvature);
  EXPECT_GE(r.iterations, 1);
  EXPECT_LT(s.g.dot(r.step), 0.0);
  const auto model = [&](const Eigen::VectorXd& p) { return s.g.dot(p) + 0.5 * full_quadratic(s.exact, p); };
  EXPECT_LT(model(r.step), model(clamped_step));
}

TEST(ExactCurvatureStep, StopsAfterMaxIterations) {
  const System s = soft_system(2.1);
  CholmodSolver clamped;
  ASSERT_TRUE(clamped.factorize(s.clamped, true, false));
  const Eigen::VectorXd clamped_step = -clamped.solve(s.g);
  const ExactCurvatureStep none = exact_curvature_step(s.exact, clamped, s.g, clamped_step, 0, 1e-10);
  EXPECT_EQ(none.iterations, 0);
  EXPECT_TRUE(none.step == clamped_step);
  EXPECT_TRUE(std::isnan(none.first_curvature_ratio)) << "no product, no ratio";
  const ExactCurvatureStep one = exact_curvature_step(s.exact, clamped, s.g, clamped_step, 1, 1e-10);
  EXPECT_EQ(one.iterations, 1);
  // One iteration is the clamped step scaled to the model's minimum along it.
  const double scale = -s.g.dot(clamped_step) / full_quadratic(s.exact, clamped_step);
  EXPECT_LT((one.step - scale * clamped_step).norm(), 1e-12 * clamped_step.norm());
}

// The operator form is the matrix form's iteration: the same steps bit for bit, and the first
// direction's curvature ratio d^T H d / d^T C d (with d the clamped step, d^T C d = -g^T d).
TEST(ExactCurvatureStep, TheProductFormTakesTheMatrixFormsStepsBitForBitAndReportsTheFirstCurvatureRatio) {
  const System s = soft_system(2.1);
  CholmodSolver clamped;
  ASSERT_TRUE(clamped.factorize(s.clamped, true, false));
  const Eigen::VectorXd clamped_step = -clamped.solve(s.g);
  int products = 0;
  const HessianProduct product = [&](const Eigen::VectorXd& d, Eigen::VectorXd& out) {
    ++products;
    out = s.exact.selfadjointView<Eigen::Lower>() * d;
    return true;
  };
  const ExactCurvatureStep a = exact_curvature_step(s.exact, clamped, s.g, clamped_step, 50, 1e-10);
  const ExactCurvatureStep b = exact_curvature_step(product, clamped, s.g, clamped_step, 50, 1e-10);
  EXPECT_TRUE(a.step == b.step);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(products, b.iterations);
  const double expected = full_quadratic(s.exact, clamped_step) / full_quadratic(s.clamped, clamped_step);
  EXPECT_NEAR(b.first_curvature_ratio, expected, 1e-12 * expected);
  EXPECT_GT(std::abs(expected - 1.0), 0.01) << "C's curvature along its own step differs from H's here";
}

// A product that cannot be formed (the potential has no gradient near the state) ends the iteration
// as non-positive curvature does, with the clamped step kept and no ratio.
TEST(ExactCurvatureStep, AFailedProductKeepsTheClampedStepAndReportsNoRatio) {
  const System s = soft_system(2.1);
  CholmodSolver clamped;
  ASSERT_TRUE(clamped.factorize(s.clamped, true, false));
  const Eigen::VectorXd clamped_step = -clamped.solve(s.g);
  const HessianProduct failing = [](const Eigen::VectorXd&, Eigen::VectorXd&) { return false; };
  const ExactCurvatureStep r = exact_curvature_step(failing, clamped, s.g, clamped_step, 50, 1e-10);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_TRUE(r.negative_curvature);
  EXPECT_TRUE(r.step == clamped_step);
  EXPECT_TRUE(std::isnan(r.first_curvature_ratio));
}

}  // namespace
}  // namespace pd
