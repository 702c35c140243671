#include "physics/hessian_assembly.h"

#include <gtest/gtest.h>

#include "support/term_eval.h"

namespace pd {
namespace {

// Reference: scatter the element blocks into a dense matrix directly.
template <int N>
void add_dense(Eigen::MatrixXd& D, const std::array<int, N>& v, const Eigen::Matrix<double, 3 * N, 3 * N>& H) {
  for (int a = 0; a < N; ++a)
    for (int b = 0; b < N; ++b) D.block<3, 3>(3 * v[a], 3 * v[b]) += H.template block<3, 3>(3 * a, 3 * b);
}

template <int N>
Eigen::Matrix<double, 3 * N, 3 * N> random_symmetric(unsigned seed) {
  std::srand(seed);
  Eigen::Matrix<double, 3 * N, 3 * N> A = Eigen::Matrix<double, 3 * N, 3 * N>::Random();
  return A + A.transpose();
}

TEST(HessianAssembly, MatchesDenseScatterOfOverlappingElements) {
  HessianAssembly asmb;
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(15, 15);
  const auto H1 = random_symmetric<3>(1);
  const auto H2 = random_symmetric<3>(2);
  const auto H3 = random_symmetric<4>(3);
  asmb.begin(15);
  asmb.add<3>({0, 1, 2}, H1);
  asmb.add<3>({2, 1, 3}, H2);  // unsorted vertex order must work
  asmb.add<4>({4, 0, 3, 1}, H3);
  Eigen::VectorXd d = Eigen::VectorXd::LinSpaced(15, 1, 15);
  asmb.add_diagonal(d);
  bool changed = false;
  const auto& L = asmb.finish(&changed);
  EXPECT_TRUE(changed);
  add_dense<3>(dense, {0, 1, 2}, H1);
  add_dense<3>(dense, {2, 1, 3}, H2);
  add_dense<4>(dense, {4, 0, 3, 1}, H3);
  dense.diagonal() += d;
  EXPECT_LT((test::symmetric_from_lower(L) - dense).norm(), 1e-12 * dense.norm());
}

TEST(HessianAssembly, SecondAssemblyWithSameStencilsReusesPatternAndGivesNewValues) {
  HessianAssembly asmb;
  asmb.begin(9);
  asmb.add<3>({0, 1, 2}, random_symmetric<3>(5));
  bool changed = false;
  asmb.finish(&changed);
  ASSERT_TRUE(changed);

  const auto H = random_symmetric<3>(6);
  asmb.begin(9);
  asmb.add<3>({0, 1, 2}, H);
  const auto& L = asmb.finish(&changed);
  EXPECT_FALSE(changed);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(9, 9);
  add_dense<3>(dense, {0, 1, 2}, H);
  EXPECT_LT((test::symmetric_from_lower(L) - dense).norm(), 1e-12 * dense.norm());

  asmb.begin(9);
  asmb.add<3>({0, 2, 1}, H);  // different stencil -> new pattern
  asmb.finish(&changed);
  EXPECT_TRUE(changed);
}

TEST(HessianAssembly, FixedDofsGetIdentityRowsAndColumns) {
  HessianAssembly asmb;
  asmb.begin(9);
  asmb.add<3>({0, 1, 2}, random_symmetric<3>(7));
  std::vector<char> fixed(9, 0);
  fixed[3] = fixed[4] = fixed[5] = 1;  // vertex 1
  asmb.set_fixed_dofs(fixed);
  const Eigen::MatrixXd S = test::symmetric_from_lower(asmb.finish(nullptr));
  for (int i = 3; i < 6; ++i)
    for (int j = 0; j < 9; ++j) {
      EXPECT_EQ(S(i, j), i == j ? 1.0 : 0.0);
      EXPECT_EQ(S(j, i), i == j ? 1.0 : 0.0);
    }
  EXPECT_NE(S(0, 7), 0.0);
}

}  // namespace
}  // namespace pd
