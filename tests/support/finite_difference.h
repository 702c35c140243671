#pragma once
// Finite-difference checks of gradients and Hessians, shared by every energy test.
//
// A check compares an analytic derivative with central differences at several step sizes and
// passes when the relative error at the best step size is below `tolerance`. Each check returns how
// many entries it compared, so a test can assert that the comparison really ran.
#include <functional>
#include <vector>

#include <Eigen/Core>

namespace pd::test {

struct FdResult {
  int comparisons = 0;              // number of scalar entries compared, over all step sizes
  double best_rel_error = 1e300;    // best over step sizes of ||analytic - fd|| / max(||analytic||, 1e-12)
  double best_step = 0.0;
  std::vector<double> rel_errors;   // one per step size, in the order given

  // How many step sizes agree to within `tolerance`; tests ask for at least two, so one lucky
  // cancellation at a single step size cannot pass a wrong derivative.
  int steps_within(double tolerance) const {
    int n = 0;
    for (double e : rel_errors) n += (e < tolerance);
    return n;
  }
};

// Default step sizes: central differences have error O(eps^2) + round-off O(1/eps).
inline std::vector<double> default_steps() { return {1e-4, 1e-5, 1e-6, 1e-7}; }

// Gradient of f at x against g(x).
FdResult check_gradient(const std::function<double(const Eigen::VectorXd&)>& f,
                        const Eigen::VectorXd& x, const Eigen::VectorXd& analytic_gradient,
                        const std::vector<double>& steps = default_steps());

// Jacobian of a vector function f (rows: outputs, columns: inputs) against `analytic`.
FdResult check_jacobian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
                        const Eigen::VectorXd& x, const Eigen::MatrixXd& analytic,
                        const std::vector<double>& steps = default_steps());

// Hessian: differences of the analytic gradient (the Jacobian of the gradient).
FdResult check_hessian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& grad,
                       const Eigen::VectorXd& x, const Eigen::MatrixXd& analytic_hessian,
                       const std::vector<double>& steps = default_steps());

}  // namespace pd::test
