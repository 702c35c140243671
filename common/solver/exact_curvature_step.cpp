#include "solver/exact_curvature_step.h"

#include <limits>

#include <Eigen/SparseCore>

namespace pd {

ExactCurvatureStep exact_curvature_step(const CholmodSolver::SparseMatrix& exact_lower, const CholmodSolver& clamped,
                                        const Eigen::VectorXd& g, const Eigen::VectorXd& clamped_step,
                                        int max_iterations, double tolerance) {
  // A serial product in a fixed order: the same bits for any thread count.
  const HessianProduct product = [&exact_lower](const Eigen::VectorXd& d, Eigen::VectorXd& out) {
    out = exact_lower.selfadjointView<Eigen::Lower>() * d;
    return true;
  };
  return exact_curvature_step(product, clamped, g, clamped_step, max_iterations, tolerance);
}

ExactCurvatureStep exact_curvature_step(const HessianProduct& exact, const CholmodSolver& clamped,
                                        const Eigen::VectorXd& g, const Eigen::VectorXd& clamped_step,
                                        int max_iterations, double tolerance) {
  ExactCurvatureStep out;
  Eigen::VectorXd p = Eigen::VectorXd::Zero(g.size());
  Eigen::VectorXd r = -g;              // residual of H p = -g
  Eigen::VectorXd z = clamped_step;    // C^{-1} r
  Eigen::VectorXd d = z;               // search direction
  Eigen::VectorXd Hd;
  double rz = r.dot(z);                // d^T C d for the first direction
  const double stop = tolerance * tolerance * rz;
  for (int k = 0; k < max_iterations; ++k) {
    const bool formed = exact(d, Hd);
    const double curvature = formed ? d.dot(Hd) : std::numeric_limits<double>::quiet_NaN();
    if (k == 0) out.first_curvature_ratio = curvature / rz;
    if (!(curvature > 0.0)) {
      out.negative_curvature = true;
      break;
    }
    const double a = rz / curvature;
    p += a * d;
    ++out.iterations;
    r -= a * Hd;
    z = clamped.solve(r);
    const double rz_next = r.dot(z);
    if (!(rz_next > stop)) break;
    d = z + (rz_next / rz) * d;
    rz = rz_next;
  }
  out.step = out.iterations > 0 ? std::move(p) : clamped_step;
  return out;
}

}  // namespace pd
