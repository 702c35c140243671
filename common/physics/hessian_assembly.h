#pragma once
// Assembly of element Hessians into the global sparse Hessian.
//
// Energies add dense per-element blocks by vertex index; this class owns how they land in the sparse
// matrix. Only the lower triangle is stored (CHOLMOD reads it as symmetric). The first assembly
// records where every element entry goes; later assemblies with the same sequence of element
// stencils (the usual case: elasticity never changes its stencils) scatter straight into the stored
// values without sorting, and report that the sparsity pattern is unchanged so that the Cholesky
// factorization can reuse its symbolic analysis.
#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

namespace pd {

class HessianAssembly {
 public:
  using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

  // Starts an assembly for `num_dofs` unknowns (3 per vertex). Call before the energies add blocks.
  void begin(int num_dofs);

  // Adds the element Hessian H (3N x 3N, rows/cols ordered as vertex verts[0] xyz, verts[1] xyz, ...).
  template <int N>
  void add(const std::array<int, N>& verts, const Eigen::Matrix<double, 3 * N, 3 * N>& H) {
    stencil_.push_back(N);
    for (int a = 0; a < N; ++a) stencil_.push_back(verts[a]);
    for (int a = 0; a < N; ++a)
      for (int b = 0; b < N; ++b) {
        if (verts[a] < verts[b]) continue;  // lower triangle of the block structure only
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) {
            const int r = 3 * verts[a] + i, c = 3 * verts[b] + j;
            if (r >= c) values_.push_back(H(3 * a + i, 3 * b + j));
          }
      }
  }

  // Adds d to the diagonal entry of every dof (mass / h^2 terms).
  void add_diagonal(const Eigen::VectorXd& d);

  // Finishes the assembly. Returns the lower triangle; `pattern_changed` tells whether the sparsity
  // pattern differs from the previous call's.
  const SparseMatrix& finish(bool* pattern_changed);

  // Pinned (Dirichlet) dofs: rows and columns zeroed, diagonal set to one. Applied by finish().
  void set_fixed_dofs(const std::vector<char>& fixed) { fixed_ = fixed; }

 private:
  void rebuild_pattern();

  int num_dofs_ = 0;
  std::vector<int> stencil_, previous_stencil_;  // N, v0..vN-1 per element, in call order
  std::vector<double> values_;                   // element entries in call order
  Eigen::VectorXd diagonal_;
  std::vector<int> scatter_;                     // values_[k] lands at matrix_.valuePtr()[scatter_[k]]
  std::vector<int> diagonal_slot_;               // value index of diagonal entry per dof
  std::vector<char> fixed_;
  SparseMatrix matrix_;
  bool have_pattern_ = false;
};

}  // namespace pd
