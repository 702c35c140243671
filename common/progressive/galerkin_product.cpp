#include "progressive/galerkin_product.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

#include "util/parallel.h"

namespace pd {

namespace {

// Groups `ops` by their destination block, destinations 0 .. count - 1, each keeping its ops in the
// order they were listed (a counting sort: what a stable sort by destination gives, in linear time;
// the stable sort took a quarter of the plans' 28 ms on flag-large), and returns the offsets of each
// destination's run.
template <class Op, class Destination>
std::vector<int> group_by_destination(std::vector<Op>& ops, int count, const Destination& destination) {
  std::vector<int> start(static_cast<size_t>(count) + 1, 0);
  for (const Op& op : ops) ++start[static_cast<size_t>(destination(op)) + 1];
  for (int d = 0; d < count; ++d) start[static_cast<size_t>(d) + 1] += start[static_cast<size_t>(d)];
  std::vector<int> next(start.begin(), start.end() - 1);
  std::vector<Op> grouped(ops.size());
  for (const Op& op : ops) grouped[static_cast<size_t>(next[static_cast<size_t>(destination(op))]++)] = op;
  ops = std::move(grouped);
  return start;
}

// The 3x3 blocks of a CSC matrix's pattern, numbered in the order their first stored value comes
// (column by column, rows ascending). A column block's stored values are contiguous, so a row block
// stamped with the current column block has its id already: no search. rows[a], when given, lists
// (column block, id) of row block a in that order.
struct BlockIds {
  std::vector<int> slot;                    // per stored value k: 9 id + row % 3 + 3 (column % 3)
  std::vector<std::pair<int, int>> blocks;  // (row block, column block) per id
};
BlockIds block_ids(const Eigen::SparseMatrix<double>& A, std::vector<std::vector<std::pair<int, int>>>* rows) {
  BlockIds out;
  out.slot.resize(static_cast<size_t>(A.nonZeros()));
  std::vector<int> stamp(static_cast<size_t>(A.rows() / 3), -1), id_of(static_cast<size_t>(A.rows() / 3));
  for (int c = 0; c < A.outerSize(); ++c)
    for (int k = A.outerIndexPtr()[c]; k < A.outerIndexPtr()[c + 1]; ++k) {
      const int r = A.innerIndexPtr()[k];
      const auto a = static_cast<size_t>(r / 3);
      const int b = c / 3;
      if (stamp[a] != b) {
        stamp[a] = b;
        id_of[a] = static_cast<int>(out.blocks.size());
        out.blocks.emplace_back(r / 3, b);
        if (rows) (*rows)[a].emplace_back(b, id_of[a]);
      }
      out.slot[static_cast<size_t>(k)] = 9 * id_of[a] + r % 3 + 3 * (c % 3);
    }
  return out;
}

// Id of M block (a, q), looked up in row a's list (a fine vertex's neighbours reach a few coarse
// vertices) and added there with the next id on first sight.
int m_block_id(std::vector<std::vector<std::pair<int, int>>>& m_rows, int& m_count, int a, int q) {
  auto& row = m_rows[static_cast<size_t>(a)];
  for (const auto& [column, id] : row)
    if (column == q) return id;
  row.emplace_back(q, m_count);
  return m_count++;
}

// A matrix in compressed form (the plans index its arrays): the matrix itself when it is, else a
// compressed copy.
class Compressed {
 public:
  explicit Compressed(const Eigen::SparseMatrix<double>& A) : copy_(A.isCompressed() ? Eigen::SparseMatrix<double>() : A) {
    copy_.makeCompressed();
    matrix_ = A.isCompressed() ? &A : &copy_;
  }
  const Eigen::SparseMatrix<double>& get() const { return *matrix_; }

