// Tests of the analytic ground contact (physics/contact/ground_barrier.h): exact derivatives against
// finite differences (horizontal and tilted grounds, gaps down to 1e-7 m), infeasibility at and below
// the offset, the analytic step cap, friction contacts and the start-state query.
#include "physics/contact/ground_barrier.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <stdexcept>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "physics/contact/barrier.h"
#include "support/contact_settings.h"
#include "support/term_eval.h"

namespace pd {
namespace {

using test::contact_settings;

// A ground with unit normal n and height h, and vertex i placed at signed distance offset + gaps[i]
// from it, shifted along the plane by a vertex-dependent tangential vector so no two coincide.
struct GroundScene {
  Vec3 n;
  double height;
  Eigen::VectorXd x;
  GroundScene(const Vec3& normal, double h, double offset, const std::vector<double>& gaps) : n(normal.normalized()), height(h) {
    const Vec3 a = n.unitOrthogonal(), b = n.cross(a);
    x.resize(3 * static_cast<Eigen::Index>(gaps.size()));
    for (std::size_t i = 0; i < gaps.size(); ++i) {
      const double t = static_cast<double>(i);
      x.segment<3>(3 * i) = (h + offset + gaps[i]) * n + 0.1 * std::sin(1.3 * t + 0.2) * a + 0.1 * std::cos(0.7 * t) * b;
    }
  }
  double gap(const Eigen::VectorXd& y, int v, double offset) const { return n.dot(y.segment<3>(3 * v)) - height - offset; }
};

void print_fd(const char* what, const test::FdResult& g, const test::FdResult& h) {
  auto errors = [](const test::FdResult& r) {
    std::string s;
    char buf[16];
    for (double e : r.rel_errors) {
      std::snprintf(buf, sizeof buf, " %.1e", e);
      s += buf;
    }
    return s;
  };
  std::printf("[ info     ] %s: gradient rel err per step%s (%d comparisons), Hessian%s (%d)\n", what,
              errors(g).c_str(), g.comparisons, errors(h).c_str(), h.comparisons);
}

TEST(GroundBarrier, GradientAndHessianMatchFiniteDifferences) {
  // Horizontal ground y = -0.1 m. Vertices 0-3 active at gaps 5 mm .. 45 mm (dhat 50 mm), 4 and 5
  // inactive, and vertex 6 - below the ground - not in the ground's list, so it must be ignored.
  // (Gaps down to 1e-7 m: next test, with steps to match.)
  const double dhat = 0.05, offset = 2e-3;
  GroundScene s(Vec3(0, 1, 0), -0.1, offset, {5e-3, 0.01, 0.02, 0.045, 0.08, 0.5, -0.3});
  const GroundBarrier term({0, 1, 2, 3, 4, 5}, s.n, s.height, contact_settings(dhat, offset, 10.0), 0.3);
  EXPECT_EQ(term.name(), "ground");
  const ContactStats st = term.stats(s.x);
  EXPECT_EQ(st.active_point_triangle, 4);
  EXPECT_EQ(st.active_edge_edge, 0);
  EXPECT_NEAR(st.min_gap, 5e-3, 1e-15);
  EXPECT_GT(term.value(s.x), 0.0);
  EXPECT_TRUE(std::isfinite(term.value(s.x)));
  // FD steps (1e-4 .. 1e-7 m) stay far from the offset and from the activation distance.
  const test::TermFdCheck c = test::check_term_derivatives(term, s.x);
  print_fd("ground, horizontal", c.gradient, c.hessian);
  test::expect_derivatives_match(c, 1e-6, 1e-5);
  EXPECT_EQ(c.gradient.comparisons, 4 * 21);
  EXPECT_EQ(c.hessian.comparisons, 4 * 21 * 21);
  // The inactive and unlisted vertices get nothing.
  const Eigen::VectorXd g = test::term_gradient(term, s.x);
  EXPECT_EQ(g.tail<9>().norm(), 0.0);
  EXPECT_EQ(c.H.rightCols<9>().norm(), 0.0);
  // Gradient along -n (pushes up, descent moves away), scaled by kappa.
  for (int v = 0; v < 4; ++v) EXPECT_LT(g.segment<3>(3 * v).dot(s.n), 0.0);
  EXPECT_LT((term.unit_stiffness_gradient(s.x) * 10.0 - g).norm(), 1e-14 * g.norm());
  // The Clamp projection leaves a positive semi-definite matrix.
  const Eigen::MatrixXd Hc = test::term_hessian(term, s.x, HessianProjection::Clamp);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Hc).eigenvalues().minCoeff(), -1e-12 * Hc.norm());
}

