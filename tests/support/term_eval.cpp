#include "support/term_eval.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <gtest/gtest.h>

#include "util/parallel.h"

namespace pd::test {

Eigen::VectorXd term_gradient(const EnergyTerm& term, const Eigen::VectorXd& x) {
  Eigen::VectorXd g = Eigen::VectorXd::Zero(x.size());
  term.add_gradient(x, g);
  return g;
}

Eigen::MatrixXd symmetric_from_lower(const HessianAssembly::SparseMatrix& lower) {
  const Eigen::MatrixXd L(lower);
  Eigen::MatrixXd S = L + L.transpose();
  S.diagonal() = L.diagonal();
  return S;
}

Eigen::MatrixXd term_hessian(const EnergyTerm& term, const Eigen::VectorXd& x, HessianProjection p) {
  HessianAssembly assembly;
  assembly.begin(static_cast<int>(x.size()));
  term.add_hessian(x, p, assembly);
  return symmetric_from_lower(assembly.finish(nullptr));
}

Eigen::VectorXd wavy(Eigen::Index n, double a, double b) {
  return Eigen::VectorXd::NullaryExpr(n, [=](Eigen::Index i) { return std::sin(a * double(i) + b); });
}

TermFdCheck check_term_derivatives(const EnergyTerm& term, const Eigen::VectorXd& x) {
  auto f = [&](const Eigen::VectorXd& y) { return term.value(y); };
  auto g = [&](const Eigen::VectorXd& y) { return term_gradient(term, y); };
  TermFdCheck c;
  c.gradient = check_gradient(f, x, g(x));
  c.H = term_hessian(term, x, HessianProjection::None);
  c.hessian = check_hessian(g, x, c.H);
  return c;
}

void expect_derivatives_match(const TermFdCheck& c, double gradient_tolerance, double hessian_tolerance) {
  EXPECT_GT(c.gradient.comparisons, 0);
  EXPECT_GE(c.gradient.steps_within(gradient_tolerance), 2) << "best " << c.gradient.best_rel_error;
  EXPECT_GT(c.hessian.comparisons, 0);
  EXPECT_GE(c.hessian.steps_within(hessian_tolerance), 2) << "best " << c.hessian.best_rel_error;
}

TermBits term_bits(const EnergyTerm& term, const Eigen::VectorXd& x, HessianProjection p, int threads) {
  const int saved = element_threads();
  set_element_threads(threads);
  TermBits bits;
  bits.value = term.value(x);
  bits.gradient = term_gradient(term, x);
  HessianAssembly assembly;
  assembly.begin(static_cast<int>(x.size()));
  term.add_hessian(x, p, assembly);
  const HessianAssembly::SparseMatrix& H = assembly.finish(nullptr);
  bits.hessian.assign(H.valuePtr(), H.valuePtr() + H.nonZeros());
  set_element_threads(saved);
  return bits;
}

void expect_reuse_after_value_is_fresh(const EnergyTerm& term, const EnergyTerm& twin, const Eigen::VectorXd& x,
                                       const Eigen::VectorXd& y) {
  const Eigen::VectorXd fresh_x = term_gradient(twin, x), fresh_y = term_gradient(twin, y);
  const double value_x = twin.value(x), value_y = twin.value(y);  // after the twin's gradients
  auto same = [](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<size_t>(a.size())) == 0;
  };
  auto same_value = [](double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; };
  ASSERT_FALSE(same(fresh_x, fresh_y)) << "x and y need different gradients";
  ASSERT_FALSE(same_value(value_x, value_y)) << "x and y need different values";
  for (const Eigen::VectorXd* at : {&x, &y}) {
    const char* name = at == &x ? "x" : "y";
    term.value(*at);
    EXPECT_TRUE(same(term_gradient(term, x), fresh_x)) << "gradient at x after value at " << name;
    term.value(*at);
    EXPECT_TRUE(same(term_gradient(term, y), fresh_y)) << "gradient at y after value at " << name;
    term.value(*at);
    EXPECT_TRUE(same_value(term.value(*at), at == &x ? value_x : value_y)) << "second value at " << name;
    EXPECT_TRUE(same_value(term.value(at == &x ? y : x), at == &x ? value_y : value_x)) << "value after one at " << name;
  }
}

long expect_value_and_gradient_bits(const std::function<std::unique_ptr<EnergyTerm>()>& make, const Eigen::VectorXd& x,
                                    double energy, const Eigen::VectorXd& gradient) {
  const int saved = element_threads();
  long compared = 0;
  for (int threads : {1, 2}) {
    set_element_threads(threads);
    for (bool after_value : {true, false}) {
      const std::unique_ptr<EnergyTerm> term = make();
      if (after_value) {
        const double value = term->value(x);
        EXPECT_EQ(std::memcmp(&value, &energy, sizeof(double)), 0) << value << " vs " << energy << ", " << threads << " threads";
        ++compared;
      }
      const Eigen::VectorXd g = term_gradient(*term, x);
      EXPECT_EQ(g.size(), gradient.size());
      for (Eigen::Index i = 0; i < std::min(g.size(), gradient.size()); ++i, ++compared)
        EXPECT_EQ(std::memcmp(&g[i], &gradient[i], sizeof(double)), 0)
            << "gradient entry " << i << (after_value ? " after a value, " : ", ") << threads << " threads";
    }
  }
  set_element_threads(saved);
  return compared;
}

long expect_same_bits(const TermBits& a, const TermBits& b) {
  long compared = 0;
  auto same = [&](const double* u, const double* v, size_t n, const char* what) {
    for (size_t i = 0; i < n; ++i, ++compared)
      if (std::memcmp(u + i, v + i, sizeof(double)) != 0) {
        ADD_FAILURE() << what << " entry " << i << " differs: " << u[i] << " vs " << v[i];
        return;
      }
  };
  same(&a.value, &b.value, 1, "value");
  EXPECT_EQ(a.gradient.size(), b.gradient.size());
  EXPECT_EQ(a.hessian.size(), b.hessian.size());
  if (a.gradient.size() == b.gradient.size())
    same(a.gradient.data(), b.gradient.data(), static_cast<size_t>(a.gradient.size()), "gradient");
  if (a.hessian.size() == b.hessian.size()) same(a.hessian.data(), b.hessian.data(), a.hessian.size(), "Hessian");
  return compared;
}

}  // namespace pd::test
