#pragma once
// Internal pressure of closed shells (balloons, inflated cushions).
//
// Enclosed volume of a closed mesh with outward (counter-clockwise seen from outside) triangles,
// by the divergence theorem (m^3):
//   V(x) = 1/6 sum_f x0 . (x1 x x2).
// Potential U(V), J:
//   constant pressure p (Pa, gauge):  U = -p V                      U'(V) = -p,        U'' = 0
//   ideal gas, isothermal:            U = -p V0 ln V  (p V = p V0)  U'(V) = -p V0 / V, U'' = p V0 / V^2
// with V0 the volume of the initial positions. Gradient U'(V) grad V; exact Hessian
//   U'(V) H_V + U''(V) grad V grad V^T.
//
// What add_hessian assembles, and why:
// - U'(V) H_V is a sum of per-triangle 9x9 blocks (skew cross-product matrices, zero diagonal blocks:
//   each block is indefinite). Each is projected on its own as the caller asks. Per-triangle
//   projection discards the cancellations between neighbouring triangles (the exact sum vanishes
//   along rigid translations, the projected sum does not), so the projected Hessian is stiffer than
//   the true one: a valid descent direction, at the cost of more Newton iterations (linear instead of
//   quadratic convergence). The balloon test in tests/physics/pressure_test.cpp measures it: 7
//   iterations against 4 with the exact Hessian, for a 1e-7 relative gradient.
// - The ideal gas's rank-one term U'' grad V grad V^T couples every dof with every other: assembling
//   it would make the sparse Hessian dense. It is PSD (U'' > 0 for p > 0), so dropping it only
//   makes the Hessian less stiff along volume changes, which partly offsets the stiffness the
//   per-triangle projection adds (the balloon test needs 13 iterations with it, 7 without). It is
//   omitted. dense_hessian_for_tests() returns the exact
//   Hessian, rank-one term included, for finite-difference tests.
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"
#include "physics/energy_term.h"
#include "scene/scene.h"

namespace pd {

// V(x) above, m^3; faces use global indices into the stacked positions x.
double enclosed_volume(const Faces& faces, const Eigen::VectorXd& x);

class PressureTerm : public EnergyTerm {
 public:
  // A single Newton step may not shrink the volume below this fraction of the current volume
  // (ideal gas only): ln V must stay finite along the line search.
  static constexpr double kMinVolumeRatio = 0.1;

  // faces: one closed, outward-oriented shell, global vertex indices. initial: stacked initial
  // positions of the scene (m), which define V0. Throws std::invalid_argument if V0 <= 0 (the mesh is
  // inward-oriented or degenerate: the pressure would pull inward).
  PressureTerm(const Faces& faces, const Eigen::VectorXd& initial, const Pressure& params);

  std::string name() const override { return "pressure"; }

  // Ideal gas: +infinity if V(x) <= 0 (inadmissible).
  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  // Per-triangle U'(V) H_V,f, each projected; the ideal gas's rank-one term is omitted (see above).
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                   HessianAssembly& hessian) const override;
  // Ideal gas: largest alpha such that V stays above kMinVolumeRatio * V(x) on the whole segment
  // x + [0, alpha] dx (V along the segment is a cubic in alpha). Constant pressure: 1.
  double max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const override;

  double volume(const Eigen::VectorXd& x) const { return enclosed_volume(faces_, x); }
  double initial_volume() const { return V0_; }  // m^3
  double pressure_at(double V) const;            // gauge pressure at volume V, Pa

  // Exact dense Hessian (3n x 3n, n = x.size() / 3), rank-one term included. Tests only: O(n^2).
  Eigen::MatrixXd dense_hessian_for_tests(const Eigen::VectorXd& x) const;

 private:
  double dU_dV(double V) const;    // Pa (J/m^3)
  double d2U_dV2(double V) const;  // Pa/m^3

  Faces faces_;
  Pressure params_;
  double V0_ = 0.0;  // m^3
};

}  // namespace pd
