// The blocked Galerkin product (progressive/galerkin_product.h) against a dense J^T H J: every lower
// block present and equal, every absent block zero, the order column by column, plans reused while
// the patterns repeat and rebuilt when they change, partial blocks (U (x) I3's diagonal entries), the
// pattern alone, and sizes that do not fit.
#include "progressive/galerkin_product.h"
#include "util/parallel.h"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <random>
#include <set>
#include <utility>
#include <vector>

namespace pd {
namespace {

using Sparse = Eigen::SparseMatrix<double>;

// J with three distinct coarse parents per fine vertex; full 3x3 blocks, or only their diagonals
// (the frozen mode's U (x) I3).
Sparse random_jacobian(int nf, int nc, bool diagonal_only, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Eigen::Triplet<double>> t;
  for (int a = 0; a < nf; ++a) {
    std::set<int> parents;
    while (parents.size() < 3) parents.insert(static_cast<int>(rng() % nc));
    for (int q : parents)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          if (!diagonal_only || r == c) t.emplace_back(3 * a + r, 3 * q + c, u(rng));
  }
  Sparse J(3 * nf, 3 * nc);
  J.setFromTriplets(t.begin(), t.end());
  return J;
}

// A symmetric H on a random block pattern (every diagonal block and `pairs` vertex pairs), its lower
// triangle stored, as HessianAssembly::finish gives it.
Sparse random_lower_hessian(int nf, int pairs, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::set<std::pair<int, int>> blocks;
  for (int a = 0; a < nf; ++a) blocks.insert({a, a});
  while (static_cast<int>(blocks.size()) < nf + pairs) {
    const int a = static_cast<int>(rng() % nf), b = static_cast<int>(rng() % nf);
    blocks.insert({std::max(a, b), std::min(a, b)});
  }
  std::vector<Eigen::Triplet<double>> t;
  for (const auto& [a, b] : blocks)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        if (a != b || r >= c) t.emplace_back(3 * a + r, 3 * b + c, u(rng));
  Sparse H(3 * nf, 3 * nf);
  H.setFromTriplets(t.begin(), t.end());
  return H;
}

Eigen::MatrixXd dense_galerkin(const Sparse& H_lower, const Sparse& J) {
  const Eigen::MatrixXd L = Eigen::MatrixXd(H_lower);
  const Eigen::MatrixXd H = L + Eigen::MatrixXd(L.triangularView<Eigen::StrictlyLower>()).transpose();
  const Eigen::MatrixXd Jd = Eigen::MatrixXd(J);
  return Jd.transpose() * H * Jd;
}

// Compares every lower 3x3 block of the dense G with the product's; returns the comparisons made.
int expect_matches_dense(const std::vector<GalerkinProduct::Block>& blocks, const Eigen::MatrixXd& G) {
  const int nc = static_cast<int>(G.rows() / 3);
  std::vector<std::vector<const Mat3*>> found(nc, std::vector<const Mat3*>(nc, nullptr));
  for (size_t k = 0; k < blocks.size(); ++k) {
    const GalerkinProduct::Block& b = blocks[k];
    EXPECT_GE(b.i, b.j);
    EXPECT_EQ(found[b.i][b.j], nullptr) << "block (" << b.i << ", " << b.j << ") twice";
    found[b.i][b.j] = &b.block;
    if (k > 0) {
      const GalerkinProduct::Block& prev = blocks[k - 1];
      EXPECT_TRUE(prev.j < b.j || (prev.j == b.j && prev.i < b.i)) << "not column by column at " << k;
    }
  }
  const double scale = G.cwiseAbs().maxCoeff();
  int compared = 0;
  for (int j = 0; j < nc; ++j)
    for (int i = j; i < nc; ++i) {
      const Mat3 dense = G.block<3, 3>(3 * i, 3 * j);
      const Mat3 got = found[i][j] ? *found[i][j] : Mat3::Zero();
      EXPECT_LE((got - dense).cwiseAbs().maxCoeff(), 1e-13 * scale) << "block (" << i << ", " << j << ")";
      ++compared;
    }
  return compared;
}

TEST(GalerkinProduct, EqualsTheDenseProductBlockByBlockInColumnOrder) {
  std::mt19937 rng(7);
  const Sparse J = random_jacobian(40, 12, false, rng);
  const Sparse H = random_lower_hessian(40, 90, rng);
  GalerkinProduct product;
  const int compared = expect_matches_dense(product.compute(H, J), dense_galerkin(H, J));
  EXPECT_EQ(compared, 12 * 13 / 2);
}

TEST(GalerkinProduct, ReusesItsPlansForNewValuesAndRebuildsThemForANewPattern) {
  std::mt19937 rng(11);
  const Sparse J = random_jacobian(30, 10, false, rng);
  const Sparse H = random_lower_hessian(30, 60, rng);
  GalerkinProduct product;
  product.compute(H, J);
  Sparse H2 = H, J2 = J;
  for (int k = 0; k < H2.nonZeros(); ++k) H2.valuePtr()[k] *= 1.0 + 0.01 * k;
  for (int k = 0; k < J2.nonZeros(); ++k) J2.valuePtr()[k] -= 0.003 * k;
  EXPECT_GT(expect_matches_dense(product.compute(H2, J2), dense_galerkin(H2, J2)), 0);
  EXPECT_EQ(product.plans_built(), 1);
  const Sparse H3 = random_lower_hessian(30, 20, rng);
  EXPECT_GT(expect_matches_dense(product.compute(H3, J2), dense_galerkin(H3, J2)), 0);
  EXPECT_EQ(product.plans_built(), 2);
}

TEST(GalerkinProduct, HandlesPartialBlocksOfTheFrozenProlongation) {
  std::mt19937 rng(3);
  const Sparse U = random_jacobian(25, 9, true, rng);
  const Sparse H = random_lower_hessian(25, 40, rng);
  GalerkinProduct product;
  EXPECT_EQ(expect_matches_dense(product.compute(H, U), dense_galerkin(H, U)), 9 * 10 / 2);
}

TEST(GalerkinProduct, GivesTheSameBitsOnOneTwoAndThreeThreads) {
  std::mt19937 rng(13);
  // Large enough that every loop of compute() is split among threads (util/parallel.h's minimums).
  const Sparse J = random_jacobian(800, 60, false, rng);
  const Sparse H = random_lower_hessian(800, 3000, rng);
  std::vector<std::vector<GalerkinProduct::Block>> results;
  for (int threads : {1, 2, 3}) {
    set_element_threads(threads);
    GalerkinProduct product;
    results.push_back(product.compute(H, J));
  }
  set_element_threads(0);
  int compared = 0;
  for (std::size_t r = 1; r < results.size(); ++r) {
    ASSERT_EQ(results[r].size(), results[0].size());
    for (std::size_t b = 0; b < results[0].size(); ++b) {
      EXPECT_EQ(results[r][b].i, results[0][b].i);
      EXPECT_EQ(results[r][b].j, results[0][b].j);
      EXPECT_EQ(std::memcmp(results[r][b].block.data(), results[0][b].block.data(), sizeof(Mat3)), 0);
      ++compared;
    }
  }
  EXPECT_GT(compared, 2 * 1000);
  EXPECT_GT(expect_matches_dense(results[0], dense_galerkin(H, J)), 1000);
}

// pattern() is compute()'s block list with zero blocks, read from the patterns alone (H and J hold
// NaN here), and its plans serve the compute() that follows: no second build, the same bits as a
// product that never ran pattern().
TEST(GalerkinProduct, PatternListsComputesBlocksAsZerosAndKeepsItsPlansForCompute) {
  std::mt19937 rng(17);
  const Sparse J = random_jacobian(60, 15, false, rng);
  const Sparse H = random_lower_hessian(60, 150, rng);
  Sparse H_nan = H, J_nan = J;
  for (int k = 0; k < H_nan.nonZeros(); ++k) H_nan.valuePtr()[k] = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k < J_nan.nonZeros(); ++k) J_nan.valuePtr()[k] = std::numeric_limits<double>::quiet_NaN();
  GalerkinProduct fresh, primed;
  const std::vector<GalerkinProduct::Block> expected = fresh.compute(H, J);
  const std::vector<GalerkinProduct::Block> pattern = primed.pattern(H_nan, J_nan);
  ASSERT_EQ(pattern.size(), expected.size());
  for (std::size_t b = 0; b < pattern.size(); ++b) {
    EXPECT_EQ(pattern[b].i, expected[b].i);
    EXPECT_EQ(pattern[b].j, expected[b].j);
    EXPECT_TRUE(pattern[b].block.isZero(0.0)) << "block " << b;
  }
  const std::vector<GalerkinProduct::Block>& got = primed.compute(H, J);
  EXPECT_EQ(primed.plans_built(), 1);
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t b = 0; b < got.size(); ++b)
    EXPECT_EQ(std::memcmp(got[b].block.data(), expected[b].block.data(), sizeof(Mat3)), 0) << "block " << b;
  EXPECT_GT(expected.size(), 15u);  // more blocks than the diagonal ones
  for (const GalerkinProduct::Block& b : primed.pattern(H, J)) EXPECT_TRUE(b.block.isZero(0.0));  // plans kept, values cleared
  EXPECT_THROW(primed.pattern(Sparse(31, 31), Sparse(31, 15)), std::invalid_argument);
}

TEST(GalerkinProduct, RefusesSizesThatDoNotFit) {
  std::mt19937 rng(5);
  const Sparse J = random_jacobian(10, 5, false, rng);
  GalerkinProduct product;
  EXPECT_THROW(product.compute(random_lower_hessian(9, 5, rng), J), std::invalid_argument);
  EXPECT_THROW(product.compute(Sparse(31, 31), Sparse(31, 15)), std::invalid_argument);
}

}  // namespace
}  // namespace pd
