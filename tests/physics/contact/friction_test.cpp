// IPC's lagged, smoothed friction: the FrictionTerm's derivatives in every smoothing regime and for
// every stencil size, its invariance to rigid translation, its Hessian projection, stick/slip of a
// pushed vertex, and the contacts BarrierPotential reports for it.
#include "physics/contact/friction.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "geometry/shapes.h"
#include "geometry/topology.h"
#include "physics/contact/barrier.h"
#include "physics/contact/barrier_potential.h"
#include "physics/contact/distance.h"
#include "physics/contact/edge_edge_mollifier.h"
#include "support/term_eval.h"
#include "support/two_squares.h"

namespace pd {
namespace {

using test::TwoSquares;

// A source that reports a fixed list of hand-made contacts, whatever x.
class FixedContacts : public FrictionSource {
 public:
  explicit FixedContacts(std::vector<FrictionContact> c) : contacts(std::move(c)) {}
  void friction_contacts(const Eigen::VectorXd&, std::vector<FrictionContact>& out) const override {
    out.insert(out.end(), contacts.begin(), contacts.end());
  }
  std::vector<FrictionContact> contacts;
};

FrictionContact make_contact(std::vector<int> verts, std::vector<double> w, const Vec3& normal,
                             double lambda, double mu) {
  FrictionContact c;
  c.count = static_cast<int>(verts.size());
  for (int k = 0; k < c.count; ++k) {
    c.vertices[k] = verts[k];
    c.weights[k] = w[k];
  }
  const Vec3 n = normal.normalized();
  const Vec3 t0 = n.unitOrthogonal();
  c.basis << t0, n.cross(t0);
  c.normal_force = lambda;
  c.mu = mu;
  return c;
}

// Five contacts on disjoint vertices, stencil sizes 1, 2, 3, 4 (point-triangle-like), 4
// (edge-edge-like), each with its own normal, normal force and coefficient; weights sum to zero
// except the size-1 stencil (a vertex against something fixed, w = (1)).
struct Contacts {
  static constexpr double kEpsV = 0.1, kH = 0.1;  // m/s, s: eps_u = 0.01 m
  std::vector<FrictionContact> list;
  Eigen::VectorXd x_start;
  Contacts() {
    list.push_back(make_contact({0}, {1.0}, Vec3(0, 0, 1), 2.0, 0.5));
    list.push_back(make_contact({1, 2}, {1.0, -1.0}, Vec3(1, 1, 0), 0.7, 0.3));
    list.push_back(make_contact({3, 4, 5}, {1.0, -0.3, -0.7}, Vec3(0.2, -1, 0.4), 1.5, 0.8));
    list.push_back(make_contact({6, 7, 8, 9}, {1.0, -0.2, -0.5, -0.3}, Vec3(-0.3, 0.1, 1), 3.0, 0.4));
    list.push_back(make_contact({10, 11, 12, 13}, {0.35, 0.65, -0.6, -0.4}, Vec3(1, -0.5, 0.2), 0.9, 0.6));
    x_start = test::wavy(3 * 14, 0.7, 0.3);
  }
  // Positions whose contact c has tangential displacement T_c^T u[c] (m): the stencil's first vertex
  // (weight w0) moves by T u / w0 plus a normal motion, and the whole stencil by a common translation,
  // neither of which changes u.
  Eigen::VectorXd displaced(const std::vector<Eigen::Vector2d>& u) const {
    Eigen::VectorXd x = x_start;
    for (size_t i = 0; i < list.size(); ++i) {
      const FrictionContact& c = list[i];
      const Vec3 n = c.basis.col(0).cross(c.basis.col(1));
      x.segment<3>(3 * c.vertices[0]) += (c.basis * u[i] + 0.02 * n) / c.weights[0];
      const Vec3 translation(0.01 * i, -0.02, 0.03);
      if (c.count > 1)
        for (int k = 0; k < c.count; ++k) x.segment<3>(3 * c.vertices[k]) += translation;
    }
    return x;
  }
};

Eigen::Vector2d dir(double angle) { return Eigen::Vector2d(std::cos(angle), std::sin(angle)); }

// Term with the hand-made contacts lagged at x_start.
struct LaggedTerm {
  Contacts c;
  FixedContacts source{c.list};
  FrictionTerm term{Contacts::kEpsV};
  LaggedTerm() {
    term.add_source(&source);
    StepStart step;
    step.h = Contacts::kH;
    step.x = &c.x_start;
    term.begin_step(step);
  }
  // |u| of every contact at x.
  std::vector<double> slips(const Eigen::VectorXd& x) const {
    std::vector<double> out;
    for (const FrictionContact& f : term.contacts()) {
      Vec3 s = Vec3::Zero();
      for (int k = 0; k < f.count; ++k)
        s += f.weights[k] * (x.segment<3>(3 * f.vertices[k]) - c.x_start.segment<3>(3 * f.vertices[k]));
      out.push_back((f.basis.transpose() * s).norm());
    }
    return out;
  }
};

void report(const char* what, const test::TermFdCheck& check) {
  std::printf("%s: gradient rel err %.2e (%d comparisons), Hessian rel err %.2e (%d comparisons)\n", what,
              check.gradient.best_rel_error, check.gradient.comparisons, check.hessian.best_rel_error,
              check.hessian.comparisons);
}

TEST(FrictionSmoothing, F0IsC1AtEpsUAndF1IsItsDerivative) {
  const double eps = 0.01;
  EXPECT_DOUBLE_EQ(friction_f0(0.0, eps), eps / 3.0);
  // Left limits at eps_u (1e-12 relative below it: f0 moves by ~1e-14 m, f1 by ~1e-24).
  EXPECT_NEAR(friction_f0(eps * (1 - 1e-12), eps), eps, 2e-14);
  EXPECT_NEAR(friction_f1(eps * (1 - 1e-12), eps), 1.0, 1e-10);
  EXPECT_DOUBLE_EQ(friction_f1_over_y(0.0, eps), 2.0 / eps);
  for (double y : {1e-4, 3e-3, 0.7e-2, 0.02}) {
    const double d = 1e-7;
    const double fd = (friction_f0(y + d, eps) - friction_f0(y - d, eps)) / (2 * d);
    EXPECT_NEAR(friction_f1(y, eps), fd, 1e-7) << y;
    EXPECT_NEAR(friction_f1_over_y(y, eps), friction_f1(y, eps) / y, 1e-9 / y) << y;
  }
}

TEST(FrictionTerm, RejectsNonPositiveEpsVNullSourcesAndStepsWithoutPositions) {
  EXPECT_THROW(FrictionTerm(0.0), std::invalid_argument);
  EXPECT_THROW(FrictionTerm(-1e-3), std::invalid_argument);
  EXPECT_THROW(FrictionTerm(NAN), std::invalid_argument);
  FrictionTerm term(1e-3);
  EXPECT_EQ(term.name(), "friction");
  EXPECT_THROW(term.add_source(nullptr), std::invalid_argument);
  StepStart step;
  step.h = 0.01;
  EXPECT_THROW(term.begin_step(step), std::invalid_argument);  // no positions
  const Eigen::VectorXd x = Eigen::VectorXd::Zero(6);
  step.x = &x;
  step.h = 0.0;
  EXPECT_THROW(term.begin_step(step), std::invalid_argument);
}

TEST(FrictionTerm, BeginStepLagsContactsFromEverySource) {
  LaggedTerm t;
  FixedContacts second({make_contact({0}, {1.0}, Vec3(0, 1, 0), 1.0, 1.0)});
  t.term.add_source(&second);
  StepStart step;
  step.h = 0.02;
  step.x = &t.c.x_start;
  t.term.begin_step(step);
  EXPECT_EQ(t.term.contacts().size(), t.c.list.size() + 1);
  EXPECT_DOUBLE_EQ(t.term.eps_u(), Contacts::kEpsV * 0.02);
  t.term.begin_step(step);  // gathers afresh, does not accumulate
  EXPECT_EQ(t.term.contacts().size(), t.c.list.size() + 1);
}

// Sliding: |u| = 3 eps_u for every contact. FD steps (<= 1e-4 m) stay far from the kink at eps_u.
TEST(FrictionTerm, DerivativesMatchFiniteDifferencesWhenEveryContactSlides) {
  LaggedTerm t;
  const double eps_u = t.term.eps_u();
  std::vector<Eigen::Vector2d> u;
  for (int i = 0; i < 5; ++i) u.push_back(3.0 * eps_u * dir(0.9 * i + 0.2));
  const Eigen::VectorXd x = t.c.displaced(u);
  for (double s : t.slips(x)) EXPECT_NEAR(s, 3.0 * eps_u, 1e-12);
  const test::TermFdCheck check = test::check_term_derivatives(t.term, x);
  report("sliding", check);
  test::expect_derivatives_match(check, 1e-6, 1e-6);
}

// Sticking: |u| = 0.4 eps_u, on the cubic branch of f0.
TEST(FrictionTerm, DerivativesMatchFiniteDifferencesWhenEveryContactSticks) {
  LaggedTerm t;
  const double eps_u = t.term.eps_u();
  std::vector<Eigen::Vector2d> u;
  for (int i = 0; i < 5; ++i) u.push_back(0.4 * eps_u * dir(1.3 * i - 0.4));
  const Eigen::VectorXd x = t.c.displaced(u);
  for (double s : t.slips(x)) EXPECT_NEAR(s, 0.4 * eps_u, 1e-12);
  const test::TermFdCheck check = test::check_term_derivatives(t.term, x);
  report("sticking", check);
  test::expect_derivatives_match(check, 1e-6, 1e-6);
}

// Contacts of sizes 1 and 4 at exactly u = 0 (their vertices at x^t), next to a sliding (size 3), a
// sticking (size 2) and a just-sliding (size 4) one. At u = 0, f0(|u|) has a |u|^3 term, so the
// central differences of the gradient there err by O(step / eps_u) (1e-5 at the 1e-7 m step).
TEST(FrictionTerm, DerivativesMatchFiniteDifferencesWithContactsAtExactlyZeroSlip) {
  LaggedTerm t;
  const double eps_u = t.term.eps_u();
  std::vector<Eigen::Vector2d> u = {Eigen::Vector2d::Zero(), 0.7 * eps_u * dir(2.0), 5.0 * eps_u * dir(-1.0),
                                    Eigen::Vector2d::Zero(), 1.2 * eps_u * dir(0.5)};
  Eigen::VectorXd x = t.c.displaced(u);
  for (int i : {0, 3})
    for (int k = 0; k < t.c.list[i].count; ++k) {
      const int v = t.c.list[i].vertices[k];
      x.segment<3>(3 * v) = t.c.x_start.segment<3>(3 * v);
    }
  const std::vector<double> slip = t.slips(x);
  EXPECT_EQ(slip[0], 0.0);
  EXPECT_EQ(slip[3], 0.0);
  const test::TermFdCheck check = test::check_term_derivatives(t.term, x);
  report("zero slip mixed", check);
  EXPECT_TRUE(check.H.allFinite());
  test::expect_derivatives_match(check, 1e-6, 1e-4);
}

// x = x^t: the gradient is exactly zero (no NaN from u/|u|) and the Hessian is the u -> 0 limit
// mu lambda (2/eps_u) Gamma Gamma^T, built here independently per contact.
TEST(FrictionTerm, AtTheStartOfTheStepGradientIsZeroAndHessianIsTheStickingLimit) {
  LaggedTerm t;
  const Eigen::VectorXd& x = t.c.x_start;
  const double eps_u = t.term.eps_u();
  double expected_value = 0.0;
  Eigen::MatrixXd expected_H = Eigen::MatrixXd::Zero(x.size(), x.size());
  for (const FrictionContact& c : t.c.list) {
    expected_value += c.mu * c.normal_force * eps_u / 3.0;
    Eigen::MatrixXd gamma = Eigen::MatrixXd::Zero(x.size(), 2);
    for (int k = 0; k < c.count; ++k) gamma.block<3, 2>(3 * c.vertices[k], 0) = c.weights[k] * c.basis;
    expected_H += c.mu * c.normal_force * (2.0 / eps_u) * gamma * gamma.transpose();
  }
  EXPECT_NEAR(t.term.value(x), expected_value, 1e-15);
  const Eigen::VectorXd g = test::term_gradient(t.term, x);
  EXPECT_TRUE(g.allFinite());
  EXPECT_EQ(g.norm(), 0.0);
  const Eigen::MatrixXd H = test::term_hessian(t.term, x, HessianProjection::None);
  EXPECT_LT((H - expected_H).norm(), 1e-12 * expected_H.norm());
  const test::FdResult fd = test::check_hessian([&](const Eigen::VectorXd& y) { return test::term_gradient(t.term, y); },
                                                x, H);
  std::printf("at rest: Hessian rel err %.2e (%d comparisons)\n", fd.best_rel_error, fd.comparisons);
  EXPECT_GT(fd.comparisons, 0);
  EXPECT_GE(fd.steps_within(1e-4), 2);
}

TEST(FrictionTerm, MaxTangentialStepIsTheLargestSlipChangeAStepMakesAndIgnoresNormalAndRigidMotion) {
  LaggedTerm t;
  // A step whose contact i changes its slip by |u_i| (m), plus normal motion and a rigid
  // translation of each stencil (displaced() adds both), measured from x_start.
  const std::vector<Eigen::Vector2d> u = {0.004 * dir(0.3), 0.011 * dir(1.9), 0.002 * dir(-0.4),
                                          0.007 * dir(2.5), 0.0005 * dir(0.8)};
  const Eigen::VectorXd p = t.c.displaced(u) - t.c.x_start;
  EXPECT_NEAR(t.term.max_tangential_step(p), 0.011, 1e-15);
  // A zero step, and a rigid translation of contact 4's stencil: no slip change.
  EXPECT_EQ(t.term.max_tangential_step(Eigen::VectorXd::Zero(t.c.x_start.size())), 0.0);
  Eigen::VectorXd rigid = Eigen::VectorXd::Zero(t.c.x_start.size());
  for (int v : {10, 11, 12, 13}) rigid.segment<3>(3 * v) = Vec3(0.3, -0.1, 0.2);
  EXPECT_NEAR(t.term.max_tangential_step(rigid), 0.0, 1e-15);
  // Without contacts (before any begin_step) it is zero.
  const FrictionTerm empty(Contacts::kEpsV);
  EXPECT_EQ(empty.max_tangential_step(p), 0.0);
}

// Translating a whole stencil rigidly leaves u unchanged, from rest (energy stays at the constant
// mu lambda eps_u / 3, zero gradient) and from a sliding state (energy and gradient unchanged).
TEST(FrictionTerm, RigidTranslationOfAStencilDoesNotChangeSlipEnergyOrGradient) {
  LaggedTerm t;
  const double eps_u = t.term.eps_u();
  const Vec3 shift(0.3, -0.2, 0.5);
  std::vector<Eigen::Vector2d> sliding;
  for (int i = 0; i < 5; ++i) sliding.push_back(2.0 * eps_u * dir(0.4 * i));
  const Eigen::VectorXd x_slide = t.c.displaced(sliding);
  const Eigen::VectorXd g_slide = test::term_gradient(t.term, x_slide);
  for (const FrictionContact& c : t.c.list) {
    if (c.count == 1) continue;  // a size-1 stencil is a vertex against a fixed body: no translation invariance
    Eigen::VectorXd x = t.c.x_start, y = x_slide;
    for (int k = 0; k < c.count; ++k) {
      x.segment<3>(3 * c.vertices[k]) += shift;
      y.segment<3>(3 * c.vertices[k]) += shift;
    }
    const double scale = c.mu * c.normal_force;
    // From rest: only this contact moved, and its u stays ~0 (round-off of x^t + shift - x^t).
    EXPECT_NEAR(t.term.value(x), t.term.value(t.c.x_start), 1e-15) << c.count;
    EXPECT_LT(test::term_gradient(t.term, x).norm(), 1e-10 * scale) << c.count;
    // From sliding.
    EXPECT_NEAR(t.term.value(y), t.term.value(x_slide), 1e-14) << c.count;
    EXPECT_LT((test::term_gradient(t.term, y) - g_slide).norm(), 1e-10 * g_slide.norm()) << c.count;
  }
}

double min_eigenvalue(const Eigen::MatrixXd& H) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(H).eigenvalues().minCoeff();
}

// With IPC's f0 the 2x2 Hessian in u has eigenvalues mu lambda f1'(|u|) >= 0 along u and
// mu lambda f1(|u|)/|u| > 0 across it, so D is convex and even the exact Hessian is PSD (to
// round-off); the Clamp projection therefore must give a PSD matrix equal to the exact one. Checked in
// every regime, including just below and above the kink at eps_u, where f1' -> 0.
TEST(FrictionTerm, ClampProjectedHessianIsPsdAndTheExactOneIsPsdToRoundOff) {
  LaggedTerm t;
  const double eps_u = t.term.eps_u();
  for (double r : {0.0, 1e-9, 0.3, 0.999999, 1.0, 1.000001, 4.0}) {
    std::vector<Eigen::Vector2d> u;
    for (int i = 0; i < 5; ++i) u.push_back(r * eps_u * dir(0.8 * i + 0.1));
    const Eigen::VectorXd x = t.c.displaced(u);
    const Eigen::MatrixXd exact = test::term_hessian(t.term, x, HessianProjection::None);
    const Eigen::MatrixXd clamp = test::term_hessian(t.term, x, HessianProjection::Clamp);
    const Eigen::MatrixXd abs = test::term_hessian(t.term, x, HessianProjection::Abs);
    const double scale = exact.norm();
    std::printf("|u|/eps_u = %g: min eigenvalue exact %.3g, clamp %.3g (largest %.3g)\n", r, min_eigenvalue(exact),
                min_eigenvalue(clamp), Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(exact).eigenvalues().maxCoeff());
    EXPECT_GE(min_eigenvalue(clamp), -1e-12 * scale) << r;
    EXPECT_GE(min_eigenvalue(exact), -1e-12 * scale) << r;
    EXPECT_LT((clamp - exact).norm(), 1e-12 * scale) << r;
    EXPECT_LT((abs - exact).norm(), 1e-12 * scale) << r;
  }
}

// A vertex resting on a fixed triangle (normal force lambda) is pushed along the tangent plane by a
// constant force F for one implicit-Euler step from rest: it minimises
//   E(p) = m/(2h^2) |p - p^t|^2 - F . (p - p^t) + D(p)
// over its 3 coordinates (Newton with backtracking, by hand). Coulomb: it sticks (|u| < eps_u) for
// |F| < mu lambda; for |F| > mu lambda it slides with m/h^2 |u| = |F| - mu lambda exactly (f1 = 1
// beyond eps_u), along F.
TEST(FrictionTerm, VertexPushedOnAFixedTriangleSticksBelowMuLambdaAndSlidesAbove) {
  const double m = 1e-3, h = 0.01, lambda = 1.0, mu = 0.5, eps_v = 1e-3;  // kg, s, N, -, m/s
  Eigen::VectorXd x_start(12);
  x_start << 0.2, 0.2, 1e-3, 0, 0, 0, 1, 0, 0, 0, 1, 0;  // p above triangle (0,0,0), (1,0,0), (0,1,0)
  FixedContacts source({make_contact({0, 1, 2, 3}, {1.0, -0.6, -0.2, -0.2}, Vec3(0, 0, 1), lambda, mu)});
  FrictionTerm term(eps_v);
  term.add_source(&source);
  StepStart step;
  step.h = h;
  step.x = &x_start;
  term.begin_step(step);
  const double eps_u = term.eps_u(), k = m / (h * h);  // m, N/m
  const Vec3 direction = Vec3(std::cos(0.5), std::sin(0.5), 0.0);

  auto solve = [&](double F) {
    const Vec3 force = F * direction;
    auto energy = [&](const Vec3& d) {
      Eigen::VectorXd x = x_start;
      x.segment<3>(0) += d;
      return 0.5 * k * d.squaredNorm() - force.dot(d) + term.value(x);
    };
    Vec3 d = Vec3::Zero();
    int iterations = 0;
    for (; iterations < 100; ++iterations) {
      Eigen::VectorXd x = x_start;
      x.segment<3>(0) += d;
      const Vec3 g = k * d - force + test::term_gradient(term, x).segment<3>(0);
      // Round-off floor: x - x^t carries ~3e-17 m of error, times the sticking curvature
      // 2 mu lambda / eps_u = 1e5 N/m.
      if (g.norm() < 1e-10) break;
      const Mat3 H = k * Mat3::Identity() + test::term_hessian(term, x, HessianProjection::Clamp).block<3, 3>(0, 0);
      const Vec3 step_dir = -H.ldlt().solve(g);
      double alpha = 1.0;
      while (energy(d + alpha * step_dir) > energy(d) && alpha > 1e-12) alpha *= 0.5;
      d += alpha * step_dir;
    }
    EXPECT_LT(iterations, 100) << "Newton did not converge for F = " << F;
    EXPECT_NEAR(d.z(), 0.0, 1e-15);  // friction is tangential only
    return d;
  };

  for (double F : {0.1, 0.3, 0.45, 0.49}) {
    const Vec3 d = solve(F);
    std::printf("F = %.2f N (mu lambda = %.2f N): |u| = %.3g m = %.3f eps_u\n", F, mu * lambda, d.norm(),
                d.norm() / eps_u);
    EXPECT_LT(d.norm(), eps_u) << F;
  }
  double previous = 0.0;
  for (double F : {0.51, 0.6, 0.8, 1.2}) {
    const Vec3 d = solve(F);
    std::printf("F = %.2f N (mu lambda = %.2f N): |u| = %.3g m = %.1f eps_u\n", F, mu * lambda, d.norm(),
                d.norm() / eps_u);
    EXPECT_GT(d.norm(), eps_u) << F;
    EXPECT_GT(d.norm(), previous) << F;
    EXPECT_NEAR(d.norm(), (F - mu * lambda) / k, 1e-10) << F;  // residual 1e-10 N / (k = 10 N/m)
    EXPECT_NEAR(d.normalized().dot(direction), 1.0, 1e-12) << F;
    previous = d.norm();
  }
}

// ---- BarrierPotential as a friction source ----------------------------------------------------

// |ea_rest|^2 |eb_rest|^2 of an edge-edge contact's two edges (the mollifier threshold's factor).
double edge_rest2(const TwoSquares& s, const FrictionContact& c) {
  auto len2 = [&](int a, int b) { return (s.rest.row(a) - s.rest.row(b)).squaredNorm(); };
  return len2(c.vertices[0], c.vertices[1]) * len2(c.vertices[2], c.vertices[3]);
}

ContactSettings two_squares_settings() {
  ContactSettings cs;
  cs.dhat = 0.2;
  cs.offset = 0.01;
  cs.kappa = 10.0;
  return cs;
}

Eigen::MatrixXd pair_mu(double between, double self = 0.0) {
  Eigen::MatrixXd mu(2, 2);
  mu << self, between, between, self;
  return mu;
}

// For every active pair: one contact, with lambda = -kappa b'(d^2) 2d > 0, weights that are signed
// convex combinations on each primitive (so they sum to zero) and whose sum_k w_k x_k is the vector
// between the closest points (its length is the pair's distance), and an orthonormal basis orthogonal
// to that vector, i.e. to the direction of the pair's barrier force.
TEST(BarrierPotentialFriction, ContactsHaveOrthonormalBasesOrthogonalToTheNormalAndWeightsSummingToZero) {
  TwoSquares s;
  const ContactSettings cs = two_squares_settings();
  BarrierPotential barrier(s.prims, s.rest, cs);
  barrier.set_friction(pair_mu(0.4));
  std::vector<FrictionContact> contacts;
  barrier.friction_contacts(s.x, contacts);
  const ContactStats stats = barrier.stats(s.x);
  ASSERT_GT(stats.active_point_triangle, 0);
  ASSERT_GT(stats.active_edge_edge, 0);
  ASSERT_EQ(static_cast<int>(contacts.size()), stats.active_point_triangle + stats.active_edge_edge);
  int point_triangle = 0, interior_point_triangle = 0, edge_edge = 0, interior_edge_edge = 0;
  for (const FrictionContact& c : contacts) {
    ASSERT_EQ(c.count, 4);
    EXPECT_EQ(c.mu, 0.4);
    Vec<12> x12;
    for (int k = 0; k < 4; ++k) x12.segment<3>(3 * k) = s.x.segment<3>(3 * c.vertices[k]);
    // Point-triangle stencils have the point in one object and the face in the other; edge-edge
    // stencils have both vertices of edge a in one object.
    const bool is_pt = s.prims.vertex_object[c.vertices[0]] != s.prims.vertex_object[c.vertices[1]];
    const double d2 = is_pt ? point_triangle_squared_distance(x12) : edge_edge_squared_distance(x12);
    if (is_pt) {
      ++point_triangle;
      interior_point_triangle += point_triangle_type(x12) == PointTriangleType::P_T;
      EXPECT_EQ(c.weights[0], 1.0);
      EXPECT_NEAR(c.weights[1] + c.weights[2] + c.weights[3], -1.0, 1e-14);
      for (int k = 1; k < 4; ++k) EXPECT_LE(c.weights[k], 1e-14);
    } else {
      ++edge_edge;
      interior_edge_edge += edge_edge_type(x12) == EdgeEdgeType::EA_EB;
      EXPECT_NEAR(c.weights[0] + c.weights[1], 1.0, 1e-14);
      EXPECT_NEAR(c.weights[2] + c.weights[3], -1.0, 1e-14);
      EXPECT_GE(std::min(c.weights[0], c.weights[1]), -1e-14);
      EXPECT_LE(std::max(c.weights[2], c.weights[3]), 1e-14);
    }
    EXPECT_NEAR(c.weights[0] + c.weights[1] + c.weights[2] + c.weights[3], 0.0, 1e-14);
    Vec3 between = Vec3::Zero();
    for (int k = 0; k < 4; ++k) between += c.weights[k] * x12.segment<3>(3 * k);
    EXPECT_NEAR(between.squaredNorm(), d2, 1e-12 * d2);
    EXPECT_LT((c.basis.transpose() * c.basis - Eigen::Matrix2d::Identity()).norm(), 1e-14);
    // The basis is orthogonal to the triangle's normal (point-triangle) or to ea x eb (edge-edge
    // that are not parallel), IPC's friction planes, whatever the closest-point type; for interior
    // types that normal is also the direction between the closest points.
    const Vec3 normal = is_pt ? Vec3((x12.segment<3>(6) - x12.segment<3>(3)).cross(x12.segment<3>(9) - x12.segment<3>(3)))
                              : Vec3((x12.segment<3>(3) - x12.segment<3>(0)).cross(x12.segment<3>(9) - x12.segment<3>(6)));
    EXPECT_LT((c.basis.transpose() * normal).norm(), 1e-12 * normal.norm());
    const bool interior = is_pt ? point_triangle_type(x12) == PointTriangleType::P_T
                                : edge_edge_type(x12) == EdgeEdgeType::EA_EB;
    if (interior) {
      EXPECT_LT((c.basis.transpose() * between).norm(), 1e-9 * between.norm());
    }
    // lambda: the pair's barrier force, mollified for edge-edge pairs like the barrier itself.
    const double mollifier = is_pt ? 1.0 : edge_edge_mollifier(x12, kEdgeEdgeMollifierScale * edge_rest2(s, c));
    const double lambda =
        -cs.kappa * barrier_first_derivative(d2, cs.dhat, cs.offset) * 2.0 * std::sqrt(d2) * mollifier;
    EXPECT_GT(c.normal_force, 0.0);
    EXPECT_NEAR(c.normal_force, lambda, 1e-12 * lambda);
  }
  std::printf("two squares: %d point-triangle contacts (%d interior), %d edge-edge (%d interior)\n", point_triangle,
              interior_point_triangle, edge_edge, interior_edge_edge);
  // Both interior and boundary closest-point types are exercised.
  EXPECT_GT(interior_point_triangle, 0);
  EXPECT_GT(point_triangle - interior_point_triangle, 0);
  EXPECT_GT(interior_edge_edge, 0);
  EXPECT_GT(edge_edge - interior_edge_edge, 0);
}

// A lone vertex (object 1) 3 cm above the incentre of one triangle of a square (object 0): its only
// active pair is that point-triangle pair, so the contact energy is kappa b(d^2) of it, and lambda
// must equal |d energy / d height| by central differences. Weights are the barycentric coordinates
// of the vertex's projection, the basis spans the square's plane.
TEST(BarrierPotentialFriction, NormalForceIsTheBarrierSlopeAlongTheNormalAboveATriangleInterior) {
  const TriMesh square = make_rectangle(1.0, 1.0, 2, 2);
  const int n = square.num_vertices();
  const Vec3 A = square.V.row(square.F(0, 0)), B = square.V.row(square.F(0, 1)), C = square.V.row(square.F(0, 2));
  const double la = (B - C).norm(), lb = (C - A).norm(), lc = (A - B).norm();
  const Vec3 incentre = (la * A + lb * B + lc * C) / (la + lb + lc);
  const double height = 0.03;
  ContactPrimitives prims;
  prims.faces = square.F;
  prims.edges = build_topology(square).edges;
  prims.vertex_object.assign(n + 1, 0);
  prims.vertex_object[n] = 1;
  prims.object_self_contact = {0, 0};
  Positions rest(n + 1, 3);
  rest << square.V, (incentre + height * Vec3::UnitZ()).transpose();
  ContactSettings cs;
  cs.dhat = 0.05;
  cs.offset = 0.005;
  cs.kappa = 100.0;
  BarrierPotential barrier(prims, rest, cs);
  barrier.set_friction(pair_mu(0.3));
  const Eigen::VectorXd x = stacked(rest);
  ASSERT_EQ(barrier.stats(x).active_point_triangle, 1);
  std::vector<FrictionContact> contacts;
  barrier.friction_contacts(x, contacts);
  ASSERT_EQ(contacts.size(), 1u);
  const FrictionContact& c = contacts[0];
  EXPECT_EQ(c.vertices[0], n);
  EXPECT_EQ(c.vertices[1], square.F(0, 0));

  const double step = 1e-6;  // m
  Eigen::VectorXd up = x, down = x;
  up[3 * n + 2] += step;
  down[3 * n + 2] -= step;
  const double slope = (barrier.value(up) - barrier.value(down)) / (2 * step);  // N
  std::printf("lambda %.10g N, |dE/dd| by central differences %.10g N\n", c.normal_force, std::abs(slope));
  EXPECT_LT(slope, 0.0);
  EXPECT_NEAR(c.normal_force, -slope, 1e-7 * c.normal_force);

  // The incentre's barycentric coordinates are proportional to the side lengths.
  const double sum = la + lb + lc;
  EXPECT_DOUBLE_EQ(c.weights[0], 1.0);
  EXPECT_NEAR(c.weights[1], -la / sum, 1e-14);
  EXPECT_NEAR(c.weights[2], -lb / sum, 1e-14);
  EXPECT_NEAR(c.weights[3], -lc / sum, 1e-14);
  EXPECT_LT((c.basis.transpose() * c.basis - Eigen::Matrix2d::Identity()).norm(), 1e-14);
  EXPECT_LT((c.basis.transpose() * Vec3::UnitZ()).norm(), 1e-14);
}

TEST(BarrierPotentialFriction, NoContactsWithoutFrictionOrWithZeroCoefficientBetweenTheObjects) {
  TwoSquares s;
  BarrierPotential barrier(s.prims, s.rest, two_squares_settings());
  ASSERT_GT(barrier.stats(s.x).active_point_triangle, 0);
  std::vector<FrictionContact> contacts;
  barrier.friction_contacts(s.x, contacts);  // set_friction never called
  EXPECT_TRUE(contacts.empty());
  barrier.set_friction(Eigen::MatrixXd::Zero(2, 2));
  barrier.friction_contacts(s.x, contacts);
  EXPECT_TRUE(contacts.empty());
  barrier.set_friction(pair_mu(0.0, 0.7));  // self-friction only; all active pairs are between objects
  barrier.friction_contacts(s.x, contacts);
  EXPECT_TRUE(contacts.empty());
  barrier.set_friction(pair_mu(0.2));
  barrier.friction_contacts(s.x, contacts);
  EXPECT_FALSE(contacts.empty());
  contacts.clear();
  barrier.set_friction(Eigen::MatrixXd());  // back to no friction
  barrier.friction_contacts(s.x, contacts);
  EXPECT_TRUE(contacts.empty());
}

TEST(BarrierPotentialFriction, SetFrictionRejectsMatricesOfTheWrongSizeNegativeNonFiniteOrAsymmetric) {
  TwoSquares s;
  BarrierPotential barrier(s.prims, s.rest, two_squares_settings());
  EXPECT_THROW(barrier.set_friction(Eigen::MatrixXd::Constant(3, 3, 0.1)), std::invalid_argument);
  EXPECT_THROW(barrier.set_friction(Eigen::MatrixXd::Constant(1, 2, 0.1)), std::invalid_argument);
  EXPECT_THROW(barrier.set_friction(Eigen::MatrixXd::Constant(1, 1, 0.1)), std::invalid_argument);
  EXPECT_THROW(barrier.set_friction(pair_mu(-0.1)), std::invalid_argument);
  EXPECT_THROW(barrier.set_friction(pair_mu(NAN)), std::invalid_argument);
  EXPECT_THROW(barrier.set_friction(pair_mu(INFINITY)), std::invalid_argument);
  Eigen::MatrixXd asymmetric = pair_mu(0.3);
  asymmetric(0, 1) = 0.31;
  EXPECT_THROW(barrier.set_friction(asymmetric), std::invalid_argument);
  EXPECT_NO_THROW(barrier.set_friction(pair_mu(0.3, 0.1)));
}

// The term fed by the barrier: derivatives at a displaced state, with real size-4 stencils of
// every closest-point type (some sliding, some sticking).
TEST(FrictionTerm, DerivativesMatchFiniteDifferencesWithContactsFromTheBarrier) {
  TwoSquares s;
  BarrierPotential barrier(s.prims, s.rest, two_squares_settings());
  barrier.set_friction(pair_mu(0.4));
  FrictionTerm term(0.05);  // eps_u = 5 mm at h = 0.1 s
  term.add_source(&barrier);
  StepStart step;
  step.h = 0.1;
  step.x = &s.x;
  term.begin_step(step);
  ASSERT_FALSE(term.contacts().empty());
  const Eigen::VectorXd x = s.x + 0.01 * test::wavy(s.x.size(), 1.1, 0.2);
  int sliding = 0;
  for (const FrictionContact& c : term.contacts()) {
    Vec3 sum = Vec3::Zero();
    for (int k = 0; k < c.count; ++k) sum += c.weights[k] * (x - s.x).segment<3>(3 * c.vertices[k]);
    sliding += (c.basis.transpose() * sum).norm() > term.eps_u();
  }
  std::printf("barrier-fed friction: %zu contacts, %d sliding\n", term.contacts().size(), sliding);
  const test::TermFdCheck check = test::check_term_derivatives(term, x);
  report("barrier-fed", check);
  test::expect_derivatives_match(check, 1e-6, 1e-6);
}

}  // namespace
}  // namespace pd
