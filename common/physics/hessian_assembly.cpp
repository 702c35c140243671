#include "physics/hessian_assembly.h"

#include <algorithm>

namespace pd {

void HessianAssembly::begin(int num_dofs) {
  if (num_dofs != num_dofs_) have_pattern_ = false;
  num_dofs_ = num_dofs;
  stencil_.clear();
  num_values_ = 0;
  diagonal_ = Eigen::VectorXd::Zero(num_dofs);
}

void HessianAssembly::add_diagonal(const Eigen::VectorXd& d) { diagonal_ += d; }

// Walks the recorded stencils in the same order as add() pushed values, calling f(row, col) for
// every stored (lower-triangle) entry.
template <class F>
static void for_each_entry(const std::vector<int>& stencil, F&& f) {
  for (size_t p = 0; p < stencil.size();) {
    const int n = stencil[p];
    const int* v = &stencil[p + 1];
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        if (v[a] < v[b]) continue;
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) {
            const int r = 3 * v[a] + i, c = 3 * v[b] + j;
            if (r >= c) f(r, c);
          }
      }
    p += 1 + n;
  }
}

void HessianAssembly::rebuild_pattern() {
  // Pattern = every element entry plus the full diagonal (mass and pinned dofs need it).
  std::vector<Eigen::Triplet<double, int>> trip;
  trip.reserve(num_values_ + num_dofs_);
  for_each_entry(stencil_, [&](int r, int c) { trip.emplace_back(r, c, 1.0); });
  for (int i = 0; i < num_dofs_; ++i) trip.emplace_back(i, i, 1.0);
  matrix_.resize(num_dofs_, num_dofs_);
  matrix_.setFromTriplets(trip.begin(), trip.end());
  matrix_.makeCompressed();

  auto slot = [&](int r, int c) {
    const int* begin = matrix_.innerIndexPtr() + matrix_.outerIndexPtr()[c];
    const int* end = matrix_.innerIndexPtr() + matrix_.outerIndexPtr()[c + 1];
    return static_cast<int>(std::lower_bound(begin, end, r) - matrix_.innerIndexPtr());
  };
  // For every matrix slot, the value indices that land in it, ascending (a counting sort of the
  // entries by slot, stable in value order), so that finish() can sum each slot on its own thread
  // in the order a serial scatter in value order would have added them.
  std::vector<int> slot_of;
  slot_of.reserve(num_values_);
  for_each_entry(stencil_, [&](int r, int c) { slot_of.push_back(slot(r, c)); });
  const int nnz = static_cast<int>(matrix_.nonZeros());
  gather_begin_.assign(static_cast<size_t>(nnz) + 1, 0);
  for (int s : slot_of) ++gather_begin_[static_cast<size_t>(s) + 1];
  for (int s = 0; s < nnz; ++s) gather_begin_[static_cast<size_t>(s) + 1] += gather_begin_[static_cast<size_t>(s)];
  gather_value_.resize(slot_of.size());
  std::vector<int> next(gather_begin_.begin(), gather_begin_.end() - 1);
  for (size_t k = 0; k < slot_of.size(); ++k)
    gather_value_[static_cast<size_t>(next[static_cast<size_t>(slot_of[k])]++)] = static_cast<int>(k);
  diagonal_slot_.resize(num_dofs_);
  for (int i = 0; i < num_dofs_; ++i) diagonal_slot_[i] = slot(i, i);
  previous_stencil_ = stencil_;
  have_pattern_ = true;
}

const HessianAssembly::SparseMatrix& HessianAssembly::finish(bool* pattern_changed) {
  const bool changed = !have_pattern_ || stencil_ != previous_stencil_;
  if (changed) rebuild_pattern();
  if (pattern_changed) *pattern_changed = changed;

  // Each slot sums its element values in value order, then the diagonal is added: the additions
  // of a serial scatter in value order, slot by slot, so the result is the same for any thread count.
  double* val = matrix_.valuePtr();
  parallel_for_index(static_cast<int>(matrix_.nonZeros()), [&](int s) {
    double sum = 0.0;
    for (int g = gather_begin_[static_cast<size_t>(s)]; g < gather_begin_[static_cast<size_t>(s) + 1]; ++g)
      sum += values_[static_cast<size_t>(gather_value_[static_cast<size_t>(g)])];
    val[s] = sum;
  });
  for (int i = 0; i < num_dofs_; ++i) val[diagonal_slot_[i]] += diagonal_[i];

  if (!fixed_.empty()) {
    // Zero rows/columns of fixed dofs, then put one on their diagonal: their Newton step is zero.
    for (int c = 0; c < num_dofs_; ++c)
      for (int k = matrix_.outerIndexPtr()[c]; k < matrix_.outerIndexPtr()[c + 1]; ++k) {
        const int r = matrix_.innerIndexPtr()[k];
        if (fixed_[r] || fixed_[c]) val[k] = (r == c) ? 1.0 : 0.0;
      }
  }
  return matrix_;
}

}  // namespace pd
