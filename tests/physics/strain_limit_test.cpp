// Tests of the strain-limit barrier (physics/strain_limit.h).
//
// Geometry is unit scale (edges ~1 m, strip 1 m x 0.2 m) so that the default finite-difference
// steps (1e-4 .. 1e-7 m) are small against the triangles; where the state sits close to the
// barrier's wall the steps are chosen against the remaining gap (stated at the test). Tolerances
// are relative errors.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <gtest/gtest.h>

#include "physics/membrane_neo_hookean.h"
#include "physics/strain_limit.h"
#include "solver/newton.h"
#include "support/finite_difference.h"
#include "support/term_eval.h"
#include "support/triangle_vectors.h"

namespace pd {
namespace {

constexpr double kGradTol = 1e-6;
constexpr double kHessTol = 1e-5;
// Band 1.1 .. 1.2: wide, so that FD steps are small against the distance to the wall.
const StrainLimitSettings kWide{1.2, 0.1, 100.0};  // limit, activation, stiffness (J/m^2)
// The brief's case: 10 % limit, 1 % band (1.09 .. 1.1).
const StrainLimitSettings kTight{1.1, 0.01, 100.0};

using Mat32 = Eigen::Matrix<double, 3, 2>;

using test::stack;
using test::vertex;
using test::area_of;
StrainLimitRest rest_of(const Vec<9>& X) { return strain_limit_rest(vertex(X, 0), vertex(X, 1), vertex(X, 2)); }

// Rest triangle in the xy plane (not right-angled, not isosceles, first edge not along an axis).
const Vec<9> kRest = stack(Vec3(0.1, -0.2, 0), Vec3(1.3, 0.1, 0), Vec3(0.4, 0.9, 0));

// Image of kRest under the in-plane linear map A (applied to xy), then the rigid motion (R, t).
// The principal stretches are the singular values of A.
Vec<9> mapped(const Eigen::Matrix2d& A, const Mat3& R = Mat3::Identity(), const Vec3& t = Vec3::Zero()) {
  Vec<9> x;
  for (int v = 0; v < 3; ++v) {
    Vec3 p = vertex(kRest, v);
    p.head<2>() = A * p.head<2>();
    x.segment<3>(3 * v) = R * p + t;
  }
  return x;
}
Eigen::Matrix2d diag2(double a, double b) { return Eigen::Vector2d(a, b).asDiagonal(); }

using test::random_triangle;

double min_eigenvalue(const Eigen::MatrixXd& H) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(H, Eigen::EigenvaluesOnly).eigenvalues()[0];
}

// One-triangle term over kRest (vertices 0, 1, 2).
struct OneTriangle {
  Positions rest;
  Faces faces;
  OneTriangle() : rest(3, 3), faces(1, 3) {
    for (int v = 0; v < 3; ++v) rest.row(v) = vertex(kRest, v).transpose();
    faces << 0, 1, 2;
  }
};

// FD check of the element functions at x with the given steps; prints the best errors.
void expect_element_derivatives_match_fd(const Vec<9>& x, const StrainLimitSettings& s,
                                         const std::vector<double>& steps = test::default_steps()) {
  const StrainLimitRest rest = rest_of(kRest);
  auto f = [&](const Eigen::VectorXd& v) { return strain_limit_energy(Vec<9>(v), rest, s); };
  auto g = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd { return strain_limit_gradient(Vec<9>(v), rest, s); };
  const Eigen::VectorXd xd = x;
  ASSERT_GT(f(xd), 0.0) << "the state must be in the band";
  const test::FdResult rg = test::check_gradient(f, xd, g(xd), steps);
  const test::FdResult rh = test::check_hessian(g, xd, strain_limit_hessian(x, rest, s), steps);
  EXPECT_EQ(rg.comparisons, 9 * static_cast<int>(steps.size()));
  EXPECT_EQ(rh.comparisons, 81 * static_cast<int>(steps.size()));
  EXPECT_GE(rg.steps_within(kGradTol), 2) << "best gradient rel. error " << rg.best_rel_error;
  EXPECT_GE(rh.steps_within(kHessTol), 2) << "best Hessian rel. error " << rh.best_rel_error;
  std::printf("    FD gradient best %.2e at %.0e, Hessian best %.2e at %.0e (%d + %d comparisons)\n",
              rg.best_rel_error, rg.best_step, rh.best_rel_error, rh.best_step, rg.comparisons,
              rh.comparisons);
}

// ---- settings ----

TEST(StrainLimit, SettingsAreValidatedAndDefaultsFollowTheMembrane) {
  EXPECT_NO_THROW(check_strain_limit_settings(kWide));
  EXPECT_THROW(check_strain_limit_settings({1.0, 0.01, 1.0}), std::invalid_argument);   // limit <= 1
  EXPECT_THROW(check_strain_limit_settings({1.1, 0.0, 1.0}), std::invalid_argument);    // no band
  EXPECT_THROW(check_strain_limit_settings({1.1, 0.15, 1.0}), std::invalid_argument);   // band below 1
  EXPECT_THROW(check_strain_limit_settings({1.1, 0.01, -1.0}), std::invalid_argument);  // stiffness < 0
  EXPECT_NO_THROW(check_strain_limit_settings({1.1, 0.01, 0.0}));
  const StrainLimitSettings d = StrainLimitSettings::from(1.1, 2e5, 1e-3);
  EXPECT_DOUBLE_EQ(d.limit, 1.1);
  EXPECT_NEAR(d.activation, 0.01, 1e-15);
  EXPECT_DOUBLE_EQ(d.stiffness, 200.0);  // E h, J/m^2
  EXPECT_NO_THROW(check_strain_limit_settings(StrainLimitSettings::from(1.001, 1e5, 1e-3)));
  EXPECT_THROW(StrainLimitSettings::from(0.9, 1e5, 1e-3), std::invalid_argument);
  EXPECT_DOUBLE_EQ(default_strain_limit_stiffness(2e5, 1e-3), 200.0);
  EXPECT_THROW(default_strain_limit_stiffness(2e5, 0.0), std::invalid_argument);
  // Activation 0 (the default member value) = the default band 0.1 (limit - 1); anything else is
  // checked as given.
  StrainLimitSettings unset;
  unset.limit = 1.2;
  unset.stiffness = 5.0;
  EXPECT_NEAR(resolve_strain_limit_settings(unset).activation, 0.02, 1e-15);
  EXPECT_THROW(resolve_strain_limit_settings({1.2, -0.01, 5.0}), std::invalid_argument);
  EXPECT_THROW(resolve_strain_limit_settings({1.0, 0.0, 5.0}), std::invalid_argument);

  const OneTriangle tri;
  EXPECT_THROW(StrainLimitTerm(tri.faces, tri.rest, {1.1, 0.2, 1.0}), std::invalid_argument);
  EXPECT_NEAR(StrainLimitTerm(tri.faces, tri.rest, unset).settings().activation, 0.02, 1e-15);
  StrainLimitTerm term(tri.faces, tri.rest, kWide);
  EXPECT_EQ(term.name(), "strain_limit");
  term.set_stiffness(7.0);
  EXPECT_EQ(term.settings().stiffness, 7.0);
  EXPECT_THROW(term.set_stiffness(-1.0), std::invalid_argument);
  EXPECT_EQ(term.settings().stiffness, 7.0);
}

// ---- kinematics ----

TEST(StrainLimit, DeformationGradientColumnsAreImagesOfAnOrthonormalRestFrame) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    const Vec<9> X = random_triangle(rng), x = random_triangle(rng);
    const StrainLimitRest rest = rest_of(X);
    EXPECT_NEAR(rest.area, area_of(X), 1e-14);
    // F at the rest shape is an isometry onto the rest plane: F^T F = I.
    const Mat32 F0 = strain_limit_deformation_gradient(X, rest);
    EXPECT_LT((F0.transpose() * F0 - Eigen::Matrix2d::Identity()).norm(), 1e-12);
    // F maps the rest edges (in the rest frame) to the deformed edges: F^T F = B^T a B.
    Mat32 e;
    e << vertex(x, 1) - vertex(x, 0), vertex(x, 2) - vertex(x, 0);
    const Mat32 F = strain_limit_deformation_gradient(x, rest);
    EXPECT_LT((F - e * rest.B).norm(), 1e-14);
  }
}

