#include "solver/cholmod_solver.h"

#include <chrono>
#include <cmath>

#include <Eigen/CholmodSupport>

// OpenBLAS (linked directly, ahead of the system BLAS that CHOLMOD was built against).
extern "C" void openblas_set_num_threads(int num_threads);

namespace pd {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

struct CholmodSolver::Impl {
  Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower> llt;
  bool analysed = false;
};

CholmodSolver::CholmodSolver() : impl_(std::make_unique<Impl>()) {
  // One BLAS thread: threaded dgemm/dsyrk split their sums by thread count, so frames would differ
  // in the last bits between machines with different core counts, and the farm promises the same
  // frames whichever worker ran a task. (On 2 cores threading also cost more than it gained for
  // cloth-sized supernodes: measured in docs/performance.md.)
  openblas_set_num_threads(1);
  // A failed factorization is handled here (shifted retry), so CHOLMOD must not print on its own.
  impl_->llt.cholmod().print = 0;
}
CholmodSolver::~CholmodSolver() = default;

bool CholmodSolver::factorize(const SparseMatrix& lower, bool pattern_changed, bool shift_if_indefinite) {
  analyse_seconds_ = factorize_seconds_ = 0.0;
  if (pattern_changed || !impl_->analysed) {
    const auto t0 = std::chrono::steady_clock::now();
    impl_->llt.analyzePattern(lower);
    impl_->analysed = true;
    ++analyses_;
    analyse_seconds_ = seconds_since(t0);
  }
  const auto t0 = std::chrono::steady_clock::now();
  impl_->llt.setShift(0.0);
  impl_->llt.factorize(lower);
  last_shift_ = 0.0;
  if (impl_->llt.info() != Eigen::Success && shift_if_indefinite) {
    // Only reached with an indefinite Hessian (projection "none", or round-off in a nearly singular
    // system). A shift turns Newton into a damped step; it stays a descent direction.
    const double mean_diag = std::abs(lower.diagonal().mean());
    double shift = 1e-8 * (mean_diag > 0 ? mean_diag : 1.0);
    for (int attempt = 0; attempt < 40 && impl_->llt.info() != Eigen::Success; ++attempt) {
      impl_->llt.setShift(shift);
      impl_->llt.factorize(lower);
      last_shift_ = shift;
      shift *= 10.0;
    }
  }
  factorize_seconds_ = seconds_since(t0);
  return impl_->llt.info() == Eigen::Success;
}

Eigen::VectorXd CholmodSolver::solve(const Eigen::VectorXd& b) const { return impl_->llt.solve(b); }

}  // namespace pd
