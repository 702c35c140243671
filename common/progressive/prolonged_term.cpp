#include "progressive/prolonged_term.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "util/parallel.h"

namespace pd {

ProlongedHessian parse_prolonged_hessian(const std::string& name) {
  if (name == "galerkin") return ProlongedHessian::Galerkin;
  if (name == "lagged") return ProlongedHessian::Lagged;
  if (name == "coarse") return ProlongedHessian::Coarse;
  if (name == "coarse-first") return ProlongedHessian::CoarseFirst;
  throw std::invalid_argument("unknown prolonged Hessian '" + name + "': use galerkin, lagged, coarse or coarse-first");
}

ProlongationState::ProlongationState(const ShellProlongation& prolongation, const Eigen::VectorXd& coarse_rest,
                                     ProlongedGradient gradient)
    : P_(&prolongation), mode_(gradient) {
  if (coarse_rest.size() != 3 * static_cast<Eigen::Index>(prolongation.num_coarse()))
    throw std::invalid_argument("ProlongationState: the coarse rest positions need 3 entries per coarse vertex");
  if (mode_ == ProlongedGradient::Frozen) offsets_ = prolongation.offsets(as_rows(coarse_rest));
}

bool ProlongationState::refresh(const Eigen::VectorXd& x) {
  if (mode_ == ProlongedGradient::Exact) return false;
  try {
    offsets_ = P_->offsets(as_rows(x));
    return true;
  } catch (const DegenerateProlongationTriangle&) {
    return false;  // keep the last offsets: see the header
  }
}

Eigen::VectorXd ProlongationState::fine_positions(const Eigen::VectorXd& x) const {
  if (mode_ == ProlongedGradient::Frozen) return stacked(P_->apply_frozen(as_rows(x), offsets_));
  if (!y_key_.matches(x)) {
    y_key_.clear();  // stays clear if apply() throws
    cached_y_ = stacked(P_->apply(as_rows(x)));
    y_key_.set(x);
  }
  return cached_y_;
}

const Eigen::SparseMatrix<double>& ProlongationState::jacobian(const Eigen::VectorXd& x) const {
  if (mode_ == ProlongedGradient::Frozen) return P_->U_stacked();
  if (!jacobian_key_.matches(x)) {
    jacobian_key_.clear();
    if (jacobian_.first.empty()) jacobian_ = P_->jacobian_plan();
    P_->jacobian(as_rows(x), jacobian_);
    jacobian_key_.set(x);
  }
  return jacobian_.J;
}

Eigen::VectorXd ProlongationState::restrict(const Eigen::VectorXd& x, const Eigen::VectorXd& g_fine) const {
  if (mode_ == ProlongedGradient::Frozen) return P_->restrict_gradient(g_fine);
  // Column c of J dotted with g, one coarse dof per index, each summed in the column's stored order
  // (Eigen's own order for J^T g): the same bits for every thread count.
  const Eigen::SparseMatrix<double>& J = jacobian(x);
  if (g_fine.size() != J.rows())  // the loop below reads g_fine by J's row indices
    throw std::invalid_argument("ProlongationState::restrict: fine gradient of size " + std::to_string(g_fine.size()) +
                                ", expected " + std::to_string(J.rows()));
  Eigen::VectorXd out(J.cols());
  parallel_for_index(static_cast<int>(J.cols()), [&](int c) {
    double sum = 0.0;
    for (Eigen::SparseMatrix<double>::InnerIterator it(J, c); it; ++it) sum += it.value() * g_fine[it.row()];
    out[c] = sum;
  }, 8);
  return out;
}

namespace {

std::vector<std::unique_ptr<EnergyTerm>> one_or_none(std::unique_ptr<EnergyTerm> term) {
  std::vector<std::unique_ptr<EnergyTerm>> out;
  if (term) out.push_back(std::move(term));
  return out;
}

}  // namespace

ProlongedTerm::ProlongedTerm(std::vector<std::unique_ptr<EnergyTerm>> fine, std::shared_ptr<ProlongationState> state,
                             ProlongedHessian mode, std::vector<std::unique_ptr<EnergyTerm>> coarse_stand_ins)
    : fine_(std::move(fine)), state_(std::move(state)), mode_(mode), coarse_(std::move(coarse_stand_ins)) {
  if (fine_.empty() || !state_) throw std::invalid_argument("ProlongedTerm: needs a fine term and a prolongation state");
  for (const auto& t : fine_) {
    if (!t) throw std::invalid_argument("ProlongedTerm: a fine term is null");
    may_limit_step_ = may_limit_step_ || t->may_limit_step();
  }
  for (const auto& t : coarse_)
    if (!t) throw std::invalid_argument("ProlongedTerm: a coarse stand-in is null");
  if ((mode_ == ProlongedHessian::Coarse || mode_ == ProlongedHessian::CoarseFirst) && coarse_.empty())
    throw std::invalid_argument("ProlongedTerm: the Coarse and CoarseFirst Hessians need a stand-in term on the level's mesh");
}

ProlongedTerm::ProlongedTerm(std::unique_ptr<EnergyTerm> fine, std::shared_ptr<ProlongationState> state,
                             ProlongedHessian mode, std::unique_ptr<EnergyTerm> coarse_stand_in)
    : ProlongedTerm(one_or_none(std::move(fine)), std::move(state), mode, one_or_none(std::move(coarse_stand_in))) {}

std::string ProlongedTerm::name() const {
  std::string out;
  for (const auto& t : fine_) out += (out.empty() ? "" : "+") + t->name();
  return out;
}

double ProlongedTerm::value(const Eigen::VectorXd& x) const {
  try {
    const Eigen::VectorXd y = state_->fine_positions(x);
    double sum = 0.0;
    for (const auto& t : fine_) sum += t->value(y);
    return sum;
  } catch (const DegenerateProlongationTriangle&) {
    return std::numeric_limits<double>::infinity();  // no prolonged shape: see the header
  }
}

std::vector<std::pair<std::string, double>> ProlongedTerm::named_values(const Eigen::VectorXd& x) const {
  std::vector<std::pair<std::string, double>> out;
  try {
    const Eigen::VectorXd y = state_->fine_positions(x);
    for (const auto& t : fine_) out.emplace_back(t->name(), t->value(y));
  } catch (const DegenerateProlongationTriangle&) {
    out.clear();
    for (const auto& t : fine_) out.emplace_back(t->name(), std::numeric_limits<double>::infinity());
  }
  return out;
}

void ProlongedTerm::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  const Eigen::VectorXd y = state_->fine_positions(x);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(y.size());
  for (const auto& t : fine_) t->add_gradient(y, g);
  grad += state_->restrict(x, g);
}

