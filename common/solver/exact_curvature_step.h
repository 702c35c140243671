#pragma once
// A Newton step on the exact Hessian, preconditioned by the clamped one (issue 16).
//
// Where the assembled exact Hessian H is indefinite, Newton solves with the clamped Hessian C
// (every element's negative eigenvalues set to zero). C = H + N with N >= 0 overestimates the
// curvature wherever a compressed triangle or hinge has a negative part, so the clamped step is too
// short along soft but stable directions, and Newton creeps there at a linear rate (spin-sphere's
// finest refinement: one or two hanging vertices at a time, the step measure falling about 0.87x per
// iterate; docs/performance.md, "The exact curvature behind a clamped step").
//
// This refines the clamped step by conjugate gradients on H p = -g with C's factorization as the
// preconditioner, started from p = 0 so that the first iterate is the clamped step scaled to the
// minimum of the quadratic model along it. Steihaug's rule ends it at the first direction of
// non-positive curvature under H, keeping the last iterate (every iterate so far is a descent
// direction of the model); if that happens on the first direction, the clamped step is returned
// unchanged. C's spectrum relative to H clusters at 1 except along the few clamped modes, so a few
// iterations usually reach the tolerance.
//
// The same iteration serves a coarse level, whose assembled Hessian C is a model of the potential's
// (the prolonged elasticity's lagged or stand-in blocks), with products by the true Hessian taken as
// differences of gradients (IncrementalPotential::hessian_product); there the ratio of the true to the
// model curvature along the model's own step tells whether the model is wrong where Newton is
// (solver/newton.h, model_curvature_iterations).
#include <functional>
#include <limits>

#include <Eigen/Core>

#include "solver/cholmod_solver.h"

namespace pd {

struct ExactCurvatureStep {
  Eigen::VectorXd step;   // the refined step (m), or the clamped step when it was not refined
  int iterations = 0;     // conjugate-gradient iterations that changed the step
  bool negative_curvature = false;  // it stopped at a direction of non-positive curvature under H
  // d^T H d / d^T C d along the first direction d, the clamped (model) step: how far the model's
  // curvature along its own step is from H's. NaN when the first product failed or none was taken
  // (max_iterations 0).
  double first_curvature_ratio = std::numeric_limits<double>::quiet_NaN();
};

// out = H d for the stacked vector d; false when the product cannot be formed (H's gradient is not
// defined near the state), which ends the iteration as non-positive curvature does.
using HessianProduct = std::function<bool(const Eigen::VectorXd& d, Eigen::VectorXd& out)>;

// exact_lower: the exact Hessian H (lower triangle, as assembled; fixed dofs are identity rows);
// clamped: C's factorization; g: the potential's gradient (J/m, fixed dofs zero); clamped_step:
// -C^{-1} g. Stops when the preconditioned residual r^T C^{-1} r falls below tolerance^2 times its
// start value, at non-positive curvature, or after max_iterations.
ExactCurvatureStep exact_curvature_step(const CholmodSolver::SparseMatrix& exact_lower, const CholmodSolver& clamped,
                                        const Eigen::VectorXd& g, const Eigen::VectorXd& clamped_step,
                                        int max_iterations, double tolerance);

// The same with H given by its products (a failed product stops as at non-positive curvature).
ExactCurvatureStep exact_curvature_step(const HessianProduct& exact, const CholmodSolver& clamped,
                                        const Eigen::VectorXd& g, const Eigen::VectorXd& clamped_step,
                                        int max_iterations, double tolerance);

}  // namespace pd