TEST(StrainLimit, PrincipalStretchesMatchJacobiSvdAndTheFrameFreeMetricOnRandomTriangles) {
  std::mt19937 rng(5);
  double worst = 0.0;
  for (int trial = 0; trial < 200; ++trial) {
    const Vec<9> X = random_triangle(rng), x = random_triangle(rng);
    const StrainLimitRest rest = rest_of(X);
    const Eigen::Vector2d s = principal_stretches(x, rest);
    const Mat32 F = strain_limit_deformation_gradient(x, rest);
    const Eigen::Vector2d svd = Eigen::JacobiSVD<Mat32>(F).singularValues();  // descending
    worst = std::max(worst, (s - svd).cwiseAbs().maxCoeff() / svd[0]);
    EXPECT_LT((s - svd).cwiseAbs().maxCoeff(), 1e-13 * svd[0]);
    // Independent of the rest frame: sigma_i^2 are the eigenvalues of abar^{-1} a.
    Mat32 E, e;
    E << vertex(X, 1) - vertex(X, 0), vertex(X, 2) - vertex(X, 0);
    e << vertex(x, 1) - vertex(x, 0), vertex(x, 2) - vertex(x, 0);
    const Eigen::Matrix2d M = (E.transpose() * E).inverse() * (e.transpose() * e);
    Eigen::Vector2d mu = Eigen::EigenSolver<Eigen::Matrix2d>(M).eigenvalues().real();
    if (mu[0] < mu[1]) std::swap(mu[0], mu[1]);
    EXPECT_NEAR(s[0] * s[0], mu[0], 1e-11 * mu[0]);
    EXPECT_NEAR(s[1] * s[1], mu[1], 1e-10 * mu[0]);
  }
  std::printf("    worst |sigma - JacobiSVD| / sigma_max over 200 triangles: %.2e\n", worst);
  // Known values through the in-plane map.
  const Eigen::Vector2d known = principal_stretches(mapped(diag2(1.17, 0.95)), rest_of(kRest));
  EXPECT_LT((known - Eigen::Vector2d(1.17, 0.95)).norm(), 1e-14);
}

