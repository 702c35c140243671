#include "support/finite_difference.h"

#include <algorithm>

namespace pd::test {

FdResult check_gradient(const std::function<double(const Eigen::VectorXd&)>& f,
                        const Eigen::VectorXd& x, const Eigen::VectorXd& analytic,
                        const std::vector<double>& steps) {
  FdResult r;
  const double scale = std::max(analytic.norm(), 1e-12);
  for (double eps : steps) {
    Eigen::VectorXd fd(x.size());
    Eigen::VectorXd xp = x;
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      const double xi = x[i];
      xp[i] = xi + eps;
      const double fp = f(xp);
      xp[i] = xi - eps;
      const double fm = f(xp);
      xp[i] = xi;
      fd[i] = (fp - fm) / (2 * eps);
    }
    r.comparisons += static_cast<int>(x.size());
    const double err = (fd - analytic).norm() / scale;
    r.rel_errors.push_back(err);
    if (err < r.best_rel_error) { r.best_rel_error = err; r.best_step = eps; }
  }
  return r;
}

FdResult check_jacobian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
                        const Eigen::VectorXd& x, const Eigen::MatrixXd& analytic,
                        const std::vector<double>& steps) {
  FdResult r;
  const double scale = std::max(analytic.norm(), 1e-12);
  for (double eps : steps) {
    Eigen::MatrixXd fd(analytic.rows(), x.size());
    Eigen::VectorXd xp = x;
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      const double xi = x[i];
      xp[i] = xi + eps;
      const Eigen::VectorXd fp = f(xp);
      xp[i] = xi - eps;
      const Eigen::VectorXd fm = f(xp);
      xp[i] = xi;
      fd.col(i) = (fp - fm) / (2 * eps);
    }
    r.comparisons += static_cast<int>(analytic.size());
    const double err = (fd - analytic).norm() / scale;
    r.rel_errors.push_back(err);
    if (err < r.best_rel_error) {
      r.best_rel_error = err;
      r.best_step = eps;
    }
  }
  return r;
}

FdResult check_hessian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& grad,
                       const Eigen::VectorXd& x, const Eigen::MatrixXd& analytic,
                       const std::vector<double>& steps) {
  return check_jacobian(grad, x, analytic, steps);
}

}  // namespace pd::test
