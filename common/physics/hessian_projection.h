#pragma once
// Projection of element Hessians to positive semi-definite matrices.
//
// Newton's method needs a descent direction; element Hessians of non-convex energies (membrane under
// compression, bending, barriers) are indefinite. The caller chooses the projection explicitly:
// energies never project on their own, so finite-difference tests can check the exact Hessian.
#include <string>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace pd {

enum class HessianProjection {
  None,   // exact Hessian (tests, diagnostics)
  Clamp,  // eigenvalues below zero set to zero (the IPC default)
  Abs,    // eigenvalues replaced by their absolute values
};

// Parses "none" | "clamp" | "abs"; returns false for anything else.
bool parse_hessian_projection(const std::string& text, HessianProjection& out);
const char* to_string(HessianProjection p);

// Returns H (symmetric, N x N) with its eigenvalues projected as `p` says.
template <int N>
Eigen::Matrix<double, N, N> project_hessian(const Eigen::Matrix<double, N, N>& H, HessianProjection p) {
  if (p == HessianProjection::None) return H;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> eig(H);
  Eigen::Matrix<double, N, 1> lambda = eig.eigenvalues();
  bool changed = false;
  for (int i = 0; i < N; ++i) {
    if (lambda[i] < 0.0) {
      lambda[i] = (p == HessianProjection::Clamp) ? 0.0 : -lambda[i];
      changed = true;
    }
  }
  if (!changed) return H;
  return eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace pd