// ---- energy, gradient, Hessian ----

TEST(StrainLimit, ZeroEnergyAndGradientAtRestBelowTheBandUnderCompressionAndForCollapsedTriangles) {
  const StrainLimitRest rest = rest_of(kRest);
  const Vec<9> collapsed = stack(Vec3(0, 0, 0), Vec3(0.4, 0.4, 0.4), Vec3(0.2, 0.2, 0.2));  // zero area
  ASSERT_LT(principal_stretches(collapsed, rest)[0], 1.1);
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  for (const Vec<9>& x : {kRest, mapped(diag2(1.09, 1.09)), mapped(diag2(1.0999, 0.7)), mapped(diag2(0.6, 0.8)),
                          mapped(diag2(1.05, 1.0), R), collapsed}) {
    EXPECT_EQ(strain_limit_energy(x, rest, kWide), 0.0);
    EXPECT_EQ(strain_limit_gradient(x, rest, kWide).norm(), 0.0);
    EXPECT_EQ(strain_limit_hessian(x, rest, kWide).norm(), 0.0);
  }
  // The band's entry is C^2: just inside it, energy ~ u^3, gradient ~ u^2 (u = depth / activation).
  const double E = strain_limit_energy(mapped(diag2(1.1001, 1.0)), rest, kWide);
  EXPECT_GT(E, 0.0);
  EXPECT_LT(E, 1e-8 * kWide.stiffness * rest.area);
}

TEST(StrainLimit, OverTheLimitIsInfiniteWithNanDerivatives) {
  const StrainLimitRest rest = rest_of(kRest);
  const double inf = std::numeric_limits<double>::infinity();
  for (const Vec<9>& x : {mapped(diag2(1.2, 1.0)), mapped(diag2(1.3, 1.25)), mapped(diag2(0.9, 2.0))}) {
    EXPECT_EQ(strain_limit_energy(x, rest, kWide), inf);
    EXPECT_TRUE(strain_limit_gradient(x, rest, kWide).array().isNaN().all());
    EXPECT_TRUE(strain_limit_hessian(x, rest, kWide).array().isNaN().all());
  }
  // Diverges approaching the wall.
  EXPECT_GT(strain_limit_energy(mapped(diag2(1.2 - 1e-9, 1.0)), rest, kWide),
            strain_limit_energy(mapped(diag2(1.2 - 1e-3, 1.0)), rest, kWide));
}

TEST(StrainLimit, EnergyMatchesClosedFormBarrierOfBothStretches) {
  const StrainLimitRest rest = rest_of(kRest);
  auto beta = [](double sigma, const StrainLimitSettings& s) {
    const double t = (s.limit - sigma) / s.activation;
    return t >= 1 ? 0.0 : -(t - 1) * (t - 1) * std::log(t);
  };
  const double kA = kWide.stiffness * area_of(kRest);
  for (const Eigen::Vector2d& sv : {Eigen::Vector2d(1.17, 0.95), Eigen::Vector2d(1.15, 1.12),
                                    Eigen::Vector2d(1.199, 1.199)}) {
    const double expected = kA * (beta(sv[0], kWide) + beta(sv[1], kWide));
    EXPECT_NEAR(strain_limit_energy(mapped(diag2(sv[0], sv[1])), rest, kWide), expected, 1e-12 * expected);
  }
}

TEST(StrainLimit, TheWidestBandStartsAtRestLeavesRestAndCompressionAloneAndHasExactDerivatives) {
  // activation = limit - 1 (C-IPC's s_hat = 1): the barrier acts on any stretch above 1.
  const StrainLimitSettings widest{1.2, 1.2 - 1.0, 100.0};
  EXPECT_NO_THROW(check_strain_limit_settings(widest));
  EXPECT_THROW(check_strain_limit_settings({1.2, 0.2000001, 100.0}), std::invalid_argument);
  const StrainLimitRest rest = rest_of(kRest);
  for (const Vec<9>& x : {kRest, mapped(diag2(0.9, 1.0)), mapped(diag2(0.95, 0.8))}) {
    EXPECT_EQ(strain_limit_energy(x, rest, widest), 0.0);
    EXPECT_EQ(strain_limit_gradient(x, rest, widest).norm(), 0.0);
  }
  // A 2 % stretch already feels it, where the default band (from 1.18) does not.
  EXPECT_GT(strain_limit_energy(mapped(diag2(1.02, 1.0)), rest, widest), 0.0);
  EXPECT_EQ(strain_limit_energy(mapped(diag2(1.02, 1.0)), rest, resolve_strain_limit_settings({1.2, 0.0, 100.0})), 0.0);
  expect_element_derivatives_match_fd(mapped(diag2(1.06, 0.97)), widest);
}

