#include "progressive/galerkin_product.h"

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "util/parallel.h"

namespace pd {

namespace {

// Sorts `ops` by their destination block (stable: each destination keeps its ops in the order they
// were listed) and returns the offsets of each destination's run, destinations 0 .. count - 1.
template <class Op, class Destination>
std::vector<int> group_by_destination(std::vector<Op>& ops, int count, const Destination& destination) {
  std::stable_sort(ops.begin(), ops.end(), [&](const Op& a, const Op& b) { return destination(a) < destination(b); });
  std::vector<int> start(static_cast<size_t>(count) + 1, 0);
  for (const Op& op : ops) ++start[static_cast<size_t>(destination(op)) + 1];
  for (int d = 0; d < count; ++d) start[static_cast<size_t>(d) + 1] += start[static_cast<size_t>(d)];
  return start;
}

// (row block, column block) -> one key.
std::int64_t key(int a, int b) { return (static_cast<std::int64_t>(a) << 32) | static_cast<std::uint32_t>(b); }

// Id of block (a, b) in `ids`, added at the end on first sight; `rows[a]` lists (b, id) as added.
int block_id(std::unordered_map<std::int64_t, int>& ids, std::vector<std::vector<std::pair<int, int>>>* rows, int a,
             int b) {
  const auto [it, added] = ids.try_emplace(key(a, b), static_cast<int>(ids.size()));
  if (added && rows) (*rows)[a].emplace_back(b, it->second);
  return it->second;
}

Eigen::SparseMatrix<double> compressed(const Eigen::SparseMatrix<double>& A) {
  Eigen::SparseMatrix<double> c = A;
  c.makeCompressed();
  return c;
}

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

  std::unordered_map<std::int64_t, int> h_ids, j_ids, m_ids, g_ids;
  std::vector<std::pair<int, int>> h_blocks;  // (a, b) per H block id
  h_slot_.assign(H.nonZeros(), 0);
  h_mirror_.assign(H.nonZeros(), -1);
  for (int c = 0; c < H.outerSize(); ++c)
    for (int k = H.outerIndexPtr()[c]; k < H.outerIndexPtr()[c + 1]; ++k) {
      const int r = H.innerIndexPtr()[k];
      const int a = r / 3, b = c / 3;
      const int id = block_id(h_ids, nullptr, a, b);
      if (id == static_cast<int>(h_blocks.size())) h_blocks.emplace_back(a, b);
      h_slot_[k] = 9 * id + r % 3 + 3 * (c % 3);
      if (a == b && r % 3 != c % 3) h_mirror_[k] = 9 * id + c % 3 + 3 * (r % 3);
    }

  std::vector<std::vector<std::pair<int, int>>> j_rows(nf), m_rows(nf);  // fine a -> (coarse q, id)
  j_slot_.assign(J.nonZeros(), 0);
  for (int c = 0; c < J.outerSize(); ++c)
    for (int k = J.outerIndexPtr()[c]; k < J.outerIndexPtr()[c + 1]; ++k) {
      const int r = J.innerIndexPtr()[k];
      j_slot_[k] = 9 * block_id(j_ids, &j_rows, r / 3, c / 3) + r % 3 + 3 * (c % 3);
    }

  mul_ops_.clear();
  for (int h = 0; h < static_cast<int>(h_blocks.size()); ++h) {
    const auto [a, b] = h_blocks[h];
    for (const auto& [q, j] : j_rows[b]) mul_ops_.push_back({h, j, block_id(m_ids, &m_rows, a, q), false});
    if (a != b)
      for (const auto& [q, j] : j_rows[a]) mul_ops_.push_back({h, j, block_id(m_ids, &m_rows, b, q), true});
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
  for (const auto& [q, p] : g_keys) {
    g_ids.emplace(key(p, q), static_cast<int>(blocks_.size()));
    blocks_.push_back({p, q, Mat3::Zero()});
  }
  gram_ops_.clear();
  for (int a = 0; a < nf; ++a)
    for (const auto& [p, j] : j_rows[a])
      for (const auto& [q, m] : m_rows[a])
        if (p >= q) gram_ops_.push_back({j, m, g_ids.at(key(p, q))});
  mul_start_ = group_by_destination(mul_ops_, static_cast<int>(m_ids.size()), [](const MulOp& op) { return op.m; });
  gram_start_ = group_by_destination(gram_ops_, static_cast<int>(blocks_.size()), [](const GramOp& op) { return op.g; });

  hb_.assign(h_ids.size(), Mat3::Zero());
  jb_.assign(j_ids.size(), Mat3::Zero());
  mb_.assign(m_ids.size(), Mat3::Zero());
  h_pattern_.take(H);
  j_pattern_.take(J);
  ++plans_built_;
}

const std::vector<GalerkinProduct::Block>& GalerkinProduct::compute(const Eigen::SparseMatrix<double>& H_lower,
                                                                    const Eigen::SparseMatrix<double>& J_in) {
  if (H_lower.rows() != H_lower.cols() || H_lower.rows() != J_in.rows() || H_lower.rows() % 3 != 0 ||
      J_in.cols() % 3 != 0)
    throw std::invalid_argument("GalerkinProduct: H is " + std::to_string(H_lower.rows()) + " x " +
                                std::to_string(H_lower.cols()) + " and J " + std::to_string(J_in.rows()) + " x " +
                                std::to_string(J_in.cols()) + ": need a square H with J's rows, all multiples of 3");
  const Eigen::SparseMatrix<double> H_copy = H_lower.isCompressed() ? Eigen::SparseMatrix<double>() : compressed(H_lower);
  const Eigen::SparseMatrix<double> J_copy = J_in.isCompressed() ? Eigen::SparseMatrix<double>() : compressed(J_in);
  const Eigen::SparseMatrix<double>& H = H_lower.isCompressed() ? H_lower : H_copy;
  const Eigen::SparseMatrix<double>& J = J_in.isCompressed() ? J_in : J_copy;
  if (plans_built_ == 0 || !h_pattern_.same_as(H) || !j_pattern_.same_as(J)) build_plans(H, J);

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
