#include "physics/hessian_projection.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

namespace pd {
namespace {

Eigen::Matrix<double, 6, 6> symmetric_with_eigenvalues(const Eigen::Matrix<double, 6, 1>& lambda, unsigned seed) {
  std::srand(seed);
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Random();
  Eigen::HouseholderQR<Eigen::Matrix<double, 6, 6>> qr(A);
  Eigen::Matrix<double, 6, 6> Q = qr.householderQ();
  return Q * lambda.asDiagonal() * Q.transpose();
}

TEST(HessianProjection, NoneReturnsTheMatrixUnchanged) {
  Eigen::Matrix<double, 6, 1> l;
  l << -3, -1, 0.5, 1, 2, 4;
  const auto H = symmetric_with_eigenvalues(l, 1);
  EXPECT_EQ((project_hessian<6>(H, HessianProjection::None) - H).norm(), 0.0);
}

TEST(HessianProjection, ClampZeroesNegativeEigenvaluesAndKeepsPositiveOnes) {
  Eigen::Matrix<double, 6, 1> l;
  l << -3, -1, 0.5, 1, 2, 4;
  const auto P = project_hessian<6>(symmetric_with_eigenvalues(l, 2), HessianProjection::Clamp);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(P);
  Eigen::Matrix<double, 6, 1> expected;
  expected << 0, 0, 0.5, 1, 2, 4;
  EXPECT_LT((eig.eigenvalues() - expected).norm(), 1e-12);
}

TEST(HessianProjection, AbsFlipsNegativeEigenvalues) {
  Eigen::Matrix<double, 6, 1> l;
  l << -3, -1, 0.5, 1, 2, 4;
  const auto P = project_hessian<6>(symmetric_with_eigenvalues(l, 3), HessianProjection::Abs);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(P);
  Eigen::Matrix<double, 6, 1> expected;
  expected << 0.5, 1, 1, 2, 3, 4;
  EXPECT_LT((eig.eigenvalues() - expected).norm(), 1e-12);
}

TEST(HessianProjection, PositiveDefiniteMatrixIsReturnedBitForBit) {
  Eigen::Matrix<double, 6, 1> l;
  l << 0.1, 1, 2, 3, 4, 5;
  const auto H = symmetric_with_eigenvalues(l, 4);
  EXPECT_EQ((project_hessian<6>(H, HessianProjection::Clamp) - H).norm(), 0.0);
  EXPECT_EQ((project_hessian<6>(H, HessianProjection::Abs) - H).norm(), 0.0);
}

TEST(HessianProjection, ExactFirstProjectsLikeClampWhereAnElementCannotRetry) {
  Eigen::Matrix<double, 6, 1> l;
  l << -3, -1, 0.5, 1, 2, 4;
  const auto H = symmetric_with_eigenvalues(l, 5);
  EXPECT_EQ((project_hessian<6>(H, HessianProjection::ExactFirst) - project_hessian<6>(H, HessianProjection::Clamp)).norm(), 0.0);
}

TEST(HessianProjection, ParsesTheFourNamesAndRejectsOthers) {
  HessianProjection p;
  ASSERT_TRUE(parse_hessian_projection("none", p));
  EXPECT_EQ(p, HessianProjection::None);
  ASSERT_TRUE(parse_hessian_projection("clamp", p));
  EXPECT_EQ(p, HessianProjection::Clamp);
  ASSERT_TRUE(parse_hessian_projection("abs", p));
  EXPECT_EQ(p, HessianProjection::Abs);
  ASSERT_TRUE(parse_hessian_projection("exact_first", p));
  EXPECT_EQ(p, HessianProjection::ExactFirst);
  EXPECT_STREQ(to_string(HessianProjection::ExactFirst), "exact_first");
  EXPECT_FALSE(parse_hessian_projection("Clamp", p));
  EXPECT_STREQ(to_string(HessianProjection::Abs), "abs");
}

}  // namespace
}  // namespace pd