TEST(GroundBarrier, DerivativesMatchFiniteDifferencesAtGapsDownTo1e7Metres) {
  // At a gap of 1e-7 m the barrier changes on a 1e-7 m scale, so the steps must be far smaller than
  // the default ones; positions are near the origin so that 1e-11 m steps are well resolved.
  const std::vector<double> steps = {1e-10, 3e-11, 1e-11, 3e-12};
  int comparisons = 0;
  for (double offset : {0.0, 5e-4}) {
    GroundScene s(Vec3(0, 0, 1), offset == 0.0 ? 0.0 : 0.01, offset, {1e-7, 1e-6, 3e-4, 2e-3});
    const GroundBarrier term({0, 1, 2, 3}, s.n, s.height, contact_settings(1e-3, offset, 1e4), 0.0);
    ASSERT_EQ(term.stats(s.x).active_point_triangle, 3);
    auto f = [&](const Eigen::VectorXd& y) { return term.value(y); };
    auto g = [&](const Eigen::VectorXd& y) { return test::term_gradient(term, y); };
    const test::FdResult rg = test::check_gradient(f, s.x, g(s.x), steps);
    const test::FdResult rh = test::check_hessian(g, s.x, test::term_hessian(term, s.x, HessianProjection::None), steps);
    print_fd(offset == 0.0 ? "ground, gap 1e-7 m, offset 0" : "ground, gap 1e-7 m, offset 0.5 mm", rg, rh);
    EXPECT_GE(rg.steps_within(1e-5), 2) << "best " << rg.best_rel_error;
    EXPECT_GE(rh.steps_within(1e-5), 2) << "best " << rh.best_rel_error;
    comparisons += rg.comparisons + rh.comparisons;
  }
  EXPECT_EQ(comparisons, 2 * 4 * (12 + 12 * 12));
}

TEST(GroundBarrier, TiltedGroundMatchesTheBarrierOfThePointPlaneDistance) {
  const double dhat = 0.02, offset = 1e-3, kappa = 3.0;
  const Vec3 normal(1.0, 2.0, -0.5);  // not unit: the constructor normalises it
  GroundScene s(normal, 0.3, offset, {4e-3, 8e-3, 0.012, 0.019, 0.05});
  const GroundBarrier term({0, 1, 2, 3, 4}, normal, 0.3, contact_settings(dhat, offset, kappa), 0.5);
  EXPECT_NEAR((term.normal() - s.n).norm(), 0.0, 1e-15);
  // Value: kappa * sum b(d^2) with d the distance to the plane, computed independently here.
  double expected = 0.0;
  for (int v = 0; v < 5; ++v) {
    const double d = s.gap(s.x, v, 0.0);
    expected += barrier(d * d, dhat, offset);
  }
  EXPECT_NEAR(term.value(s.x), kappa * expected, 1e-12 * kappa * expected);
  const test::TermFdCheck c = test::check_term_derivatives(term, s.x);
  print_fd("ground, tilted", c.gradient, c.hessian);
  test::expect_derivatives_match(c, 1e-6, 1e-5);
  // Every vertex's gradient and Hessian block act along the normal only.
  const Eigen::VectorXd g = test::term_gradient(term, s.x);
  for (int v = 0; v < 4; ++v) {
    EXPECT_LT((g.segment<3>(3 * v) - g.segment<3>(3 * v).dot(s.n) * s.n).norm(), 1e-12 * g.segment<3>(3 * v).norm());
    const Mat3 Hv = c.H.block<3, 3>(3 * v, 3 * v);
    EXPECT_LT((Hv - s.n.dot(Hv * s.n) * s.n * s.n.transpose()).norm(), 1e-12 * Hv.norm());
  }
}

