// Tests of the edge-edge mollifier (physics/contact/edge_edge_mollifier.h).
#include "physics/contact/edge_edge_mollifier.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <utility>

#include <gtest/gtest.h>

#include "support/finite_difference.h"

namespace pd {
namespace {

double uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}
Vec3 random_unit(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  return Vec3(n(rng), n(rng), n(rng)).normalized();
}

// Two edges (metres) at sin^2(angle) = sin2, lengths in [0.3, 1.5] m, random placement.
Vec<12> edges_at(std::mt19937& rng, double sin2) {
  const Vec3 a = random_unit(rng), d = (random_unit(rng).cross(a)).normalized();
  const Vec3 b = std::sqrt(1 - sin2) * a + std::sqrt(sin2) * d;
  const Vec3 pa = random_unit(rng), pb = random_unit(rng);
  Vec<12> x;
  x << pa, pa + uniform(rng, 0.3, 1.5) * a, pb, pb + uniform(rng, 0.3, 1.5) * b;
  return x;
}
double eps_of(const Vec<12>& rest) {
  return edge_edge_mollifier_threshold(rest.segment<3>(0), rest.segment<3>(3), rest.segment<3>(6),
                                       rest.segment<3>(9));
}

TEST(EdgeEdgeMollifier, ThresholdIsScaleTimesRestEdgeLengthsSquared) {
  const Vec3 o(0, 0, 0);
  EXPECT_DOUBLE_EQ(edge_edge_mollifier_threshold(o, Vec3(2, 0, 0), Vec3(1, 1, 1), Vec3(1, 4, 1)),
                   1e-3 * 4 * 9);
  EXPECT_EQ(edge_edge_mollifier_threshold(o, o, Vec3(1, 1, 1), Vec3(1, 4, 1)), 0.0);
}

// FD check of value -> gradient -> Hessian for a function of x (default steps: m varies on the
// angle scale sqrt(1e-3) ~ 0.03 rad, far above them); returns the best errors.
std::pair<double, double> expect_fd(const std::function<double(const Vec<12>&)>& f,
                                    const std::function<Vec<12>(const Vec<12>&)>& g,
                                    const std::function<Mat<12>(const Vec<12>&)>& h, const Vec<12>& x) {
  using Dyn = Eigen::VectorXd;
  const auto rg = test::check_gradient([&](const Dyn& y) { return f(y); }, x, g(x));
  const auto rh = test::check_hessian([&](const Dyn& y) -> Dyn { return g(y); }, x, h(x));
  EXPECT_GT(rg.comparisons, 0);
  EXPECT_GT(rh.comparisons, 0);
  EXPECT_GE(rg.steps_within(1e-6), 2) << rg.best_rel_error;
  EXPECT_GE(rh.steps_within(1e-5), 2) << rh.best_rel_error;
  EXPECT_LT((h(x) - h(x).transpose()).norm(), 1e-12 * h(x).norm());
  return {rg.best_rel_error, rh.best_rel_error};
}

TEST(EdgeEdgeMollifier, CrossSquaredNormAndMollifierMatchFiniteDifferences) {
  std::mt19937 rng(7);
  double worst_g = 0, worst_h = 0;
  int checked = 0;
  for (int k = 0; k < 60; ++k) {
    // Rest = the current edges with edge a stretched by 0.9-1.1, so eps_x is not tied to x.
    const Vec<12> x = edges_at(rng, uniform(rng, 1e-6, 9e-4));
    Vec<12> rest = x;
    rest.segment<3>(3) = x.segment<3>(0) + uniform(rng, 0.9, 1.1) * (x.segment<3>(3) - x.segment<3>(0));
    const double eps_x = eps_of(rest);
    // Active region only, away from the threshold so no FD stencil crosses it: c / eps_x < 0.9.
    if (!(edge_edge_cross_squared_norm(x) < 0.9 * eps_x)) continue;
    ASSERT_TRUE(edge_edge_mollifier_active(x, eps_x));
    ++checked;
    for (const auto& [eg, eh] :
         {expect_fd(edge_edge_cross_squared_norm, edge_edge_cross_squared_norm_gradient,
                    edge_edge_cross_squared_norm_hessian, x),
          expect_fd([&](const Vec<12>& y) { return edge_edge_mollifier(y, eps_x); },
                    [&](const Vec<12>& y) { return edge_edge_mollifier_gradient(y, eps_x); },
                    [&](const Vec<12>& y) { return edge_edge_mollifier_hessian(y, eps_x); }, x)}) {
      worst_g = std::max(worst_g, eg);
      worst_h = std::max(worst_h, eh);
    }
  }
  EXPECT_GE(checked, 30);
  std::printf("  c and mollifier (%d configurations): worst FD rel. error gradient %.2e, Hessian %.2e\n",
              checked, worst_g, worst_h);
}

TEST(EdgeEdgeMollifier, EqualsOneWithZeroDerivativesAtAndAboveThreshold) {
  std::mt19937 rng(8);
  for (int k = 0; k < 100; ++k) {
    const Vec<12> x = edges_at(rng, uniform(rng, 0.0, 1.0));
    const double c = edge_edge_cross_squared_norm(x);
    for (double eps_x : {c, 0.5 * c, 1e-3 * c, 0.0}) {  // c >= eps_x, including c == eps_x exactly
      EXPECT_FALSE(edge_edge_mollifier_active(x, eps_x));
      EXPECT_EQ(edge_edge_mollifier(x, eps_x), 1.0);
      EXPECT_TRUE(edge_edge_mollifier_gradient(x, eps_x).isZero(0.0));
      EXPECT_TRUE(edge_edge_mollifier_hessian(x, eps_x).isZero(0.0));
    }
  }
}

TEST(EdgeEdgeMollifier, ProfileIsZeroWhenParallelMonotoneAndC1AtThreshold) {
  const double eps_x = 2.5e-4;
  EXPECT_EQ(edge_edge_mollifier_of(0.0, eps_x), 0.0);
  EXPECT_DOUBLE_EQ(edge_edge_mollifier_of(0.5 * eps_x, eps_x), 0.75);
  double prev = -1;
  for (int i = 0; i <= 1000; ++i) {  // nondecreasing on [0, 1.1 eps_x]
    const double m = edge_edge_mollifier_of(1.1e-3 * i * eps_x, eps_x);
    EXPECT_GE(m, prev);
    EXPECT_LE(m, 1.0);
    prev = m;
  }
  // Value and first derivative continuous at eps_x (approach from below: 1 - m = (1 - c/eps)^2,
  // m' = 2 (1 - c/eps) / eps); the second derivative is not (-2/eps^2 below, 0 above).
  for (double r : {1e-3, 1e-6, 1e-9}) {
    const double below = (1 - r) * eps_x, above = (1 + r) * eps_x;
    EXPECT_NEAR(edge_edge_mollifier_of(below, eps_x), 1.0, 1.01 * r * r);
    EXPECT_EQ(edge_edge_mollifier_of(above, eps_x), 1.0);
    EXPECT_NEAR(edge_edge_mollifier_derivative_of(below, eps_x) * eps_x, 0.0, 2.01 * r);
    EXPECT_EQ(edge_edge_mollifier_derivative_of(above, eps_x), 0.0);
  }
  EXPECT_DOUBLE_EQ(edge_edge_mollifier_second_derivative_of(0.999 * eps_x, eps_x), -2 / eps_x / eps_x);
  // Scalar derivatives against central differences.
  const double c = 0.37 * eps_x, h = 1e-6 * eps_x;
  EXPECT_NEAR((edge_edge_mollifier_of(c + h, eps_x) - edge_edge_mollifier_of(c - h, eps_x)) / (2 * h),
              edge_edge_mollifier_derivative_of(c, eps_x), 1e-6 / eps_x);
}

TEST(EdgeEdgeMollifier, GradientIsContinuousWhenEdgesTurnThroughTheThreshold) {
  // Rotate edge b so that c passes eps_x: the stacked gradient goes to zero from below.
  std::mt19937 rng(9);
  const Vec<12> rest = edges_at(rng, 0.5);
  const double eps_x = eps_of(rest);
  const double la = (rest.segment<3>(3) - rest.segment<3>(0)).norm();
  const double lb = (rest.segment<3>(9) - rest.segment<3>(6)).norm();
  // sin^2 at which c = eps_x for unstretched edges: c = la^2 lb^2 sin^2.
  const double sin2_star = eps_x / (la * la * lb * lb);
  double prev_m = 0;
  for (double f : {0.5, 0.9, 0.99, 0.9999, 0.999999, 1.000001, 1.01}) {
    std::mt19937 same(10);  // same placement each time, only the angle changes
    Vec<12> x = edges_at(same, f * sin2_star);
    x.segment<3>(3) = x.segment<3>(0) + la * (x.segment<3>(3) - x.segment<3>(0)).normalized();
    x.segment<3>(9) = x.segment<3>(6) + lb * (x.segment<3>(9) - x.segment<3>(6)).normalized();
    const double m = edge_edge_mollifier(x, eps_x);
    const double gnorm = edge_edge_mollifier_gradient(x, eps_x).norm();
    EXPECT_GE(m, prev_m);
    prev_m = m;
    // |grad m| <= m'(c) |grad c| = 2 (1 - c/eps_x)/eps_x |grad c| -> 0 linearly in (1 - f).
    const double gc = edge_edge_cross_squared_norm_gradient(x).norm();
    EXPECT_LE(gnorm, 2 * std::max(0.0, 1 - f) * 1.001 / eps_x * gc + 1e-12) << f;
    EXPECT_NEAR(m, f < 1 ? 1 - (1 - f) * (1 - f) : 1.0, 1e-9) << f;
  }
}

}  // namespace
}  // namespace pd
