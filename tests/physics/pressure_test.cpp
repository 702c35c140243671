// Internal pressure: enclosed volume, constant and isothermal ideal-gas models.
#include "physics/pressure.h"

#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <set>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "physics/inertia.h"
#include "support/finite_difference.h"
#include "support/term_eval.h"

namespace pd {
namespace {

// Regular icosahedron with vertices (0, +-1, +-phi) and cyclic permutations (edge 2), faces found as
// the vertex triples at mutual distance 2 and oriented outward (it is convex around the origin).
TriMesh icosahedron() {
  const double phi = 0.5 * (1.0 + std::sqrt(5.0));
  TriMesh m;
  m.V.resize(12, 3);
  int k = 0;
  for (double a : {-1.0, 1.0})
    for (double b : {-phi, phi}) {
      m.V.row(k++) << 0, a, b;
      m.V.row(k++) << a, b, 0;
      m.V.row(k++) << b, 0, a;
    }
  std::vector<std::array<int, 3>> faces;
  auto edge = [&](int i, int j) { return std::abs((m.V.row(i) - m.V.row(j)).norm() - 2.0) < 1e-9; };
  for (int i = 0; i < 12; ++i)
    for (int j = i + 1; j < 12; ++j)
      for (int l = j + 1; l < 12; ++l)
        if (edge(i, j) && edge(j, l) && edge(i, l)) {
          const Vec3 a = m.V.row(i), b = m.V.row(j), c = m.V.row(l);
          if ((b - a).cross(c - a).dot(a + b + c) > 0) faces.push_back({i, j, l});
          else faces.push_back({i, l, j});
        }
  m.F.resize(static_cast<int>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f) m.F.row(f) << faces[f][0], faces[f][1], faces[f][2];
  return m;
}

// One 4-to-1 subdivision with the new vertices pushed to the sphere of radius r (42 vertices).
TriMesh icosphere(double r) {
  const TriMesh ico = icosahedron();
  std::vector<Vec3> V;
  for (int i = 0; i < 12; ++i) V.push_back(ico.V.row(i).normalized() * r);
  std::map<std::pair<int, int>, int> mid;
  auto midpoint = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    V.push_back((V[a] + V[b]).normalized() * r);
    return mid[key] = static_cast<int>(V.size()) - 1;
  };
  TriMesh m;
  m.F.resize(80, 3);
  for (int f = 0; f < 20; ++f) {
    const int a = ico.F(f, 0), b = ico.F(f, 1), c = ico.F(f, 2);
    const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    m.F.row(4 * f) << a, ab, ca;
    m.F.row(4 * f + 1) << ab, b, bc;
    m.F.row(4 * f + 2) << ca, bc, c;
    m.F.row(4 * f + 3) << ab, bc, ca;
  }
  m.V.resize(static_cast<int>(V.size()), 3);
  for (size_t i = 0; i < V.size(); ++i) m.V.row(i) = V[i].transpose();
  return m;
}

// Axis-aligned cube of side s centred at c, two outward triangles per side, listed by hand.
TriMesh cube(double s, const Vec3& c) {
  TriMesh m;
  m.V.resize(8, 3);
  for (int i = 0; i < 8; ++i)  // vertex i = (bit0, bit1, bit2) along (x, y, z)
    m.V.row(i) = (c + s * Vec3((i & 1) - 0.5, ((i >> 1) & 1) - 0.5, ((i >> 2) & 1) - 0.5)).transpose();
  m.F.resize(12, 3);
  m.F << 0, 2, 3, 0, 3, 1,  // z = -s/2
      4, 5, 7, 4, 7, 6,     // z = +s/2
      0, 1, 5, 0, 5, 4,     // y = -s/2
      2, 6, 7, 2, 7, 3,     // y = +s/2
      0, 4, 6, 0, 6, 2,     // x = -s/2
      1, 3, 7, 1, 7, 5;     // x = +s/2
  return m;
}

TEST(EnclosedVolume, CubeAndIcosahedronMatchAnalyticVolumes) {
  const TriMesh c = cube(0.7, Vec3(3.0, -1.0, 2.0));  // off the origin: closed meshes don't care
  for (int f = 0; f < 12; ++f) {  // the hand-written faces are outward
    const Vec3 a = c.V.row(c.F(f, 0)), b = c.V.row(c.F(f, 1)), d = c.V.row(c.F(f, 2));
    ASSERT_GT((b - a).cross(d - a).dot((a + b + d) / 3.0 - Vec3(3.0, -1.0, 2.0)), 0.0) << f;
  }
  EXPECT_NEAR(enclosed_volume(c.F, stacked(c.V)), 0.7 * 0.7 * 0.7, 1e-14);
  const TriMesh ico = icosahedron();
  ASSERT_EQ(ico.F.rows(), 20);
  EXPECT_NEAR(enclosed_volume(ico.F, stacked(ico.V)), 5.0 / 12.0 * (3.0 + std::sqrt(5.0)) * 8.0, 1e-12);
}

struct PressureFixture : ::testing::Test {
  TriMesh mesh = icosahedron();
  Eigen::VectorXd x0 = 0.1 * stacked(mesh.V);                  // the term's initial shape
  Eigen::VectorXd x = x0 + 0.01 * test::wavy(36, 1.7, 0.3);           // a deformed configuration
  Pressure constant{Pressure::Model::Constant, 1500.0};
  Pressure gas{Pressure::Model::IdealGas, 1500.0};
};

TEST_F(PressureFixture, InvariantUnderRigidMotion) {
  const Mat3 R = Eigen::AngleAxisd(0.8, Vec3(1, -2, 0.5).normalized()).toRotationMatrix();
  const Vec3 t(0.3, -0.7, 1.1);
  Eigen::VectorXd y(36);
  for (int i = 0; i < 12; ++i) y.segment<3>(3 * i) = R * x.segment<3>(3 * i) + t;
  for (const Pressure& p : {constant, gas}) {
    const PressureTerm term(mesh.F, x0, p);
    EXPECT_NEAR(term.volume(y), term.volume(x), 1e-15);
    EXPECT_NEAR(term.value(y), term.value(x), 1e-12 * std::abs(term.value(x)));
    const Eigen::VectorXd gx = test::term_gradient(term, x), gy = test::term_gradient(term, y);
    Vec3 net_force = Vec3::Zero(), net_torque = Vec3::Zero();
    for (int i = 0; i < 12; ++i) {
      EXPECT_LT((gy.segment<3>(3 * i) - R * gx.segment<3>(3 * i)).norm(), 1e-12 * gx.norm());
      net_force += gx.segment<3>(3 * i);
      net_torque += x.segment<3>(3 * i).cross(gx.segment<3>(3 * i));
    }
    EXPECT_LT(net_force.norm(), 1e-12 * gx.norm());  // pressure cannot push a shell around
    EXPECT_LT(net_torque.norm(), 1e-12 * gx.norm());
  }
}

// Scaling x by s scales V by s^3, so grad V . x = 3 V and grad U . x = 3 V U'(V).
TEST_F(PressureFixture, PressureLawsAndScalingIdentity) {
  const PressureTerm c(mesh.F, x0, constant), g(mesh.F, x0, gas);
  const double V0 = enclosed_volume(mesh.F, x0), V = c.volume(x);
  EXPECT_NEAR(g.initial_volume(), V0, 1e-18);
  EXPECT_EQ(g.pressure_at(V0), 1500.0);
  EXPECT_NEAR(g.pressure_at(2.0 * V0), 750.0, 1e-12);
  EXPECT_EQ(c.pressure_at(2.0 * V0), 1500.0);
  EXPECT_NEAR(c.value(x), -1500.0 * V, 1e-12);
  EXPECT_NEAR(g.value(x), -1500.0 * V0 * std::log(V), 1e-12);
  EXPECT_NEAR(test::term_gradient(c, x).dot(x), -3.0 * 1500.0 * V, 1e-10);
  EXPECT_NEAR(test::term_gradient(g, x).dot(x), -3.0 * 1500.0 * V0, 1e-10);
}

TEST_F(PressureFixture, ConstantModelGradientAndHessianMatchFiniteDifferences) {
  const PressureTerm term(mesh.F, x0, constant);
  const test::TermFdCheck fd = test::check_term_derivatives(term, x);
  test::expect_derivatives_match(fd, 1e-7, 1e-7);
  const Eigen::MatrixXd& H = fd.H;
  const test::FdResult& rg = fd.gradient;
  const test::FdResult& rh = fd.hessian;
  EXPECT_LT((H - term.dense_hessian_for_tests(x)).norm(), 1e-12 * H.norm());
  std::printf("pressure (constant): gradient FD rel err %.2e, Hessian FD rel err %.2e\n",
              rg.best_rel_error, rh.best_rel_error);
}

TEST_F(PressureFixture, IdealGasExactHessianMatchesFiniteDifferences) {
  const PressureTerm term(mesh.F, x0, gas);
  auto f = [&](const Eigen::VectorXd& y) { return term.value(y); };
  auto g = [&](const Eigen::VectorXd& y) { return test::term_gradient(term, y); };
  const test::FdResult rg = test::check_gradient(f, x, g(x));
  EXPECT_GT(rg.comparisons, 0);
  EXPECT_GE(rg.steps_within(1e-7), 2) << "best " << rg.best_rel_error;
  const Eigen::MatrixXd H = term.dense_hessian_for_tests(x);
  const test::FdResult rh = test::check_hessian(g, x, H);
  EXPECT_GT(rh.comparisons, 0);
  EXPECT_GE(rh.steps_within(1e-7), 2) << "best " << rh.best_rel_error;
  // The assembled Hessian is the exact one minus the PSD rank-one term p V0 / V^2 gV gV^T.
  const double V = term.volume(x);
  const Eigen::VectorXd gV = g(x) / (-1500.0 * enclosed_volume(mesh.F, x0) / V);
  const Eigen::MatrixXd rank_one = 1500.0 * term.initial_volume() / (V * V) * gV * gV.transpose();
  EXPECT_LT((test::term_hessian(term, x, HessianProjection::None) - (H - rank_one)).norm(), 1e-12 * H.norm());
  std::printf("pressure (ideal gas): gradient FD rel err %.2e, exact Hessian FD rel err %.2e\n",
              rg.best_rel_error, rh.best_rel_error);
}

TEST_F(PressureFixture, ExactHessianIsIndefiniteProjectedIsPsd) {
  const PressureTerm term(mesh.F, x0, constant);
  const Eigen::VectorXd lo_none =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(test::term_hessian(term, x, HessianProjection::None)).eigenvalues();
  const Eigen::VectorXd lo_clamp =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(test::term_hessian(term, x, HessianProjection::Clamp)).eigenvalues();
  EXPECT_LT(lo_none.minCoeff(), -1e-3 * lo_none.maxCoeff());
  EXPECT_GT(lo_clamp.minCoeff(), -1e-10 * lo_clamp.maxCoeff());
}

TEST_F(PressureFixture, MaxStepKeepsIdealGasVolumePositive) {
  const PressureTerm g(mesh.F, x0, gas), c(mesh.F, x0, constant);
  // Shrinking towards the centre: V(alpha) = (1 - alpha)^3 V, so V = V / 10 at 1 - 10^(-1/3).
  EXPECT_NEAR(g.max_step(x0, -x0), 1.0 - std::cbrt(PressureTerm::kMinVolumeRatio), 1e-12);
  EXPECT_NEAR(g.max_step(x0, -3.0 * x0), (1.0 - std::cbrt(PressureTerm::kMinVolumeRatio)) / 3.0, 1e-12);
  EXPECT_EQ(g.max_step(x0, x0), 1.0);
  EXPECT_EQ(c.max_step(x0, -3.0 * x0), 1.0);
  // Through the inside and out again (turns the shell inside out): stops before the first crossing.
  const double a = g.max_step(x0, -2.5 * x0);
  EXPECT_NEAR(a, (1.0 - std::cbrt(PressureTerm::kMinVolumeRatio)) / 2.5, 1e-12);
  EXPECT_GT(g.volume(x0 - a * 2.5 * x0), 0.0);
}

TEST(PressureTerm, RejectsInwardOrientedShell) {
  TriMesh m = icosahedron();
  m.F.col(1).swap(m.F.col(2));
  EXPECT_THROW(PressureTerm(m.F, stacked(m.V), Pressure{}), std::invalid_argument);
}

// Edge springs k/2 (|xi - xj| - L)^2 standing in for the membrane, for the balloon solve below.
struct Springs {
  std::vector<std::array<int, 2>> edges;
  std::vector<double> rest;
  double k;
  Springs(const Faces& F, const Eigen::VectorXd& x, double k_) : k(k_) {
    std::set<std::pair<int, int>> seen;
    for (int f = 0; f < F.rows(); ++f)
      for (int a = 0; a < 3; ++a) seen.insert(std::minmax(F(f, a), F(f, (a + 1) % 3)));
    for (auto [i, j] : seen) {
      edges.push_back({i, j});
      rest.push_back((x.segment<3>(3 * i) - x.segment<3>(3 * j)).norm());
    }
  }
  double value(const Eigen::VectorXd& x) const {
    double E = 0;
    for (size_t e = 0; e < edges.size(); ++e) {
      const double l = (x.segment<3>(3 * edges[e][0]) - x.segment<3>(3 * edges[e][1])).norm();
      E += 0.5 * k * (l - rest[e]) * (l - rest[e]);
    }
    return E;
  }
  void add(const Eigen::VectorXd& x, bool project, Eigen::VectorXd& g, Eigen::MatrixXd& H) const {
    for (size_t e = 0; e < edges.size(); ++e) {
      const int i = edges[e][0], j = edges[e][1];
      const Vec3 d = x.segment<3>(3 * i) - x.segment<3>(3 * j);
      const double l = d.norm();
      const Vec3 u = d / l;
      g.segment<3>(3 * i) += k * (l - rest[e]) * u;
      g.segment<3>(3 * j) -= k * (l - rest[e]) * u;
      double t = 1.0 - rest[e] / l;  // transverse stiffness factor, negative when compressed
      if (project) t = std::max(t, 0.0);
      const Mat3 K = k * (t * (Mat3::Identity() - u * u.transpose()) + u * u.transpose());
      H.block<3, 3>(3 * i, 3 * i) += K;
      H.block<3, 3>(3 * j, 3 * j) += K;
      H.block<3, 3>(3 * i, 3 * j) -= K;
      H.block<3, 3>(3 * j, 3 * i) -= K;
    }
  }
};

// One implicit-Euler step of an inflating balloon (42-vertex icosphere, ideal gas at 3 kPa, edge
// springs), solved by Newton with a dense LDLT and Armijo backtracking capped by max_step. Measures
// the iterations with the Hessian the solver assembles (per-triangle clamped, rank-one term omitted)
// against the exact Hessian: the projection discards coupling, but Newton must still converge.
TEST(PressureTerm, BalloonNewtonConverges) {
  const TriMesh m = icosphere(0.1);
  const Eigen::VectorXd x0 = stacked(m.V), v0 = Eigen::VectorXd::Zero(x0.size());
  const double h = 1.0 / 30.0;
  const int n = static_cast<int>(x0.size());
  InertiaTerm inertia(lumped_masses(m.F, m.V, 0.1));
  inertia.begin_step(StepStart{h, h, &x0, &v0});
  const PressureTerm gas(m.F, x0, Pressure{Pressure::Model::IdealGas, 3000.0});
  const Springs springs(m.F, x0, 300.0);

  auto energy = [&](const Eigen::VectorXd& y) { return inertia.value(y) + gas.value(y) + springs.value(y); };
  // Hessians: the solver's (per-triangle clamp, rank-one omitted), the same plus the rank-one term
  // (to tell which simplification costs iterations), and the exact one.
  enum class Mode { Projected, ProjectedPlusRankOne, Exact };
  auto solve = [&](Mode mode, double* final_volume) {
    Eigen::VectorXd x = x0;
    double g0 = -1;
    for (int it = 0; it < 200; ++it) {
      Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
      inertia.add_gradient(x, g);
      gas.add_gradient(x, g);
      Eigen::MatrixXd H = test::term_hessian(inertia, x, HessianProjection::None);
      if (mode == Mode::Exact) {
        H += gas.dense_hessian_for_tests(x);
      } else {
        H += test::term_hessian(gas, x, HessianProjection::Clamp);
        if (mode == Mode::ProjectedPlusRankOne)
          H += gas.dense_hessian_for_tests(x) - test::term_hessian(gas, x, HessianProjection::None);
      }
      springs.add(x, mode != Mode::Exact, g, H);
      if (g0 < 0) g0 = g.norm();
      // 1e-7: tight enough to show the convergence rate, above where the energy-based line search
      // loses its last digits (|E| ~ 50 J: energy decreases below ~1e-14 J are round-off).
      if (g.norm() < 1e-7 * g0) { *final_volume = gas.volume(x); return it; }
      Eigen::VectorXd p = -H.ldlt().solve(g);
      if (g.dot(p) >= 0) p = -g;  // not a descent direction (exact Hessian may be indefinite)
      double alpha = std::min(1.0, gas.max_step(x, p));
      const double E = energy(x);
      while (energy(x + alpha * p) > E + 1e-4 * alpha * g.dot(p) && alpha > 1e-12) alpha *= 0.5;
      x += alpha * p;
    }
    return -1;
  };
  double V_projected = 0, V_rank_one = 0, V_exact = 0;
  const int it_projected = solve(Mode::Projected, &V_projected);
  const int it_rank_one = solve(Mode::ProjectedPlusRankOne, &V_rank_one);
  const int it_exact = solve(Mode::Exact, &V_exact);
  const double V0 = gas.initial_volume();
  std::printf("balloon: Newton iterations: solver Hessian %d, + rank-one term %d, exact %d; V/V0 = %.4f\n",
              it_projected, it_rank_one, it_exact, V_projected / V0);
  ASSERT_GT(it_projected, 0);
  EXPECT_LE(it_projected, 20);
  EXPECT_GT(V_projected, 1.05 * V0);  // it really inflated
  ASSERT_GT(it_exact, 0);
  EXPECT_NEAR(V_projected, V_exact, 1e-7 * V0);  // same minimiser either way
}

}  // namespace
}  // namespace pd