 private:
  Eigen::SparseMatrix<double> copy_;
  const Eigen::SparseMatrix<double>* matrix_;
};

}  // namespace

bool GalerkinProduct::Pattern::same_as(const Eigen::SparseMatrix<double>& A) const {
  if (outer.size() != static_cast<size_t>(A.outerSize() + 1) || inner.size() != static_cast<size_t>(A.nonZeros()))
    return false;
  return std::equal(outer.begin(), outer.end(), A.outerIndexPtr()) &&
         std::equal(inner.begin(), inner.end(), A.innerIndexPtr());
}

void GalerkinProduct::Pattern::take(const Eigen::SparseMatrix<double>& A) {
  outer.assign(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1);
  inner.assign(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
}

// The plans: where each stored value of H and J goes among the 3x3 blocks, which block products
// form M = H J, and which form G = J^T M (only G's lower block triangle, p >= q).
void GalerkinProduct::build_plans(const Eigen::SparseMatrix<double>& H, const Eigen::SparseMatrix<double>& J) {
  const int nf = static_cast<int>(H.rows() / 3);

  BlockIds h_ids = block_ids(H, nullptr);
  h_slot_ = std::move(h_ids.slot);
  h_mirror_.assign(static_cast<size_t>(H.nonZeros()), -1);
  for (int c = 0; c < H.outerSize(); ++c)
    for (int k = H.outerIndexPtr()[c]; k < H.outerIndexPtr()[c + 1]; ++k) {
      const int r = H.innerIndexPtr()[k];
      if (r / 3 == c / 3 && r % 3 != c % 3) h_mirror_[k] = h_slot_[k] - h_slot_[k] % 9 + c % 3 + 3 * (r % 3);
    }
  const std::vector<std::pair<int, int>>& h_blocks = h_ids.blocks;

  std::vector<std::vector<std::pair<int, int>>> j_rows(nf), m_rows(nf);  // fine a -> (coarse q, id)
  BlockIds j_ids = block_ids(J, &j_rows);
  j_slot_ = std::move(j_ids.slot);

  std::size_t mul_count = 0;
  for (const auto& [a, b] : h_blocks) mul_count += j_rows[b].size() + (a != b ? j_rows[a].size() : 0);
  mul_ops_.clear();
  mul_ops_.reserve(mul_count);
  int m_count = 0;
  for (int h = 0; h < static_cast<int>(h_blocks.size()); ++h) {
    const auto [a, b] = h_blocks[h];
    for (const auto& [q, j] : j_rows[b]) mul_ops_.push_back({h, j, m_block_id(m_rows, m_count, a, q), false});
    if (a != b)
      for (const auto& [q, j] : j_rows[a]) mul_ops_.push_back({h, j, m_block_id(m_rows, m_count, b, q), true});
  }

  // G's blocks sorted column by column, rows ascending (the order the coarse assembly sees).
  std::vector<std::pair<int, int>> g_keys;  // (q, p)
  for (int a = 0; a < nf; ++a)
    for (const auto& [p, j] : j_rows[a])
      for (const auto& [q, m] : m_rows[a])
        if (p >= q) g_keys.emplace_back(q, p);
  std::sort(g_keys.begin(), g_keys.end());
  g_keys.erase(std::unique(g_keys.begin(), g_keys.end()), g_keys.end());
  blocks_.clear();
  std::vector<int> g_column_start(static_cast<size_t>(J.cols() / 3) + 1, 0);  // blocks_ of column q
  for (const auto& [q, p] : g_keys) {
    blocks_.push_back({p, q, Mat3::Zero()});
    ++g_column_start[static_cast<size_t>(q) + 1];
  }
  for (size_t q = 1; q < g_column_start.size(); ++q) g_column_start[q] += g_column_start[q - 1];
  const auto g_id = [&](int p, int q) {  // G block (p, q): a binary search in column q's rows
    const auto first = blocks_.begin() + g_column_start[static_cast<size_t>(q)];
    const auto last = blocks_.begin() + g_column_start[static_cast<size_t>(q) + 1];
    return static_cast<int>(std::lower_bound(first, last, p, [](const Block& b, int row) { return b.i < row; }) -
                            blocks_.begin());
  };
  gram_ops_.clear();
  for (int a = 0; a < nf; ++a)
    for (const auto& [p, j] : j_rows[a])
      for (const auto& [q, m] : m_rows[a])
        if (p >= q) gram_ops_.push_back({j, m, g_id(p, q)});
  mul_start_ = group_by_destination(mul_ops_, m_count, [](const MulOp& op) { return op.m; });
  gram_start_ = group_by_destination(gram_ops_, static_cast<int>(blocks_.size()), [](const GramOp& op) { return op.g; });

  hb_.assign(h_blocks.size(), Mat3::Zero());
  jb_.assign(j_ids.blocks.size(), Mat3::Zero());
  mb_.assign(static_cast<size_t>(m_count), Mat3::Zero());
  h_pattern_.take(H);
  j_pattern_.take(J);
  ++plans_built_;
}

void GalerkinProduct::prepare(const Eigen::SparseMatrix<double>& H, const Eigen::SparseMatrix<double>& J) {
  if (H.rows() != H.cols() || H.rows() != J.rows() || H.rows() % 3 != 0 || J.cols() % 3 != 0)
    throw std::invalid_argument("GalerkinProduct: H is " + std::to_string(H.rows()) + " x " +
                                std::to_string(H.cols()) + " and J " + std::to_string(J.rows()) + " x " +
                                std::to_string(J.cols()) + ": need a square H with J's rows, all multiples of 3");
  if (plans_built_ == 0 || !h_pattern_.same_as(H) || !j_pattern_.same_as(J)) build_plans(H, J);
}

const std::vector<GalerkinProduct::Block>& GalerkinProduct::pattern(const Eigen::SparseMatrix<double>& H_lower,
                                                                    const Eigen::SparseMatrix<double>& J) {
  prepare(Compressed(H_lower).get(), Compressed(J).get());
  for (Block& b : blocks_) b.block.setZero();
  return blocks_;
}

const std::vector<GalerkinProduct::Block>& GalerkinProduct::compute(const Eigen::SparseMatrix<double>& H_lower,
                                                                    const Eigen::SparseMatrix<double>& J_in) {
  const Compressed H_compressed(H_lower), J_compressed(J_in);
  const Eigen::SparseMatrix<double>& H = H_compressed.get();
  const Eigen::SparseMatrix<double>& J = J_compressed.get();
  prepare(H, J);

  // A pattern need not store every entry of its blocks: the rest stay zero.
  for (Mat3& b : hb_) b.setZero();
  for (Mat3& b : jb_) b.setZero();
  double* h = hb_.empty() ? nullptr : hb_.front().data();
  parallel_for_index(static_cast<int>(h_slot_.size()), [&](int k) {
    h[h_slot_[k]] = H.valuePtr()[k];
    if (h_mirror_[k] >= 0) h[h_mirror_[k]] = H.valuePtr()[k];
  }, 4096);
  double* j = jb_.empty() ? nullptr : jb_.front().data();
  parallel_for_index(static_cast<int>(j_slot_.size()), [&](int k) { j[j_slot_[k]] = J.valuePtr()[k]; }, 4096);

  parallel_for_index(static_cast<int>(mb_.size()), [&](int m) {
    Mat3& out = mb_[static_cast<size_t>(m)];
    out.setZero();
    for (int o = mul_start_[static_cast<size_t>(m)]; o < mul_start_[static_cast<size_t>(m) + 1]; ++o) {
      const MulOp& op = mul_ops_[static_cast<size_t>(o)];
      if (op.transpose)
        out.noalias() += hb_[op.h].transpose() * jb_[op.j];
      else
        out.noalias() += hb_[op.h] * jb_[op.j];
    }
  });
  // G has few blocks (coarse vertex pairs), each with many products: small tasks.
  parallel_for_index(static_cast<int>(blocks_.size()), [&](int g) {
    Mat3& out = blocks_[static_cast<size_t>(g)].block;
    out.setZero();
    for (int o = gram_start_[static_cast<size_t>(g)]; o < gram_start_[static_cast<size_t>(g) + 1]; ++o) {
      const GramOp& op = gram_ops_[static_cast<size_t>(o)];
      out.noalias() += jb_[op.j].transpose() * mb_[op.m];
    }
  }, 4);
  return blocks_;
}

}  // namespace pd