TEST(StrainLimit, AnisotropicStretchNearTheLimitDerivativesMatchFiniteDifferences) {
  expect_element_derivatives_match_fd(mapped(diag2(1.17, 0.95)), kWide);  // t = 0.3, sigma2 inactive
}

TEST(StrainLimit, ShearedTriangleDerivativesMatchFiniteDifferences) {
  Eigen::Matrix2d A;
  A << 1.05, 0.25, 0.0, 1.0;  // sigma = (1.160, 0.905)
  const Vec<9> x = mapped(A);
  ASSERT_NEAR(principal_stretches(x, rest_of(kRest))[0], 1.16, 0.01);
  expect_element_derivatives_match_fd(x, kWide);
}

TEST(StrainLimit, RotatedBiaxialStretchWithBothStretchesActiveDerivativesMatchFiniteDifferences) {
  const Mat3 R = Eigen::AngleAxisd(1.1, Vec3(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  Vec<9> x = mapped(diag2(1.16, 1.13), R, Vec3(2, -3, 0.5));
  x[8] += 0.02;  // and out of plane: a generic state
  const Eigen::Vector2d s = principal_stretches(x, rest_of(kRest));
  ASSERT_GT(s[1], kWide.limit - kWide.activation);  // both in the band
  expect_element_derivatives_match_fd(x, kWide);
}

TEST(StrainLimit, UniformStretchInTheBandHasRepeatedStretchesAndExactDerivatives) {
  // sigma1 == sigma2 = 1.095 under limit 1.1 (band 1.09 .. 1.1): sigma_max is not differentiable
  // here, the sum over both stretches is. The remaining gap to the wall is 0.005, so the FD steps
  // (1e-5 .. 1e-8 m on a 1 m triangle) are chosen well below it.
  const Vec<9> x = mapped(diag2(1.095, 1.095), Eigen::AngleAxisd(0.4, Vec3(1, 0, 1).normalized()).toRotationMatrix());
  const Eigen::Vector2d s = principal_stretches(x, rest_of(kRest));
  ASSERT_NEAR(s[0] - s[1], 0.0, 1e-12);
  const Mat<9> H = strain_limit_hessian(x, rest_of(kRest), kTight);
  EXPECT_TRUE(H.allFinite());
  EXPECT_TRUE(strain_limit_gradient(x, rest_of(kRest), kTight).allFinite());
  expect_element_derivatives_match_fd(x, kTight, {1e-5, 1e-6, 1e-7, 1e-8});
}

TEST(StrainLimit, HessianIsContinuousThroughRepeatedStretches) {
  // Splitting the repeated stretch by 1e-12 .. 1e-3 moves the Hessian by O(split) only: the
  // divided difference of psi' has no 0/0 and switches formula (quadrature vs quotient) smoothly.
  const StrainLimitRest rest = rest_of(kRest);
  const Mat<9> H0 = strain_limit_hessian(mapped(diag2(1.095, 1.095)), rest, kTight);
  for (double split : {1e-12, 1e-9, 1e-6, 1e-4, 1e-3}) {
    const Mat<9> H = strain_limit_hessian(mapped(diag2(1.095 + split, 1.095)), rest, kTight);
    const double rel = (H - H0).norm() / H0.norm();
    EXPECT_LT(rel, 1e-6 + 2e3 * split) << "split " << split;
    std::printf("    split %.0e: |H - H0| / |H0| = %.2e\n", split, rel);
  }
}

TEST(StrainLimit, HessianAgreesOnBothSidesOfTheDividedDifferenceSwitch) {
  // With both stretches in the band, (psi'(l1) - psi'(l2)) / (l1 - l2) is evaluated by quadrature
  // when l1 - l2 <= 0.1 (limit^2 - l1) and as the quotient above. Find the split where the rule
  // switches (sigma2 = 1.095 under limit 1.1) and compare the Hessians just below and above it.
  const StrainLimitRest rest = rest_of(kRest);
  const double L2 = kTight.limit * kTight.limit, s2 = 1.095;
  auto excess = [&](double s1) { return (s1 * s1 - s2 * s2) - 0.1 * (L2 - s1 * s1); };
  double lo = s2, hi = kTight.limit;
  for (int it = 0; it < 100; ++it) (excess(0.5 * (lo + hi)) < 0 ? lo : hi) = 0.5 * (lo + hi);
  const double s1 = 0.5 * (lo + hi);
  const Mat<9> below = strain_limit_hessian(mapped(diag2(s1 - 1e-12, s2)), rest, kTight);
  const Mat<9> above = strain_limit_hessian(mapped(diag2(s1 + 1e-12, s2)), rest, kTight);
  const double rel = (above - below).norm() / below.norm();
  EXPECT_LT(rel, 1e-7);
  std::printf("    switch at sigma1 = %.6f: |H+ - H-| / |H| = %.2e\n", s1, rel);
}

TEST(StrainLimit, RigidMotionLeavesEnergyUnchangedAndRotatesTheGradient) {
  const StrainLimitRest rest = rest_of(kRest);
  Eigen::Matrix2d A;
  A << 1.12, 0.1, -0.05, 1.08;
  const Vec<9> x = mapped(A);
  const Mat3 R = Eigen::AngleAxisd(2.3, Vec3(-0.2, 0.9, 0.4).normalized()).toRotationMatrix();
  const Vec<9> y = mapped(A, R, Vec3(5, 1, -2));
  const double E = strain_limit_energy(x, rest, kWide);
  ASSERT_GT(E, 0.0);
  EXPECT_NEAR(strain_limit_energy(y, rest, kWide), E, 1e-12 * E);
  Mat<9> Rb = Mat<9>::Zero();
  for (int v = 0; v < 3; ++v) Rb.block<3, 3>(3 * v, 3 * v) = R;
  const Vec<9> g = strain_limit_gradient(x, rest, kWide);
  EXPECT_LT((strain_limit_gradient(y, rest, kWide) - Rb * g).norm(), 1e-10 * g.norm());
  EXPECT_LT((vertex(g, 0) + vertex(g, 1) + vertex(g, 2)).norm(), 1e-10 * g.norm());  // translations
}

// Small strip mesh: 2 x (n + 1) vertices along x (length 1 m, width 0.2 m), 2n triangles; vertex 0
// of the scene belongs to another object (unreferenced).
struct Strip {
  int n;
  Positions rest;
  Faces faces;
  explicit Strip(int segments) : n(segments), rest(2 * (segments + 1) + 1, 3), faces(2 * segments, 3) {
    rest.row(0) << 9, 9, 9;
    for (int i = 0; i <= n; ++i) {
      rest.row(bottom(i)) << double(i) / n, 0.0, 0.0;
      rest.row(top(i)) << double(i) / n, 0.2, 0.0;
    }
    for (int i = 0; i < n; ++i) {
      faces.row(2 * i) << bottom(i), bottom(i + 1), top(i + 1);
      faces.row(2 * i + 1) << bottom(i), top(i + 1), top(i);
    }
  }
  int bottom(int i) const { return 1 + 2 * i; }
  int top(int i) const { return 2 + 2 * i; }
};

TEST(StrainLimit, AssembledTermDerivativesMatchFiniteDifferencesWithSeveralTrianglesActive) {
  const Strip strip(4);
  const StrainLimitTerm term(strip.faces, strip.rest, kWide);
  Eigen::VectorXd x = stacked(strip.rest);
  for (Eigen::Index v = 1; v < strip.rest.rows(); ++v) {
    x[3 * v] *= 1.14;                      // stretch along the strip into the band
    x[3 * v + 1] *= 0.97;
  }
  x.tail(x.size() - 3) += 0.006 * test::wavy(x.size() - 3, 1.7, 0.3);  // generic, out of plane too
  int active = 0;
  for (int f = 0; f < strip.faces.rows(); ++f) {
    Vec<9> xe, Xe;
    for (int k = 0; k < 3; ++k) {
      xe.segment<3>(3 * k) = x.segment<3>(3 * strip.faces(f, k));
      Xe.segment<3>(3 * k) = strip.rest.row(strip.faces(f, k)).transpose();
    }
    active += strain_limit_energy(xe, rest_of(Xe), kWide) > 0.0;
  }
  ASSERT_GE(active, 4);
  std::printf("    %d of %d triangles in the band, max stretch %.4f\n", active, int(strip.faces.rows()),
              term.max_stretch(x));

  const test::TermFdCheck c = test::check_term_derivatives(term, x);
  const int n = static_cast<int>(x.size()), steps = static_cast<int>(test::default_steps().size());
  EXPECT_EQ(c.gradient.comparisons, steps * n);
  EXPECT_EQ(c.hessian.comparisons, steps * n * n);
  test::expect_derivatives_match(c, kGradTol, kHessTol);
  std::printf("    FD gradient best %.2e, Hessian best %.2e (%d + %d comparisons)\n", c.gradient.best_rel_error,
              c.hessian.best_rel_error, c.gradient.comparisons, c.hessian.comparisons);
  EXPECT_EQ(test::term_gradient(term, x).head<3>().norm(), 0.0);  // unreferenced vertex 0
}

TEST(StrainLimit, ExactHessianIsPsdSinceTheTermIsConvexAndProjectionLeavesIt) {
  // sum_i phi(sigma_i(F)) with phi convex and nondecreasing is convex in F (Lewis 1995), and F is
  // linear in x: the exact element Hessian is PSD, with both stretches in the band as well. The
  // projections must keep it (PSD, changed by round-off at most).
  const StrainLimitRest rest = rest_of(kRest);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst_min = 0.0, worst_change = 0.0;
  int both_active = 0;
  for (int trial = 0; trial < 200; ++trial) {
    // Random in-plane map with stretches in (1.1, 1.2) and (0.8, 1.2), random rotation, a bump.
    const double s1 = 1.1 + 0.0999 * (0.5 + 0.5 * u(rng)), s2 = 1.0 + 0.2 * u(rng) * (s1 - 1.0) / 0.1;
    const Eigen::Matrix2d U = Eigen::Rotation2Dd(3.0 * u(rng)).toRotationMatrix();
    const Eigen::Matrix2d V = Eigen::Rotation2Dd(3.0 * u(rng)).toRotationMatrix();
    const Mat3 R = Eigen::AngleAxisd(3.0 * u(rng), Vec3(u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
    Vec<9> x = mapped(U * diag2(s1, std::min(s2, s1)) * V, R);
    x[3 * (trial % 3) + 2] += 0.01 * u(rng);
    if (!std::isfinite(strain_limit_energy(x, rest, kWide)) || strain_limit_energy(x, rest, kWide) == 0.0) continue;
    both_active += principal_stretches(x, rest)[1] > kWide.limit - kWide.activation;
    const Mat<9> H = strain_limit_hessian(x, rest, kWide);
    worst_min = std::min(worst_min, min_eigenvalue(H) / H.norm());
    for (HessianProjection proj : {HessianProjection::Clamp, HessianProjection::Abs}) {
      const Mat<9> Hp = project_hessian<9>(H, proj);
      EXPECT_GE(min_eigenvalue(Hp), -1e-10 * H.norm()) << to_string(proj);
      worst_change = std::max(worst_change, (Hp - H).norm() / H.norm());
    }
  }
  EXPECT_GE(worst_min, -1e-10);
  EXPECT_LT(worst_change, 1e-9);
  EXPECT_GE(both_active, 20);
  std::printf("    200 active states (%d with both stretches in the band): min eigenvalue / |H| >= %.2e, "
              "projection changed H by <= %.2e relative\n", both_active, worst_min, worst_change);

  // Through the term's assembly as well.
  const OneTriangle tri;
  const StrainLimitTerm term(tri.faces, tri.rest, kWide);
  Vec<9> x = mapped(diag2(1.16, 1.13));
  x[8] += 0.02;
  const Eigen::VectorXd xv = x;
  const Eigen::MatrixXd H = test::term_hessian(term, xv, HessianProjection::None);
  EXPECT_LT((H - Eigen::MatrixXd(strain_limit_hessian(x, rest, kWide))).norm(), 1e-12 * H.norm());
  for (HessianProjection proj : {HessianProjection::Clamp, HessianProjection::Abs})
    EXPECT_GE(min_eigenvalue(test::term_hessian(term, xv, proj)), -1e-10 * H.norm()) << to_string(proj);
}

// ---- max_step ----

// Largest stretch of a triangle by JacobiSVD (independent of the closed form under test).
double svd_stretch(const Vec<9>& x, const StrainLimitRest& rest) {
  return Eigen::JacobiSVD<Mat32>(strain_limit_deformation_gradient(x, rest)).singularValues()[0];
}

// First alpha in [0, 1] where the triangle reaches the limit (infinity if none): a scan of 2000
// samples, then bisection of the first bracketing interval.
double true_crossing(const Vec<9>& x, const Vec<9>& dx, const StrainLimitRest& rest, double limit) {
  const int samples = 2000;
  for (int k = 1; k <= samples; ++k) {
    const double a = double(k) / samples;
    if (svd_stretch(x + a * dx, rest) >= limit) {
      double lo = double(k - 1) / samples, hi = a;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        (svd_stretch(x + mid * dx, rest) < limit ? lo : hi) = mid;
      }
      return hi;
    }
  }
  return std::numeric_limits<double>::infinity();
}

TEST(StrainLimit, MaxStepKeepsEveryTriangleBelowTheLimitAndIsTight) {
  const Strip strip(5);
  const StrainLimitTerm term(strip.faces, strip.rest, kTight);
  std::vector<StrainLimitRest> rests;
  for (int f = 0; f < strip.faces.rows(); ++f) {
    Vec<9> Xe;
    for (int k = 0; k < 3; ++k) Xe.segment<3>(3 * k) = strip.rest.row(strip.faces(f, k)).transpose();
    rests.push_back(rest_of(Xe));
  }
  auto gather = [&](const Eigen::VectorXd& v, int f) {
    Vec<9> e;
    for (int k = 0; k < 3; ++k) e.segment<3>(3 * k) = v.segment<3>(3 * strip.faces(f, k));
    return e;
  };

  std::mt19937 rng(42);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  int crossing_cases = 0;
  double worst_ratio = 1e300, best_ratio = 0.0;
  for (int trial = 0; trial < 60; ++trial) {
    // Start: the rest strip, some of it already well into the band (up to 1.098 of 1.1).
    Eigen::VectorXd x = stacked(strip.rest);
    const double pre = 1.0 + 0.098 * uni(rng);
    for (Eigen::Index v = 1; v < strip.rest.rows(); ++v) x[3 * v] *= pre;
    ASSERT_EQ(term.first_violating_triangle(x), -1);
    // Random step, large enough to cross in most trials.
    Eigen::VectorXd dx(x.size());
    for (Eigen::Index i = 0; i < dx.size(); ++i) dx[i] = normal(rng);
    dx *= (trial % 3 == 0 ? 0.02 : 0.2) * uni(rng);

    const double alpha = term.max_step(x, dx);
    ASSERT_GT(alpha, 0.0);
    ASSERT_LE(alpha, 1.0);
    const Eigen::VectorXd trial_x = x + alpha * dx;
    EXPECT_LT(term.max_stretch(trial_x), kTight.limit);
    EXPECT_EQ(term.first_violating_triangle(trial_x), -1);
    EXPECT_TRUE(std::isfinite(term.value(trial_x)));
    for (int f = 0; f < strip.faces.rows(); ++f) EXPECT_LT(svd_stretch(gather(trial_x, f), rests[f]), kTight.limit);

    double crossing = std::numeric_limits<double>::infinity();
    for (int f = 0; f < strip.faces.rows(); ++f)
      crossing = std::min(crossing, true_crossing(gather(x, f), gather(dx, f), rests[f], kTight.limit));
    if (std::isinf(crossing)) {
      EXPECT_EQ(alpha, 1.0);
      continue;
    }
    ++crossing_cases;
    const double ratio = alpha / crossing;
    worst_ratio = std::min(worst_ratio, ratio);
    best_ratio = std::max(best_ratio, ratio);
    EXPECT_LT(ratio, 1.0);
    EXPECT_GT(ratio, kStrainLimitStepSafety * (1 - 1e-5)) << "not the safety fraction of the crossing";
  }
  EXPECT_GE(crossing_cases, 30);
  std::printf("    %d crossing steps: alpha / true crossing in [%.7f, %.7f] (safety %.2f)\n", crossing_cases,
              worst_ratio, best_ratio, kStrainLimitStepSafety);
}

TEST(StrainLimit, MaxStepIsOneForHarmlessStepsAndZeroFromAnInadmissibleStart) {
  const OneTriangle tri;
  const StrainLimitTerm term(tri.faces, tri.rest, kTight);
  const Eigen::VectorXd rest = stacked(tri.rest);
  const Eigen::VectorXd shrink = -0.3 * rest;  // compression only
  EXPECT_EQ(term.max_step(rest, shrink), 1.0);
  EXPECT_EQ(term.max_step(rest, Eigen::VectorXd::Zero(rest.size())), 1.0);
  const Eigen::VectorXd over = stacked(tri.rest) * 1.2;  // uniform 20 % stretch: over the limit
  EXPECT_EQ(term.first_violating_triangle(over), 0);
  EXPECT_NEAR(term.max_stretch(over), 1.2, 1e-14);
  EXPECT_EQ(term.max_step(over, shrink), 0.0);
  // Convexity guarantee: the step keeps a tenth of the gap. Uniform stretch from 1 towards 1.5.
  const double alpha = term.max_step(rest, 0.5 * rest);
  const double after = term.max_stretch(rest + alpha * 0.5 * rest);
  EXPECT_GE(kTight.limit - after, 0.1 * (kTight.limit - 1.0) * (1 - 1e-6));
  EXPECT_NEAR(alpha, 0.9 * 0.2, 1e-6);  // crossing at 1 + 0.5 a = 1.1
}

// ---- behaviour ----

// Linear potential -f . x on some vertices: a constant pulling force (N).
class PullTerm : public EnergyTerm {
 public:
  explicit PullTerm(Eigen::VectorXd f) : f_(std::move(f)) {}
  std::string name() const override { return "pull"; }
  double value(const Eigen::VectorXd& x) const override { return -f_.dot(x); }
  void add_gradient(const Eigen::VectorXd& /*x*/, Eigen::VectorXd& g) const override { g -= f_; }
  void add_hessian(const Eigen::VectorXd&, HessianProjection, HessianAssembly&) const override {}

 private:
  Eigen::VectorXd f_;
};

// Records the largest stretch at every state the solver evaluates (contributes nothing).
class StretchRecorder : public EnergyTerm {
 public:
  explicit StretchRecorder(const StrainLimitTerm* limit) : limit_(limit) {}
  std::string name() const override { return "recorder"; }
  double value(const Eigen::VectorXd& x) const override {
    stretches_.push_back(limit_->max_stretch(x));
    return 0.0;
  }
  void add_gradient(const Eigen::VectorXd&, Eigen::VectorXd&) const override {}
  void add_hessian(const Eigen::VectorXd&, HessianProjection, HessianAssembly&) const override {}
  const std::vector<double>& stretches() const { return stretches_; }

 private:
  const StrainLimitTerm* limit_;
  mutable std::vector<double> stretches_;
};

struct PulledStrip {
  double max_stretch = 0.0;
  NewtonReport report;
  std::vector<double> evaluated_stretches;
};

// The strip pinned at x = 0, pulled along +x at x = 1 by `force` (N, total), in-plane (z fixed),
// minimised statically by Newton from rest, with or without the strain limit.
PulledStrip pull_strip(double force, bool with_limit) {
  const Strip strip(5);
  const double E = 1e5, nu = 0.3, h = 1e-3;  // Pa, -, m: E h = 100 N/m
  const int ndof = static_cast<int>(3 * strip.rest.rows());
  IncrementalPotential ip;
  ip.add_term(std::make_unique<NeoHookeanMembrane>(strip.faces, strip.rest, MembraneMaterialParams::from(E, nu, h)));
  auto limit = std::make_unique<StrainLimitTerm>(strip.faces, strip.rest, StrainLimitSettings::from(1.1, E, h));
  auto recorder = std::make_unique<StretchRecorder>(limit.get());
  const StrainLimitTerm* limit_ptr = limit.get();
  const StretchRecorder* recorder_ptr = recorder.get();
  if (with_limit) ip.add_term(std::move(limit));
  ip.add_term(std::move(recorder));
  Eigen::VectorXd f = Eigen::VectorXd::Zero(ndof);
  f[3 * strip.bottom(strip.n)] = f[3 * strip.top(strip.n)] = 0.5 * force;
  ip.add_term(std::make_unique<PullTerm>(f));
  std::vector<char> fixed(ndof, 0);
  for (int v = 0; v < strip.rest.rows(); ++v) fixed[3 * v + 2] = 1;  // planar problem
  for (int k = 0; k < 3; ++k) {
    fixed[3 * 0 + k] = 1;  // the unreferenced vertex
    fixed[3 * strip.bottom(0) + k] = fixed[3 * strip.top(0) + k] = 1;
  }
  ip.set_fixed_dofs(fixed);

  Eigen::VectorXd x = stacked(strip.rest);
  NewtonSettings s;
  s.h = 1.0;
  // m (h = 1 s). Newton converges quadratically down to ~1e-9 m steps; below that the potential
  // (-f . x ~ 2e3 J at 2000 N) cannot resolve the decrease and the line search stops at no_descent.
  s.step_tolerance = 1e-7;
  s.max_iterations = 300;
  s.projection = HessianProjection::Clamp;
  HessianAssembly H;
  CholmodSolver solver;
  PulledStrip out;
  out.report = newton_minimize(ip, x, s, H, solver);
  out.max_stretch = limit_ptr->max_stretch(x);
  out.evaluated_stretches = recorder_ptr->stretches();
  return out;
}

TEST(StrainLimit, PulledStripNeverExceedsTheLimitAndSettlesInTheBand) {
  // 20 N over a 0.2 m wide strip of E h = 100 N/m: about 100 % strain for the membrane alone.
  const PulledStrip free = pull_strip(20.0, false);
  ASSERT_TRUE(free.report.converged) << free.report.stop_reason;
  EXPECT_GT(free.max_stretch, 1.5);

  for (double force : {20.0, 2000.0}) {
    SCOPED_TRACE(force);
    const PulledStrip limited = pull_strip(force, true);
    ASSERT_TRUE(limited.report.converged) << limited.report.stop_reason;
    ASSERT_FALSE(limited.evaluated_stretches.empty());
    const double worst = *std::max_element(limited.evaluated_stretches.begin(), limited.evaluated_stretches.end());
    EXPECT_LT(worst, 1.1) << "a state the solver evaluated exceeded the limit";
    EXPECT_GT(limited.max_stretch, 1.09) << "the load must drive the strip into the band";
    EXPECT_LT(limited.max_stretch, 1.1);
    std::printf("    force %6.0f N: final max stretch %.6f (free membrane %.3f), %d Newton iterations, "
                "%d line-search cuts, %zu states evaluated, largest %.6f\n",
                force, limited.max_stretch, free.max_stretch, limited.report.iterations,
                limited.report.line_search_cuts, limited.evaluated_stretches.size(), worst);
  }
}

}  // namespace
}  // namespace pd
