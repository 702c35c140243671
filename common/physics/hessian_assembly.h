#pragma once
// Assembly of element Hessians into the global sparse Hessian.
//
// Energies add dense per-element blocks by vertex index; this class owns how they land in the sparse
// matrix. Only the lower triangle is stored (CHOLMOD reads it as symmetric). The first assembly
// records where every element entry goes; later assemblies with the same sequence of element
// stencils (the usual case: elasticity never changes its stencils) scatter straight into the stored
// values without sorting, and report that the sparsity pattern is unchanged so that the Cholesky
// factorization can reuse its symbolic analysis.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "util/parallel.h"

namespace pd {

class HessianAssembly {
 public:
  using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

  // Starts an assembly for `num_dofs` unknowns (3 per vertex). Call before the energies add blocks.
  void begin(int num_dofs);
  // Starts an assembly of the sparsity pattern alone: add() and add_elements() record the element
  // stencils and skip their blocks (add_elements does not call hessian(e)), and finish() returns the
  // pattern with every stored value 0. For a caller that needs the pattern of a Hessian it will not
  // use (ProlongedTerm's first coarse-first assembly: its fine element Hessians took as long as two
  // fine gradients). The next begin() assembles values again, with this pattern already analysed.
  void begin_pattern(int num_dofs);

  // Adds the element Hessian H (3N x 3N, rows/cols ordered as vertex verts[0] xyz, verts[1] xyz, ...).
  template <int N>
  void add(const std::array<int, N>& verts, const Eigen::Matrix<double, 3 * N, 3 * N>& H) {
    push_stencil<N>(verts);
    const size_t first = num_values_;
    reserve_values(first + lower_entry_count<N>(verts));
    if (!pattern_only_) write_lower_entries<N>(verts, H, values_.data() + first);
  }

  // Adds `count` element Hessians at once: verts(e) -> std::array<int, N>, hessian(e) -> the 3N x 3N
  // block, e in [0, count). The same entries in the same order as `count` calls of add(), but the
  // blocks (the costly part: element Hessians and their projections) are computed on every
  // element thread (util/parallel.h), each into its own slice of the values.
  template <int N, class Verts, class Hessian>
  void add_elements(int count, const Verts& verts, const Hessian& hessian) {
    element_offsets_.resize(static_cast<size_t>(count));
    size_t end = num_values_;
    for (int e = 0; e < count; ++e) {
      const std::array<int, N> v = verts(e);
      push_stencil<N>(v);
      element_offsets_[static_cast<size_t>(e)] = end;
      end += lower_entry_count<N>(v);
    }
    reserve_values(end);
    if (pattern_only_) return;
    parallel_for_index(count, [&](int e) {
      write_lower_entries<N>(verts(e), hessian(e), values_.data() + element_offsets_[static_cast<size_t>(e)]);
    });
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
  // rebuild_pattern's parts (hessian_assembly.cpp)
  template <class F>
  void for_element_blocks(int e, F&& f) const;
  void index_elements();
  void build_blocks(std::vector<int>& occurrence_block);
  void build_columns();
  void build_gather(const std::vector<int>& occurrence_block);

  // Makes values_[0, n) usable and num_values_ = n. values_ only grows: it is not cleared between
  // assemblies, which would zero-fill tens of megabytes every Newton iteration. A pattern-only
  // assembly writes no values and leaves it alone (15 MB on flag-large's fine terms).
  void reserve_values(size_t n) {
    if (!pattern_only_ && values_.size() < n) values_.resize(std::max(n, 2 * values_.size()));
    num_values_ = n;
  }
  template <int N>
  void push_stencil(const std::array<int, N>& verts) {
    stencil_.push_back(N);
    for (int a = 0; a < N; ++a) stencil_.push_back(verts[a]);
  }
  // The element's stored entries: its lower triangle over the global dof order (for every vertex
  // pair a, b with verts[a] >= verts[b], the 3x3 block's entries with row >= column).
  template <int N, class F>
  static void for_lower_entries(const std::array<int, N>& verts, F&& f) {
    for (int a = 0; a < N; ++a)
      for (int b = 0; b < N; ++b) {
        if (verts[a] < verts[b]) continue;
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            if (3 * verts[a] + i >= 3 * verts[b] + j) f(3 * a + i, 3 * b + j);
      }
  }
  // The values for_lower_entries stores for the vertex pair (u, w), u = verts[a] >= w = verts[b]:
  // the lower triangle of a diagonal block (6) or a whole block (9).
  static constexpr int block_value_count(int u, int w) { return u == w ? 6 : 9; }
  // The number of entries for_lower_entries visits, counted by vertex pairs (it runs serially for
  // every element of every assembly).
  template <int N>
  static size_t lower_entry_count(const std::array<int, N>& verts) {
    size_t n = 0;
    for (int a = 0; a < N; ++a)
      for (int b = 0; b < N; ++b)
        if (verts[a] >= verts[b]) n += static_cast<size_t>(block_value_count(verts[a], verts[b]));
    return n;
  }
  template <int N>
  static void write_lower_entries(const std::array<int, N>& verts, const Eigen::Matrix<double, 3 * N, 3 * N>& H,
                                  double* out) {
    for_lower_entries<N>(verts, [&](int i, int j) { *out++ = H(i, j); });
  }

  int num_dofs_ = 0;
  std::vector<int> stencil_, previous_stencil_;  // N, v0..vN-1 per element, in call order
  std::vector<double> values_;                   // element entries in call order: [0, num_values_)
  size_t num_values_ = 0;
  std::vector<size_t> element_offsets_;          // add_elements: first value of each element
  Eigen::VectorXd diagonal_;
  // Vertex blocks of the pattern (see rebuild_pattern): block q is (block_row_[q], block_column_[q])
  // in vertices, column vertex w's blocks are [block_first_[w], block_first_[w + 1]). The values of
  // block q's occurrences in elements start at values_[gather_value_[g]] for g in
  // [gather_begin_[q], gather_begin_[q + 1]), ascending.
  std::vector<int> block_first_, block_row_, block_column_;
  std::vector<size_t> gather_begin_, gather_value_;
  // rebuild_pattern's per-element index: first stencil entry, first value, first block occurrence
  std::vector<size_t> element_stencil_, element_first_value_, element_first_block_;
  std::vector<char> fixed_;
  SparseMatrix matrix_;
  bool have_pattern_ = false;
  bool pattern_only_ = false;  // begin_pattern's assembly: stencils only, see there
};

}  // namespace pd
