// Tests of the C-IPC offset log barrier and IPC's adaptive stiffness (physics/contact/barrier.h).
#include "physics/contact/barrier.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "support/finite_difference.h"

namespace pd {
namespace {

// (dhat, xi) pairs in metres: plain IPC, cloth-like thickness, thickness much larger than dhat,
// and dhat much larger than the thickness.
struct Params { double dhat, xi; };
const std::vector<Params> kParams = {{1e-3, 0.0}, {1e-3, 1e-3}, {1e-4, 5e-3}, {1e-2, 1e-4}, {1.0, 0.5}};

// d^2 at which s = d^2 - xi^2 is the fraction `f` of s_hat.
double d2_at(const Params& p, double f) { return p.xi * p.xi + f * barrier_activation(p.dhat, p.xi); }

TEST(Barrier, ActivationIsSquaredOffsetPlusDhatMinusSquaredOffset) {
  for (const Params& p : kParams) {
    const double s_hat = barrier_activation(p.dhat, p.xi);
    EXPECT_NEAR(s_hat, (p.xi + p.dhat) * (p.xi + p.dhat) - p.xi * p.xi, 1e-14 * (p.xi + p.dhat) * (p.xi + p.dhat));
    EXPECT_DOUBLE_EQ(barrier_active_squared_distance(p.dhat, p.xi), (p.xi + p.dhat) * (p.xi + p.dhat));
    // The formula in the header, at one interior point.
    const double s = 0.3 * s_hat;
    EXPECT_NEAR(barrier(d2_at(p, 0.3), p.dhat, p.xi), -(s - s_hat) * (s - s_hat) * std::log(0.3),
                1e-12 * s_hat * s_hat);
  }
  // With no thickness it is IPC's b(d^2, dhat^2).
  const double d2 = 0.25e-6, dhat = 1e-3;
  EXPECT_DOUBLE_EQ(barrier(d2, dhat, 0.0), -(d2 - dhat * dhat) * (d2 - dhat * dhat) * std::log(d2 / (dhat * dhat)));
}

TEST(Barrier, FirstAndSecondDerivativesMatchFiniteDifferences) {
  int comparisons = 0, points = 0;
  double worst_g = 0.0, worst_h = 0.0;
  for (const Params& p : kParams) {
    for (double f : {0.02, 0.1, 0.3, 0.5, 0.8, 0.97}) {
      const double d2 = d2_at(p, f);
      const double s = f * barrier_activation(p.dhat, p.xi);
      // Steps relative to the distance to the nearer end of (0, s_hat): inside the domain, and small
      // against the scale on which b' varies near s_hat (where b' ~ (s_hat - s)^2 is tiny).
      const double base = std::min(s, barrier_activation(p.dhat, p.xi) - s);
      const std::vector<double> steps = {1e-3 * base, 1e-4 * base, 1e-5 * base, 1e-6 * base};
      Eigen::VectorXd x(1);
      x[0] = d2;
      auto value = [&](const Eigen::VectorXd& y) { return barrier(y[0], p.dhat, p.xi); };
      auto grad = [&](const Eigen::VectorXd& y) {
        Eigen::VectorXd g(1);
        g[0] = barrier_first_derivative(y[0], p.dhat, p.xi);
        return g;
      };
      Eigen::MatrixXd H(1, 1);
      H(0, 0) = barrier_second_derivative(d2, p.dhat, p.xi);
      const test::FdResult rg = test::check_gradient(value, x, grad(x), steps);
      const test::FdResult rh = test::check_hessian(grad, x, H, steps);
      EXPECT_GE(rg.steps_within(1e-6), 2) << "dhat " << p.dhat << " xi " << p.xi << " f " << f
                                          << " best " << rg.best_rel_error;
      EXPECT_GE(rh.steps_within(1e-6), 2) << "dhat " << p.dhat << " xi " << p.xi << " f " << f
                                          << " best " << rh.best_rel_error;
      comparisons += rg.comparisons + rh.comparisons;
      worst_g = std::max(worst_g, rg.best_rel_error);
      worst_h = std::max(worst_h, rh.best_rel_error);
      ++points;
    }
  }
  EXPECT_EQ(points, 30);
  EXPECT_EQ(comparisons, 30 * 8);
  std::printf("barrier FD: %d points, worst best-step rel err: b' %.1e, b'' %.1e\n", points, worst_g,
              worst_h);
}

TEST(Barrier, ZeroWithZeroDerivativesAtAndBeyondActivation) {
  for (const Params& p : kParams) {
    const double d2_act = barrier_active_squared_distance(p.dhat, p.xi);
    for (double d2 : {d2_act, d2_act * (1 + 1e-12), 1.01 * d2_act, 100 * d2_act, 1e30}) {
      EXPECT_EQ(barrier(d2, p.dhat, p.xi), 0.0) << d2;
      EXPECT_EQ(barrier_first_derivative(d2, p.dhat, p.xi), 0.0) << d2;
      EXPECT_EQ(barrier_second_derivative(d2, p.dhat, p.xi), 0.0) << d2;
    }
    // Just inside the activation distance the barrier is on.
    const double d_in = (p.xi + p.dhat) * (1 - 1e-6);
    EXPECT_GT(barrier(d_in * d_in, p.dhat, p.xi), 0.0);
  }
}

TEST(Barrier, InfiniteAtAndBelowTheOffset) {
  const double inf = std::numeric_limits<double>::infinity();
  for (const Params& p : kParams) {
    for (double d2 : {p.xi * p.xi, 0.5 * p.xi * p.xi, 0.0}) {
      EXPECT_EQ(barrier(d2, p.dhat, p.xi), inf) << d2;
      EXPECT_EQ(barrier_first_derivative(d2, p.dhat, p.xi), -inf) << d2;
      EXPECT_EQ(barrier_second_derivative(d2, p.dhat, p.xi), inf) << d2;
    }
    // Finite, and large, just above the offset.
    const double b = barrier(d2_at(p, 1e-12), p.dhat, p.xi);
    EXPECT_TRUE(std::isfinite(b));
    EXPECT_GT(b, 20.0 * std::pow(barrier_activation(p.dhat, p.xi), 2));  // -ln(1e-12) ~ 27.6
  }
}

TEST(Barrier, MonotoneDecreasingAndConvexOnTheActiveRange) {
  for (const Params& p : kParams) {
    const int n = 2000;
    double prev = std::numeric_limits<double>::infinity();
    for (int i = 1; i < n; ++i) {
      const double f = static_cast<double>(i) / n;
      const double d2 = d2_at(p, f);
      const double b = barrier(d2, p.dhat, p.xi);
      EXPECT_GT(b, 0.0) << f;
      EXPECT_LT(b, prev) << f;
      EXPECT_LT(barrier_first_derivative(d2, p.dhat, p.xi), 0.0) << f;
      EXPECT_GT(barrier_second_derivative(d2, p.dhat, p.xi), 0.0) << f;
      prev = b;
    }
  }
}

TEST(Barrier, TwiceContinuouslyDifferentiableAtActivation) {
  // From below, b, b' and b'' must all go to the zero values taken beyond dhat: near s_hat,
  // b ~ eps^3 s_hat^2, b' ~ eps^2 s_hat, b'' ~ 6 eps with eps = 1 - s / s_hat.
  for (const Params& p : kParams) {
    const double s_hat = barrier_activation(p.dhat, p.xi);
    double prev_ratio = 0.0;
    for (double eps : {1e-2, 1e-3, 1e-4, 1e-5}) {
      const double d2 = d2_at(p, 1.0 - eps);
      const double b = barrier(d2, p.dhat, p.xi);
      const double b1 = barrier_first_derivative(d2, p.dhat, p.xi);
      const double b2 = barrier_second_derivative(d2, p.dhat, p.xi);
      EXPECT_LE(std::abs(b), 2.0 * eps * eps * eps * s_hat * s_hat) << eps;
      EXPECT_LE(std::abs(b1), 4.0 * eps * eps * s_hat) << eps;
      EXPECT_LE(std::abs(b2), 7.0 * eps) << eps;
      // b'' / eps tends to the constant 6: the second derivative is continuous (Lipschitz) at s_hat.
      if (prev_ratio > 0.0) {
        EXPECT_NEAR(b2 / eps, 6.0, 0.1) << eps;
      }
      prev_ratio = b2 / eps;
    }
    // One-sided difference quotients of b' across s_hat agree (both ~0): no kink in b'.
    const double h = 1e-7 * s_hat;
    const double d2a = p.xi * p.xi + s_hat;
    const double left = (barrier_first_derivative(d2a, p.dhat, p.xi) -
                         barrier_first_derivative(d2a - h, p.dhat, p.xi)) / h;
    const double right = (barrier_first_derivative(d2a + h, p.dhat, p.xi) -
                          barrier_first_derivative(d2a, p.dhat, p.xi)) / h;
    EXPECT_NEAR(left, right, 1e-5);
  }
}

TEST(BarrierStiffness, BoundsFollowIpcMassRuleInJoules) {
  const double dhat = 1e-3, xi = 1e-3, bbox = 2.0, mass = 1e-3, h = 1e-2;
  const BarrierStiffnessBounds b = barrier_stiffness_bounds(dhat, xi, bbox, mass, h);
  EXPECT_GT(b.kappa_min, 0.0);
  EXPECT_DOUBLE_EQ(b.kappa_max, 100.0 * b.kappa_min);
  // Curvature along the normal at gap 1e-8 * bbox equals 1e11 m / h^2.
  const double d0 = xi + 1e-8 * bbox;
  const double curvature = b.kappa_min * 4.0 * d0 * d0 * barrier_second_derivative(d0 * d0, dhat, xi);
  EXPECT_NEAR(curvature / (1e11 * mass / (h * h)), 1.0, 1e-6);
  // Linear in mass and in 1 / h^2.
  EXPECT_NEAR(barrier_stiffness_bounds(dhat, xi, bbox, 2 * mass, h).kappa_min / b.kappa_min, 2.0, 1e-12);
  EXPECT_NEAR(barrier_stiffness_bounds(dhat, xi, bbox, mass, 2 * h).kappa_min / b.kappa_min, 0.25, 1e-12);
  // dhat far below 1e-8 bbox: the reference point moves to s_hat / 2 and stays finite and positive.
  const BarrierStiffnessBounds tiny = barrier_stiffness_bounds(1e-12, 0.0, 1e3, mass, h);
  EXPECT_TRUE(std::isfinite(tiny.kappa_min));
  EXPECT_GT(tiny.kappa_min, 0.0);
}

TEST(BarrierStiffness, InitialKappaMinimisesGradientNormWithinBounds) {
  const BarrierStiffnessBounds bounds{1.0, 100.0};
  Eigen::VectorXd gb(6), perp(6);
  gb << 1, -2, 0.5, 3, 0, -1;
  perp << 2, 1, 0, 0, 1, 0;  // orthogonal to gb
  ASSERT_NEAR(gb.dot(perp), 0.0, 1e-15);
  for (double k : {3.0, 42.0, 99.0}) {
    const Eigen::VectorXd ge = -k * gb + perp;
    const double kappa = initial_barrier_stiffness(ge, gb, bounds);
    EXPECT_NEAR(kappa, k, 1e-12 * k);
    // It is the minimiser: moving kappa either way increases ||gE + kappa gB||.
    const double r = (ge + kappa * gb).norm();
    EXPECT_LT(r, (ge + (kappa * 1.01) * gb).norm());
    EXPECT_LT(r, (ge + (kappa * 0.99) * gb).norm());
  }
  EXPECT_EQ(initial_barrier_stiffness(-1e4 * gb, gb, bounds), 100.0);  // clamped to kappa_max
  EXPECT_EQ(initial_barrier_stiffness(1e-3 * gb, gb, bounds), 1.0);    // negative optimum -> kappa_min
  EXPECT_EQ(initial_barrier_stiffness(gb, Eigen::VectorXd::Zero(6), bounds), 1.0);  // no contact
}

TEST(BarrierStiffness, UpdateDoublesOnlyWhenSmallGapKeepsShrinking) {
  const double dhat = 1e-3, eps = 1e-6 * dhat;
  EXPECT_EQ(update_barrier_stiffness(0.5 * eps, 0.4 * eps, dhat, 10.0, 1000.0), 20.0);
  EXPECT_EQ(update_barrier_stiffness(0.5 * eps, 0.6 * eps, dhat, 10.0, 1000.0), 10.0);  // growing
  EXPECT_EQ(update_barrier_stiffness(2.0 * eps, 0.4 * eps, dhat, 10.0, 1000.0), 10.0);  // was large
  EXPECT_EQ(update_barrier_stiffness(0.5 * eps, 0.4 * eps, dhat, 600.0, 1000.0), 1000.0);  // capped
  EXPECT_EQ(update_barrier_stiffness(0.5 * eps, 0.4 * eps, dhat, 2000.0, 1000.0), 2000.0);  // no cut
  // A custom fraction of dhat.
  EXPECT_EQ(update_barrier_stiffness(0.05 * dhat, 0.04 * dhat, dhat, 10.0, 1000.0, 0.1), 20.0);
}

}  // namespace
}  // namespace pd
