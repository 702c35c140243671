#include "physics/hessian_assembly.h"

#include <algorithm>

namespace pd {

void HessianAssembly::begin(int num_dofs) {
  if (num_dofs != num_dofs_) have_pattern_ = false;
  num_dofs_ = num_dofs;
  stencil_.clear();
  values_.clear();
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
  trip.reserve(values_.size() + num_dofs_);
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
  scatter_.clear();
  scatter_.reserve(values_.size());
  for_each_entry(stencil_, [&](int r, int c) { scatter_.push_back(slot(r, c)); });
  diagonal_slot_.resize(num_dofs_);
  for (int i = 0; i < num_dofs_; ++i) diagonal_slot_[i] = slot(i, i);
  previous_stencil_ = stencil_;
  have_pattern_ = true;
}

const HessianAssembly::SparseMatrix& HessianAssembly::finish(bool* pattern_changed) {
  const bool changed = !have_pattern_ || stencil_ != previous_stencil_;
  if (changed) rebuild_pattern();
  if (pattern_changed) *pattern_changed = changed;

  double* val = matrix_.valuePtr();
  std::fill(val, val + matrix_.nonZeros(), 0.0);
  for (size_t k = 0; k < values_.size(); ++k) val[scatter_[k]] += values_[k];
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