void ProlongedTerm::add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                                HessianAssembly& hessian) const {
  if (mode_ == ProlongedHessian::Coarse) {
    for (const auto& t : coarse_) t->add_hessian(x, projection, hessian);
    return;
  }
  if (mode_ == ProlongedHessian::CoarseFirst && (assemblies_in_step_++ < kCoarseFirstAssemblies || keep_stand_in_)) {
    // The union pattern needs the Galerkin blocks' pattern from the term's first assembly on, not
    // from its first lagged phase: a run continued from stored frames (a new term) must assemble the
    // same pattern as the run it continues, or CHOLMOD orders another matrix and the frames differ
    // in the last bits. The pattern does not depend on x, and no values are computed (computed_at
    // stays -1, so the step's first lagged assembly computes its own): on flag-large's ten-frame
    // preview the first assembly took 0.065 s with the values.
    if (lagged_[last_lagged_].product.blocks().empty())
      compute_galerkin_blocks(x, projection, lagged_[last_lagged_].product, /*values=*/false);
    compute_coarse_blocks(x, projection);
    add_blocks(coarse_blocks_, lagged_[last_lagged_].product.blocks(), hessian);
    return;
  }
  LaggedBlocks& set = lagged_.at(static_cast<std::size_t>(projection));
  const int now = lagged_assemblies_++;
  if (mode_ == ProlongedHessian::Galerkin || set.computed_at < 0 || now - set.computed_at >= kLaggedRefreshEvery) {
    compute_galerkin_blocks(x, projection, set.product);
    set.computed_at = now;
    last_lagged_ = static_cast<std::size_t>(projection);
  }
  add_blocks(set.product.blocks(), coarse_blocks_, hessian);
}

namespace {

// (column, row) order of lower-triangle blocks: the order both block lists are kept in.
bool before(const GalerkinProduct::Block& a, const GalerkinProduct::Block& b) {
  return a.j != b.j ? a.j < b.j : a.i < b.i;
}

void add_block(int i, int j, const Mat3& block, HessianAssembly& hessian) {
  if (i == j) {
    hessian.add<1>({i}, block);
  } else {
    Eigen::Matrix<double, 6, 6> pair = Eigen::Matrix<double, 6, 6>::Zero();
    pair.block<3, 3>(0, 3) = block;
    hessian.add<2>({i, j}, pair);
  }
}

}  // namespace

