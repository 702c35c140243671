#pragma once
// Projection of element Hessians to positive semi-definite matrices.
//
// Newton's method needs a descent direction; element Hessians of non-convex energies (membrane under
// compression, bending, barriers) are indefinite. The caller chooses the projection explicitly:
// energies never project on their own, so finite-difference tests can check the exact Hessian.
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace pd {

enum class HessianProjection {
  None,   // exact Hessian (tests, diagnostics)
  Clamp,  // eigenvalues below zero set to zero (the IPC default)
  Abs,    // eigenvalues replaced by their absolute values
  // The scene default. A Newton policy, not an element projection: an iterate assembles the exact
  // Hessian and reassembles it with Clamp only when CHOLMOD finds the assembled system indefinite,
  // or assembles it with Clamp at once after a capped step (solver/newton.h). Element code that
  // cannot retry treats it as Clamp.
  ExactFirst,
};

// Parses "none" | "clamp" | "abs" | "exact_first"; returns false for anything else.
bool parse_hessian_projection(const std::string& text, HessianProjection& out);
const char* to_string(HessianProjection p);

// Returns H (symmetric, N x N) with its eigenvalues projected as `p` says.
//
// Fast path: an element Hessian that is already positive semi-definite up to round-off (eigenvalues
// above -1e-12 times its largest diagonal entry) is returned unchanged. The test is a Cholesky
// factorization of H + eps I, about 30x cheaper than the eigen-decomposition at N = 9..12, and most
// element Hessians of a resting or gently moving sheet pass it.
template <int N>
Eigen::Matrix<double, N, N> project_hessian(const Eigen::Matrix<double, N, N>& H, HessianProjection p) {
  if (p == HessianProjection::None) return H;
  const bool clamp = p == HessianProjection::Clamp || p == HessianProjection::ExactFirst;
  const double eps = 1e-12 * H.diagonal().cwiseAbs().maxCoeff();
  Eigen::Matrix<double, N, N> shifted = H;
  shifted.diagonal().array() += eps;
  if (eps > 0 && Eigen::LLT<Eigen::Matrix<double, N, N>>(shifted).info() == Eigen::Success) return H;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> eig(H);
  Eigen::Matrix<double, N, 1> lambda = eig.eigenvalues();
  bool changed = false;
  for (int i = 0; i < N; ++i) {
    if (lambda[i] < 0.0) {
      lambda[i] = clamp ? 0.0 : -lambda[i];
      changed = true;
    }
  }
  if (!changed) return H;
  return eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace pd
