#include "physics/hessian_assembly.h"

#include <algorithm>
#include <stdexcept>

namespace pd {

void HessianAssembly::begin(int num_dofs) {
  if (num_dofs != num_dofs_) have_pattern_ = false;
  num_dofs_ = num_dofs;
  stencil_.clear();
  num_values_ = 0;
  diagonal_ = Eigen::VectorXd::Zero(num_dofs);
  pattern_only_ = false;
}

void HessianAssembly::begin_pattern(int num_dofs) {
  begin(num_dofs);
  pattern_only_ = true;
}

void HessianAssembly::add_diagonal(const Eigen::VectorXd& d) { diagonal_ += d; }

namespace {
// Where entry (i, j) of a vertex block lies among an element's values for that block
// (for_lower_entries' order): a diagonal block stores its lower triangle row by row, (0,0), (1,0),
// (1,1), (2,0), (2,1), (2,2); any other block all nine entries row by row.
constexpr int kDiagonalOffset[3][3] = {{0, -1, -1}, {1, 2, -1}, {3, 4, 5}};
}  // namespace

// The pattern is built on vertex blocks, not entry by entry: an element of N vertices touches
// N(N+1)/2 vertex blocks but up to 78 lower entries (N = 4), and with self-contact the pattern
// changes in about half of the Newton iterations (docs/performance.md, "Contact step cost"). The
// matrix is the same as an entry-wise build: the lower triangle of the union of the element
// blocks, plus the whole diagonal.
//
// Layout (compressed columns, rows ascending): for vertex w, column 3w + j (j = 0..2) holds, if w
// is in some element, the rows 3w + j..3w + 2 of its own diagonal block, then 3u..3u + 2 for every
// other vertex u > w sharing an element with w, u ascending; if w is in no element, only row 3w + j.
// Blocks are numbered column vertex by column vertex, rows ascending within one: block_first_[w]
// is (w, w) whenever w has blocks (every element holding w has the block (w, w)).
void HessianAssembly::rebuild_pattern() {
  index_elements();
  std::vector<int> occurrence_block;
  build_blocks(occurrence_block);
  build_columns();
  build_gather(occurrence_block);
  previous_stencil_ = stencil_;
  have_pattern_ = true;
}

// Visits element e's vertex blocks in value order (for_lower_entries' vertex pairs a, b with
// v[a] >= v[b]): f(row vertex, column vertex, number of values).
template <class F>
void HessianAssembly::for_element_blocks(int e, F&& f) const {
  const size_t p = element_stencil_[static_cast<size_t>(e)];
  const int n = stencil_[p];
  const int* v = &stencil_[p + 1];
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      if (v[a] >= v[b]) f(v[a], v[b], block_value_count(v[a], v[b]));
}

void HessianAssembly::index_elements() {
  element_stencil_.clear();
  for (size_t p = 0; p < stencil_.size(); p += 1 + static_cast<size_t>(stencil_[p])) element_stencil_.push_back(p);
  const int num_elements = static_cast<int>(element_stencil_.size());
  element_first_value_.assign(static_cast<size_t>(num_elements) + 1, 0);
  element_first_block_.assign(static_cast<size_t>(num_elements) + 1, 0);
  for (int e = 0; e < num_elements; ++e) {
    size_t values = 0, blocks = 0;
    for_element_blocks(e, [&](int, int, int count) {
      values += static_cast<size_t>(count);
      ++blocks;
    });
    element_first_value_[static_cast<size_t>(e) + 1] = element_first_value_[static_cast<size_t>(e)] + values;
    element_first_block_[static_cast<size_t>(e) + 1] = element_first_block_[static_cast<size_t>(e)] + blocks;
  }
  if (element_first_value_.back() != num_values_)
    throw std::logic_error("HessianAssembly: the stencils do not match the values added");
}

// The pattern's blocks: every element's, by column vertex (counted, filled, then sorted and made
// unique per column). occurrence_block: the block of each element block, in value order.
void HessianAssembly::build_blocks(std::vector<int>& occurrence_block) {
  const int nv = (num_dofs_ + 2) / 3;
  const int num_elements = static_cast<int>(element_stencil_.size());
  std::vector<int> begin(static_cast<size_t>(nv) + 1, 0);
  for (int e = 0; e < num_elements; ++e) for_element_blocks(e, [&](int, int w, int) { ++begin[static_cast<size_t>(w) + 1]; });
  for (int w = 0; w < nv; ++w) begin[static_cast<size_t>(w) + 1] += begin[static_cast<size_t>(w)];
  std::vector<int> rows(static_cast<size_t>(begin[static_cast<size_t>(nv)]));
  std::vector<int> next(begin.begin(), begin.end() - 1);
  for (int e = 0; e < num_elements; ++e)
    for_element_blocks(e, [&](int u, int w, int) { rows[static_cast<size_t>(next[static_cast<size_t>(w)]++)] = u; });
  std::vector<int> count(static_cast<size_t>(nv));
  parallel_for_index(nv, [&](int w) {
    int* first = rows.data() + begin[static_cast<size_t>(w)];
    int* last = rows.data() + begin[static_cast<size_t>(w) + 1];
    std::sort(first, last);
    count[static_cast<size_t>(w)] = static_cast<int>(std::unique(first, last) - first);
  });
  block_first_.assign(static_cast<size_t>(nv) + 1, 0);
  for (int w = 0; w < nv; ++w) block_first_[static_cast<size_t>(w) + 1] = block_first_[static_cast<size_t>(w)] + count[static_cast<size_t>(w)];
  const int num_blocks = block_first_[static_cast<size_t>(nv)];
  block_row_.resize(static_cast<size_t>(num_blocks));
  block_column_.resize(static_cast<size_t>(num_blocks));
  parallel_for_index(nv, [&](int w) {
    for (int k = 0; k < count[static_cast<size_t>(w)]; ++k) {
      const size_t q = static_cast<size_t>(block_first_[static_cast<size_t>(w)] + k);
      block_row_[q] = rows[static_cast<size_t>(begin[static_cast<size_t>(w)] + k)];
      block_column_[q] = w;
    }
  });
  occurrence_block.resize(element_first_block_.back());
  parallel_for_index(num_elements, [&](int e) {
    int* out = occurrence_block.data() + element_first_block_[static_cast<size_t>(e)];
    for_element_blocks(e, [&](int u, int w, int) {
      const int* first = block_row_.data() + block_first_[static_cast<size_t>(w)];
      const int* last = block_row_.data() + block_first_[static_cast<size_t>(w) + 1];
      *out++ = static_cast<int>(std::lower_bound(first, last, u) - block_row_.data());
    });
  });
}

// The compressed columns of the layout above; values zero until finish().
void HessianAssembly::build_columns() {
  const auto blocks_of = [&](int w) { return block_first_[static_cast<size_t>(w) + 1] - block_first_[static_cast<size_t>(w)]; };
  matrix_ = SparseMatrix(num_dofs_, num_dofs_);
  int* column_begin = matrix_.outerIndexPtr();
  for (int c = 0; c < num_dofs_; ++c) {
    const int j = c % 3, blocks = blocks_of(c / 3);
    column_begin[c + 1] = column_begin[c] + (blocks == 0 ? 1 : (3 - j) + 3 * (blocks - 1));
  }
  matrix_.resizeNonZeros(column_begin[num_dofs_]);
  int* rows = matrix_.innerIndexPtr();
  parallel_for_index(num_dofs_, [&](int c) {
    const int w = c / 3, j = c % 3;
    int* out = rows + column_begin[c];
    if (blocks_of(w) == 0) {
      *out = c;
      return;
    }
    for (int i = j; i < 3; ++i) *out++ = 3 * w + i;
    for (int q = block_first_[static_cast<size_t>(w)] + 1; q < block_first_[static_cast<size_t>(w) + 1]; ++q)
      for (int i = 0; i < 3; ++i) *out++ = 3 * block_row_[static_cast<size_t>(q)] + i;
  });
  std::fill(matrix_.valuePtr(), matrix_.valuePtr() + matrix_.nonZeros(), 0.0);
}

// For every block, the first value of each of its occurrences, ascending (a counting sort of the
// occurrences by block, stable in value order), so that finish() sums every entry of a block on
// one thread in the order a serial scatter in value order would have added them.
void HessianAssembly::build_gather(const std::vector<int>& occurrence_block) {
  const size_t num_blocks = block_row_.size();
  gather_begin_.assign(num_blocks + 1, 0);
  for (int q : occurrence_block) ++gather_begin_[static_cast<size_t>(q) + 1];
  for (size_t q = 0; q < num_blocks; ++q) gather_begin_[q + 1] += gather_begin_[q];
  gather_value_.resize(occurrence_block.size());
  std::vector<size_t> next(gather_begin_.begin(), gather_begin_.end() - 1);
  size_t occurrence = 0;
  for (int e = 0; e < static_cast<int>(element_stencil_.size()); ++e) {
    size_t value = element_first_value_[static_cast<size_t>(e)];
    for_element_blocks(e, [&](int, int, int count) {
      gather_value_[next[static_cast<size_t>(occurrence_block[occurrence++])]++] = value;
      value += static_cast<size_t>(count);
    });
  }
}

const HessianAssembly::SparseMatrix& HessianAssembly::finish(bool* pattern_changed) {
  const bool changed = !have_pattern_ || stencil_ != previous_stencil_;
  if (changed) rebuild_pattern();
  if (pattern_changed) *pattern_changed = changed;
  if (pattern_only_) {  // no element values were written: see begin_pattern
    std::fill(matrix_.valuePtr(), matrix_.valuePtr() + matrix_.nonZeros(), 0.0);
    return matrix_;
  }

  // Each entry sums its element values in value order, then the diagonal is added and fixed dofs
  // are made identity rows and columns: the operations of a serial scatter in value order, entry by
  // entry, so the result is the same for any thread count. A block's entries are summed together,
  // one occurrence (a contiguous run of 6 or 9 values) at a time, so that each run is read once.
  double* val = matrix_.valuePtr();
  const int* column_begin = matrix_.outerIndexPtr();
  const auto fixed = [&](int dof) { return !fixed_.empty() && fixed_[static_cast<size_t>(dof)]; };
  parallel_for_index(static_cast<int>(block_row_.size()), [&](int q) {
    const int u = block_row_[static_cast<size_t>(q)], w = block_column_[static_cast<size_t>(q)];
    const int k = q - block_first_[static_cast<size_t>(w)];  // position in column w (0: the diagonal block)
    const int count = block_value_count(u, w);
    const size_t g0 = gather_begin_[static_cast<size_t>(q)], g1 = gather_begin_[static_cast<size_t>(q) + 1];
    double sum[9] = {};  // by position in the run (kDiagonalOffset's for the diagonal block)
    for (size_t g = g0; g < g1; ++g) {
      const double* run = values_.data() + gather_value_[g];
      for (int o = 0; o < count; ++o) sum[o] += run[o];
    }
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        if (k == 0 && i < j) continue;  // the upper part of a diagonal block is not stored
        double entry = sum[k == 0 ? kDiagonalOffset[i][j] : 3 * i + j];
        const int r = 3 * u + i, c = 3 * w + j;
        if (r == c) entry += diagonal_[c];
        if (fixed(r) || fixed(c)) entry = r == c ? 1.0 : 0.0;
        val[column_begin[c] + (k == 0 ? i - j : (3 - j) + 3 * (k - 1) + i)] = entry;
      }
  });
  // Dofs of vertices in no element: the diagonal alone.
  for (int c = 0; c < num_dofs_; ++c)
    if (block_first_[static_cast<size_t>(c / 3)] == block_first_[static_cast<size_t>(c / 3) + 1])
      val[column_begin[c]] = fixed(c) ? 1.0 : 0.0 + diagonal_[c];
  return matrix_;
}

}  // namespace pd