TEST(GroundBarrier, ValueIsInfiniteAtAndBelowTheOffset) {
  const double offset = 5e-4;
  // Ground z = 0: vertex 0 exactly at the offset, 1 a little inside it, 2 far below the plane (where
  // d^2 alone would look far away), 3 just above the offset, 4 not listed.
  Eigen::VectorXd x(15);
  x << 0, 0, offset, 1, 0, 2e-4, 0, 1, -1.0, 1, 1, offset + 1e-9, 2, 2, -5.0;
  const ContactSettings cs = contact_settings(1e-3, offset, 1.0);
  EXPECT_EQ(GroundBarrier({0}, Vec3(0, 0, 1), 0.0, cs, 0).value(x), std::numeric_limits<double>::infinity());
  EXPECT_EQ(GroundBarrier({1}, Vec3(0, 0, 1), 0.0, cs, 0).value(x), std::numeric_limits<double>::infinity());
  EXPECT_EQ(GroundBarrier({2}, Vec3(0, 0, 1), 0.0, cs, 0).value(x), std::numeric_limits<double>::infinity());
  const double close = GroundBarrier({3}, Vec3(0, 0, 1), 0.0, cs, 0).value(x);
  EXPECT_TRUE(std::isfinite(close));
  EXPECT_GT(close, 0.0);
  EXPECT_EQ(GroundBarrier({4, 3}, Vec3(0, 0, 2), 0.0, cs, 0).value(x), std::numeric_limits<double>::infinity());

  // vertices_below lists exactly the infeasible ones, ascending whatever the input order.
  const GroundBarrier all({4, 3, 2, 1, 0, 2}, Vec3(0, 0, 1), 0.0, cs, 0);
  EXPECT_EQ(all.vertices(), (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(all.vertices_below(x), (std::vector<int>{0, 1, 2, 4}));
  EXPECT_LT(all.stats(x).min_gap, 0.0);
  EXPECT_EQ(GroundBarrier({3}, Vec3(0, 0, 1), 0.0, cs, 0).vertices_below(x), std::vector<int>{});
  // The same with the plane shifted: height is along the (normalised) normal.
  EXPECT_EQ(GroundBarrier({0, 1, 2, 3, 4}, Vec3(0, 0, -3), 0.5, cs, 0).vertices_below(x), (std::vector<int>{0, 1, 3}));
  // A position vector without the listed vertex is an error, not a silent read.
  EXPECT_THROW(GroundBarrier({5}, Vec3(0, 0, 1), 0.0, cs, 0).value(x), std::out_of_range);
}

TEST(GroundBarrier, MaxStepKeepsEveryVertexFeasibleOnRandomSteps) {
  const double offset = 1e-3;
  const Vec3 normal(0.3, 1.0, 0.2);
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> gap_dist(-7.0, -1.0);  // log10 of the gap, m
  std::normal_distribution<double> motion(0.0, 0.05);
  int cut = 0, trials = 0;
  double worst_margin = std::numeric_limits<double>::infinity();  // min over trials of new gap / ((1 - eta) old gap)
  for (double ratio : {0.9, 0.5, 0.99}) {
    ContactSettings cs = contact_settings(1e-3, offset, 1.0);
    cs.ccd_ratio = ratio;
    for (int trial = 0; trial < 200; ++trial) {
      std::vector<double> gaps(12);
      for (double& g : gaps) g = std::pow(10.0, gap_dist(rng));
      GroundScene s(normal, -0.2, offset, gaps);
      const GroundBarrier term({0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}, normal, -0.2, cs, 0.0);
      Eigen::VectorXd dx(s.x.size());
      for (Eigen::Index i = 0; i < dx.size(); ++i) dx[i] = motion(rng);
      const double alpha = term.max_step(s.x, dx);
      ASSERT_GT(alpha, 0.0);
      ASSERT_LE(alpha, 1.0);
      cut += alpha < 1.0;
      ++trials;
      const Eigen::VectorXd x1 = s.x + alpha * dx;
      double tightest = std::numeric_limits<double>::infinity();
      for (int v = 0; v < 12; ++v) {
        const double g0 = s.gap(s.x, v, offset), g1 = s.gap(x1, v, offset);
        ASSERT_GT(g1, 0.0) << "vertex " << v << " trial " << trial;
        tightest = std::min(tightest, g1 / ((1.0 - ratio) * g0));
      }
      ASSERT_GT(tightest, 1.0 - 1e-6);
      EXPECT_TRUE(std::isfinite(term.value(x1)));
      // When the step is cut, it is cut no more than needed: some vertex sits at the margin.
      if (alpha < 1.0) {
        EXPECT_NEAR(tightest, 1.0, 1e-6);
      }
      worst_margin = std::min(worst_margin, tightest);
    }
  }
  std::printf("[ info     ] ground max_step: %d of %d random steps cut, min new gap / margin %.9f\n", cut, trials,
              worst_margin);
  EXPECT_GT(cut, trials / 2);
}

TEST(GroundBarrier, MaxStepIsOneWhenNoVertexApproaches) {
  const double offset = 1e-3;
  GroundScene s(Vec3(0, 1, 0), 0.0, offset, {1e-6, 1e-4, 0.5});
  const GroundBarrier term({0, 1, 2}, s.n, 0.0, contact_settings(1e-3, offset, 1.0), 0.0);
  Eigen::VectorXd dx(9);
  dx << 0.3, 0.2, -0.1, -1.0, 0.0, 2.0, 0.0, -0.4, 0.0;  // up, sideways; vertex 2 falls, but only 0.4 m
  EXPECT_EQ(term.max_step(s.x, dx), 1.0);
  dx[7] = -0.9;  // vertex 2 (gap 0.5 m) now falls 0.9 m: cut to 0.9 * 0.5 / 0.9 = 0.5
  EXPECT_NEAR(term.max_step(s.x, dx), 0.5, 1e-12);
  EXPECT_EQ(term.max_step(s.x, Eigen::VectorXd::Zero(9)), 1.0);
  // A vertex already at the offset refuses any step (as ACCD does).
  Eigen::VectorXd x = s.x;
  x[1] = offset;
  EXPECT_EQ(term.max_step(x, dx), 0.0);
}

TEST(GroundBarrier, FrictionContactsCarryTheNormalForceOfTheBarrier) {
  const double dhat = 0.01, offset = 1e-3, kappa = 50.0, mu = 0.4;
  const Vec3 normal(-0.2, 0.1, 1.0);
  GroundScene s(normal, 0.05, offset, {1e-4, 3e-3, 9e-3, 0.02});
  const GroundBarrier term({3, 2, 1, 0}, normal, 0.05, contact_settings(dhat, offset, kappa), mu);
  std::vector<FrictionContact> contacts;
  term.friction_contacts(s.x, contacts);
  ASSERT_EQ(contacts.size(), 3u);  // vertex 3 is inactive
  const Eigen::Matrix<double, 3, 2>& T = term.tangent_basis();
  EXPECT_LT((T.transpose() * T - Eigen::Matrix2d::Identity()).norm(), 1e-15);
  EXPECT_LT((T.transpose() * s.n).norm(), 1e-15);
  double worst = 0.0;
  for (int k = 0; k < 3; ++k) {
    const FrictionContact& c = contacts[k];
    EXPECT_EQ(c.count, 1);
    EXPECT_EQ(c.vertices[0], k);  // ascending vertex order
    EXPECT_EQ(c.weights[0], 1.0);
    EXPECT_EQ(c.mu, mu);
    EXPECT_EQ(c.basis, T);
    // lambda = -dE/dd: central difference of the energy along the normal at this vertex.
    const double h = 1e-4 * s.gap(s.x, k, offset);  // small against the scale the barrier varies on
    Eigen::VectorXd xp = s.x, xm = s.x;
    xp.segment<3>(3 * k) += h * s.n;
    xm.segment<3>(3 * k) -= h * s.n;
    const double fd = -(term.value(xp) - term.value(xm)) / (2.0 * h);
    EXPECT_GT(c.normal_force, 0.0);
    EXPECT_NEAR(c.normal_force, fd, 1e-6 * fd) << "vertex " << k;
    worst = std::max(worst, std::abs(c.normal_force - fd) / fd);
  }
  std::printf("[ info     ] ground friction: lambda vs FD of E along n, worst rel err %.2e\n", worst);
  // Nothing without friction, and nothing appended when no vertex is active.
  std::vector<FrictionContact> none;
  GroundBarrier({0, 1, 2}, normal, 0.05, contact_settings(dhat, offset, kappa), 0.0).friction_contacts(s.x, none);
  EXPECT_TRUE(none.empty());
  GroundBarrier({3}, normal, 0.05, contact_settings(dhat, offset, kappa), mu).friction_contacts(s.x, none);
  EXPECT_TRUE(none.empty());
}

TEST(GroundBarrier, RejectsInvalidArguments) {
  const ContactSettings ok = contact_settings(1e-3, 0.0, 1.0);
  EXPECT_THROW(GroundBarrier({0}, Vec3::Zero(), 0.0, ok, 0.1), std::invalid_argument);
  EXPECT_THROW(GroundBarrier({0}, Vec3(0, std::nan(""), 1), 0.0, ok, 0.1), std::invalid_argument);
  EXPECT_THROW(GroundBarrier({0}, Vec3(0, INFINITY, 0), 0.0, ok, 0.1), std::invalid_argument);
  EXPECT_THROW(GroundBarrier({0}, Vec3(0, 1, 0), NAN, ok, 0.1), std::invalid_argument);
  EXPECT_THROW(GroundBarrier({0}, Vec3(0, 1, 0), 0.0, contact_settings(0.0, 0.0, 1.0), 0.1), std::invalid_argument);
  EXPECT_THROW(GroundBarrier({0}, Vec3(0, 1, 0), 0.0, contact_settings(1e-3, -1e-4, 1.0), 0.1), std::invalid_argument);
  EXPECT_THROW(GroundBarrier({0}, Vec3(0, 1, 0), 0.0, ok, -0.1), std::invalid_argument);
  EXPECT_THROW(GroundBarrier({-1}, Vec3(0, 1, 0), 0.0, ok, 0.1), std::invalid_argument);
  EXPECT_NO_THROW(GroundBarrier({}, Vec3(0, 1e-30, 0), 0.0, ok, 0.0));
}

}  // namespace
}  // namespace pd
