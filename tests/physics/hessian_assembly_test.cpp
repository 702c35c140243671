#include "physics/hessian_assembly.h"

#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <random>

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

// The entry-by-entry reference of the block-built pattern: every stored element entry (lower
// triangle over the global dofs) and every diagonal entry, summed by a serial scatter in the order
// the values were added, then the diagonal, then the fixed dofs' identity rows and columns.
struct ReferenceAssembly {
  int n;
  std::vector<Eigen::Triplet<double, int>> entries;
  void add_element(const std::vector<int>& v, const Eigen::MatrixXd& H) {
    const int N = static_cast<int>(v.size());
    for (int a = 0; a < N; ++a)
      for (int b = 0; b < N; ++b) {
        if (v[a] < v[b]) continue;
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            if (3 * v[a] + i >= 3 * v[b] + j) entries.emplace_back(3 * v[a] + i, 3 * v[b] + j, H(3 * a + i, 3 * b + j));
      }
  }
  HessianAssembly::SparseMatrix finish(const Eigen::VectorXd& diagonal, const std::vector<char>& fixed) const {
    std::vector<Eigen::Triplet<double, int>> pattern;
    for (const auto& t : entries) pattern.emplace_back(t.row(), t.col(), 0.0);
    for (int i = 0; i < n; ++i) pattern.emplace_back(i, i, 0.0);
    HessianAssembly::SparseMatrix M(n, n);
    M.setFromTriplets(pattern.begin(), pattern.end());
    M.makeCompressed();
    for (const auto& t : entries) M.coeffRef(t.row(), t.col()) += t.value();
    for (int i = 0; i < n; ++i) M.coeffRef(i, i) += diagonal[i];
    for (int c = 0; c < n; ++c)
      for (HessianAssembly::SparseMatrix::InnerIterator it(M, c); it; ++it)
        if (fixed[static_cast<size_t>(it.row())] || fixed[static_cast<size_t>(c)]) it.valueRef() = it.row() == c ? 1.0 : 0.0;
    return M;
  }
};

template <int N>
void add_both(HessianAssembly& asmb, ReferenceAssembly& ref, const std::array<int, N>& v, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix<double, 3 * N, 3 * N> H;
  for (int i = 0; i < 3 * N; ++i)
    for (int j = 0; j <= i; ++j) H(i, j) = H(j, i) = u(rng);
  asmb.add<N>(v, H);
  ref.add_element(std::vector<int>(v.begin(), v.end()), H);
}

// Random stencils of 2, 3 and 4 vertices over 40 vertices of which the last 8 are in no element,
// some with a vertex repeated (a degenerate element: its two copies share the diagonal block), with
// pinned dofs: the same pattern, and the same values bit for bit, as the entry-by-entry reference.
TEST(HessianAssembly, BlockBuiltPatternEqualsEntryByEntryAssemblyBitForBit) {
  const int nv = 40, n = 3 * nv;
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> vertex(0, nv - 9);
  for (int round = 0; round < 3; ++round) {  // three different patterns, each rebuilt
    HessianAssembly asmb;
    ReferenceAssembly ref{n, {}};
    asmb.begin(n);
    for (int e = 0; e < 60; ++e) {
      switch (e % 3) {
        case 0: add_both<2>(asmb, ref, {vertex(rng), vertex(rng)}, rng); break;
        case 1: add_both<3>(asmb, ref, {vertex(rng), vertex(rng), vertex(rng)}, rng); break;
        default: add_both<4>(asmb, ref, {vertex(rng), vertex(rng), vertex(rng), vertex(rng)}, rng); break;
      }
    }
    add_both<3>(asmb, ref, {5, 5, 7}, rng);  // a repeated vertex for certain
    const Eigen::VectorXd d = Eigen::VectorXd::LinSpaced(n, 0.5, 3.0);
    asmb.add_diagonal(d);
    std::vector<char> fixed(static_cast<size_t>(n), 0);
    fixed[static_cast<size_t>(3 * (round + 1))] = fixed[static_cast<size_t>(n - 1)] = 1;  // an element dof, a free vertex's
    asmb.set_fixed_dofs(fixed);
    bool changed = false;
    const auto& L = asmb.finish(&changed);
    EXPECT_TRUE(changed);
    const auto R = ref.finish(d, fixed);
    ASSERT_EQ(L.nonZeros(), R.nonZeros());
    EXPECT_EQ(0, std::memcmp(L.outerIndexPtr(), R.outerIndexPtr(), sizeof(int) * static_cast<size_t>(n + 1)));
    EXPECT_EQ(0, std::memcmp(L.innerIndexPtr(), R.innerIndexPtr(), sizeof(int) * static_cast<size_t>(R.nonZeros())));
    for (Eigen::Index k = 0; k < R.nonZeros(); ++k)
      ASSERT_EQ(L.valuePtr()[k], R.valuePtr()[k]) << "slot " << k;  // same bits: same sums in the same order
    EXPECT_GT(R.nonZeros(), 9 * nv);  // the elements overlap: far more entries compared than the diagonal
  }
}