// A diagonal block as a one-vertex element, an off-diagonal block (i > j) as the (i, j) block of a
// two-vertex element whose other blocks are zero. Every block of `values` is added, and every block
// of `pattern_only` that `values` lacks is added as zero, in (column, row) order: the coarse-first
// Hessian's two phases then give the assembly the same stencil sequence, so the coarse matrix's
// pattern is analysed once, not at every switch. Both lists depend only on the meshes and the
// prolongation's sparsity pattern, so the sequence repeats from one assembly to the next.
void ProlongedTerm::add_blocks(const std::vector<GalerkinProduct::Block>& values,
                               const std::vector<GalerkinProduct::Block>& pattern_only, HessianAssembly& hessian) const {
  std::size_t a = 0, b = 0;
  while (a < values.size() || b < pattern_only.size()) {
    if (b == pattern_only.size() || (a < values.size() && !before(pattern_only[b], values[a]))) {
      if (b < pattern_only.size() && !before(values[a], pattern_only[b])) ++b;  // the same block in both
      add_block(values[a].i, values[a].j, values[a].block, hessian);
      ++a;
    } else {
      add_block(pattern_only[b].i, pattern_only[b].j, Mat3::Zero(), hessian);
      ++b;
    }
  }
}

// The stand-in's Hessian on the level's mesh (each element projected as asked) as its lower 3x3
// blocks in (column, row) order.
void ProlongedTerm::compute_coarse_blocks(const Eigen::VectorXd& x, HessianProjection projection) const {
  coarse_hessian_.begin(static_cast<int>(x.size()));
  for (const auto& t : coarse_) t->add_hessian(x, projection, coarse_hessian_);
  const HessianAssembly::SparseMatrix& H = coarse_hessian_.finish(nullptr);
  coarse_blocks_.clear();
  for (int j = 0; 3 * j < H.outerSize(); ++j) {
    const std::size_t first = coarse_blocks_.size();
    for (int c = 3 * j; c < 3 * j + 3; ++c)
      for (HessianAssembly::SparseMatrix::InnerIterator it(H, c); it; ++it) {
        const int i = static_cast<int>(it.row()) / 3;
        auto found = std::find_if(coarse_blocks_.begin() + static_cast<std::ptrdiff_t>(first), coarse_blocks_.end(),
                                  [i](const GalerkinProduct::Block& blk) { return blk.i == i; });
        if (found == coarse_blocks_.end()) {
          coarse_blocks_.push_back({i, j, Mat3::Zero()});
          found = coarse_blocks_.end() - 1;
        }
        found->block(static_cast<int>(it.row()) % 3, c % 3) = it.value();
      }
    std::sort(coarse_blocks_.begin() + static_cast<std::ptrdiff_t>(first), coarse_blocks_.end(), before);
  }
}

// The fine Hessian (each element block projected as asked) carried through the prolongation's
// Jacobian (U when frozen): its lower block triangle, from galerkin_product.h.
void ProlongedTerm::compute_galerkin_blocks(const Eigen::VectorXd& x, HessianProjection projection,
                                            GalerkinProduct& product, bool values) const {
  if (values)
    fine_hessian_.begin(3 * state_->num_fine());
  else
    fine_hessian_.begin_pattern(3 * state_->num_fine());
  const Eigen::VectorXd y = state_->fine_positions(x);
  for (const auto& t : fine_) t->add_hessian(y, projection, fine_hessian_);
  if (values)
    product.compute(fine_hessian_.finish(nullptr), state_->jacobian(x));
  else
    product.pattern(fine_hessian_.finish(nullptr), state_->jacobian(x));
}

double ProlongedTerm::max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const {
  if (!may_limit_step_) return 1.0;
  const Eigen::VectorXd y = state_->fine_positions(x);
  const Eigen::VectorXd dy = state_->jacobian(x) * dx;
  double alpha = 1.0;
  for (const auto& t : fine_) alpha = std::min(alpha, t->max_step(y, dy));
  return alpha;
}

// Only coarse-first counts its assemblies, and only its add_hessian reads the keep.
bool ProlongedTerm::stand_in_hessian_ends() const {
  return !keep_stand_in_ && assemblies_in_step_ == kCoarseFirstAssemblies;
}

void ProlongedTerm::keep_stand_in_hessian(bool keep) const { keep_stand_in_ = keep; }

void ProlongedTerm::begin_step(const StepStart& step) {
  for (LaggedBlocks& set : lagged_) set.computed_at = -1;
  lagged_assemblies_ = 0;
  assemblies_in_step_ = 0;
  keep_stand_in_ = false;
  StepStart fine = step;
  Eigen::VectorXd x_fine, v_fine;
  if (step.x) {
    x_fine = state_->fine_positions(*step.x);
    fine.x = &x_fine;
  }
  if (step.v) {
    // The prolonged shape's velocity at the start; without positions, U v (the rigid-free part).
    v_fine = step.x ? Eigen::VectorXd(state_->jacobian(*step.x) * *step.v) : Eigen::VectorXd(state_->U() * *step.v);
    fine.v = &v_fine;
  }
  for (const auto& t : fine_) t->begin_step(fine);
}

}  // namespace pd
