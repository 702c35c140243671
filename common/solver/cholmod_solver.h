#pragma once
// Sparse Cholesky for the Newton systems, through CHOLMOD's supernodal factorization (Eigen's
// CholmodSupport binding). The symbolic analysis (fill-reducing ordering, supernode structure) is
// the expensive part for cloth meshes and depends only on the sparsity pattern, so it is redone
// only when the caller says the pattern changed.
#include <memory>

#include <Eigen/SparseCore>

namespace pd {

class CholmodSolver {
 public:
  using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

  CholmodSolver();
  ~CholmodSolver();
  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  // Factorizes A (symmetric; only its lower triangle is read). Re-analyses when pattern_changed or
  // on the first call. If A is not numerically positive definite, retries with a growing multiple of
  // the identity added (starting at 1e-8 times the mean diagonal) and reports the shift used.
  // Returns false only if even a large shift fails (non-finite entries). With shift_if_indefinite
  // false it returns false as soon as A is found not positive definite (the caller has a better
  // fallback than damping, e.g. a projected Hessian).
  bool factorize(const SparseMatrix& lower, bool pattern_changed, bool shift_if_indefinite = true);

  // Solves A x = b with the last successful factorization.
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;

  double last_shift() const { return last_shift_; }   // diagonal shift of the last factorization
  int analyses() const { return analyses_; }          // symbolic analyses performed so far
  double analyse_seconds() const { return analyse_seconds_; }      // of the last factorize call
  double factorize_seconds() const { return factorize_seconds_; }  // of the last factorize call

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double last_shift_ = 0.0;
  int analyses_ = 0;
  double analyse_seconds_ = 0.0, factorize_seconds_ = 0.0;
};

}  // namespace pd
