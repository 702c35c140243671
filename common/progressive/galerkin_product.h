#pragma once
// The Galerkin product G = J^T H J of a prolonged term (prolonged_term.h), computed on 3x3 vertex
// blocks with index plans built once per sparsity pattern.
//
// Why not Eigen's sparse product. The previous code made H full from its lower triangle (two sparse
// copies), then ran J^T (H J) through Eigen's general sparse-sparse product, whose symbolic phase,
// allocations and per-entry bookkeeping ran again at every call, and cut the result into blocks
// through a std::map per column: about a third of a preview's Hessian time on flag-large, where the
// product's arithmetic is small (about 12M multiply-adds at 6 161 fine vertices). Both operands keep
// their patterns for a whole run (J's: every fine vertex's three coarse parents; H's: the fine
// term's elements), so the plans are built on the first call and reused while the patterns repeat.
//
// Order of operations (fixed, so the same inputs give the same bits): M = H J is formed fine block by
// fine block in H's column-major order, then G = J^T M fine vertex by fine vertex. This order is not
// Eigen's, so G differs from the previous code's in the last bits.
// Threads (util/parallel.h's rule): each block of M and of G is summed by one thread from its own list
// of block products, kept in that serial order, so the bits do not depend on the thread count.
//
// Conventions: H is 3 n_f x 3 n_f, lower triangle stored (HessianAssembly::finish's output), J is
// 3 n_f x 3 n_c (stacked coordinates, x[3i + k]); G is given as its lower block triangle (i >= j,
// coarse vertex ids), column by column and, within a column, by ascending row.

#include <Eigen/Sparse>
#include <vector>

#include "geometry/mesh.h"  // Mat3

namespace pd {

class GalerkinProduct {
 public:
  struct Block {
    int i, j;    // coarse vertex ids, i >= j
    Mat3 block;  // rows of vertex i, columns of vertex j
  };

  // G = J^T H J from H's lower triangle and J (variables in that order: fine Hessian, Jacobian).
  // Rebuilds the plans when either pattern differs from the last call's. Throws
  // std::invalid_argument when the sizes do not fit together or a dimension is not a multiple of 3.
  const std::vector<Block>& compute(const Eigen::SparseMatrix<double>& H_lower, const Eigen::SparseMatrix<double>& J);

  // The blocks compute(H_lower, J) would give, each set to zero: the pattern alone, which depends
  // only on H's and J's patterns (their values are not read). Builds the plans as compute() does, so
  // a later compute() on the same patterns pays only the arithmetic. Throws as compute() does.
  const std::vector<Block>& pattern(const Eigen::SparseMatrix<double>& H_lower, const Eigen::SparseMatrix<double>& J);

  // The last compute()'s or pattern()'s blocks (empty before the first).
  const std::vector<Block>& blocks() const { return blocks_; }

  // How many times the plans were built (1 for a run whose patterns never change); for tests.
  int plans_built() const { return plans_built_; }

 private:
  struct Pattern {
    std::vector<int> outer, inner;
    bool same_as(const Eigen::SparseMatrix<double>& A) const;
    void take(const Eigen::SparseMatrix<double>& A);
  };
  void build_plans(const Eigen::SparseMatrix<double>& H_lower, const Eigen::SparseMatrix<double>& J);
  // Checks the sizes and builds the plans unless H's and J's patterns are those of the last call.
  void prepare(const Eigen::SparseMatrix<double>& H_lower, const Eigen::SparseMatrix<double>& J);

  Pattern h_pattern_, j_pattern_;
  int plans_built_ = 0;
  // Scatter of a CSC matrix's value k into a 3x3 block: value_block[k] * 9 + (row % 3) + 3 (col % 3).
  std::vector<int> h_slot_, j_slot_;
  std::vector<int> h_mirror_;        // H value k on a diagonal block off its diagonal: its mirrored slot, else -1
  std::vector<Mat3> hb_, jb_, mb_;   // fine H blocks (a >= b), J blocks (fine a, coarse q), M blocks
  struct MulOp {                     // mb_[m] += (transpose ? hb_[h]^T : hb_[h]) * jb_[j]
    int h, j, m;
    bool transpose;
  };
  struct GramOp {  // blocks_[g].block += jb_[j]^T * mb_[m]
    int j, m, g;
  };
  // Both op lists grouped by the block they add to (stable, so each block's ops stay in the serial
  // order); the ops of M block m are mul_ops_[mul_start_[m], mul_start_[m + 1]), likewise for G.
  std::vector<MulOp> mul_ops_;
  std::vector<int> mul_start_;
  std::vector<GramOp> gram_ops_;
  std::vector<int> gram_start_;
  std::vector<Block> blocks_;
};

}  // namespace pd