// begin_pattern: the stencils are recorded, no element block is computed (add_elements never calls
// hessian(e)), finish() gives the pattern of a value assembly with zeros; the value assembly that
// follows finds the pattern analysed and gives the bits of an assembly that never saw begin_pattern.
TEST(HessianAssembly, APatternOnlyAssemblyComputesNoBlockAndLeavesItsPatternToTheNextAssembly) {
  const int n = 3 * 7;
  const std::array<std::array<int, 3>, 4> faces = {{{0, 1, 2}, {2, 1, 3}, {3, 4, 2}, {6, 5, 4}}};
  const auto H = random_symmetric<3>(11);
  const auto H4 = random_symmetric<4>(12);
  int blocks_computed = 0;
  const auto assemble = [&](HessianAssembly& asmb) {
    asmb.add_elements<3>(static_cast<int>(faces.size()), [&](int e) { return faces[static_cast<size_t>(e)]; },
                         [&](int e) {
                           ++blocks_computed;
                           return Eigen::Matrix<double, 9, 9>((1.0 + e) * H);
                         });
    asmb.add<4>({5, 0, 3, 1}, H4);
    asmb.add_diagonal(Eigen::VectorXd::LinSpaced(n, 1.0, 2.0));
  };
  HessianAssembly reference;
  reference.begin(n);
  assemble(reference);
  const HessianAssembly::SparseMatrix R = reference.finish(nullptr);
  ASSERT_EQ(blocks_computed, 4);

  HessianAssembly asmb;
  asmb.begin_pattern(n);
  assemble(asmb);
  EXPECT_EQ(blocks_computed, 4);  // none more
  bool changed = false;
  const HessianAssembly::SparseMatrix P = asmb.finish(&changed);
  EXPECT_TRUE(changed);
  ASSERT_EQ(P.nonZeros(), R.nonZeros());
  EXPECT_EQ(0, std::memcmp(P.outerIndexPtr(), R.outerIndexPtr(), sizeof(int) * static_cast<size_t>(n + 1)));
  EXPECT_EQ(0, std::memcmp(P.innerIndexPtr(), R.innerIndexPtr(), sizeof(int) * static_cast<size_t>(R.nonZeros())));
  for (Eigen::Index k = 0; k < P.nonZeros(); ++k) ASSERT_EQ(P.valuePtr()[k], 0.0) << "slot " << k;

  asmb.begin(n);
  assemble(asmb);
  EXPECT_EQ(blocks_computed, 8);
  const HessianAssembly::SparseMatrix& V = asmb.finish(&changed);
  EXPECT_FALSE(changed);
  ASSERT_EQ(V.nonZeros(), R.nonZeros());
  EXPECT_EQ(0, std::memcmp(V.valuePtr(), R.valuePtr(), sizeof(double) * static_cast<size_t>(R.nonZeros())));
  EXPECT_GT(R.nonZeros(), n);  // the elements add entries off the diagonal
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
