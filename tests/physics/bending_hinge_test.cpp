// Tests of the discrete-hinge bending energy (physics/bending_hinge.h).
// GCC 12 -O2 false positive inside Eigen's self-adjoint eigensolver; silenced for Eigen's lines only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#pragma GCC diagnostic pop

#include "physics/bending_hinge.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "support/finite_difference.h"
#include "geometry/shapes.h"
#include "support/term_eval.h"

namespace pd {
namespace {

constexpr double kPi = 3.14159265358979323846;

Mat3 random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return q.normalized().toRotationMatrix();
}

// A hinge whose dihedral angle is exactly `theta`: edge along x, wing 1 in the z = 0 plane on the +y
// side (normal +z), wing 2 turned by theta about the edge; random shape, then a random rigid motion.
Vec<12> make_hinge(std::mt19937& rng, double theta) {
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const double L = 0.6 + 0.8 * U(rng);
  const double s1 = (-0.3 + 1.6 * U(rng)) * L, h1 = 0.4 + 0.8 * U(rng);
  const double s2 = (-0.3 + 1.6 * U(rng)) * L, h2 = 0.4 + 0.8 * U(rng);
  const Vec3 p[4] = {Vec3(0, 0, 0), Vec3(L, 0, 0), Vec3(s1, h1, 0),
                     Vec3(s2, -h2 * std::cos(theta), -h2 * std::sin(theta))};
  const Mat3 Q = random_rotation(rng);
  const Vec3 t(2 * U(rng) - 1, 2 * U(rng) - 1, 2 * U(rng) - 1);
  Vec<12> x;
  for (int i = 0; i < 4; ++i) x.segment<3>(3 * i) = Q * p[i] + t;
  return x;
}

// Near-flat, moderate and strongly folded hinges of both signs.
const std::vector<double> kTestAngles = {0.0, 1e-3, -2e-3, 0.4, -1.1, 2.0, 2.5, -2.5};

// One hinge per interior edge, built by hand from consistently oriented faces (see pd::Hinge).
std::vector<Hinge> hinges_of(const Faces& F) {
  std::map<std::pair<int, int>, int> opposite;  // directed edge (a, b) -> opposite vertex
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) opposite[{F(f, k), F(f, (k + 1) % 3)}] = F(f, (k + 2) % 3);
  std::vector<Hinge> hinges;
  for (const auto& [edge, c] : opposite) {
    if (edge.first > edge.second) continue;
    const auto other = opposite.find({edge.second, edge.first});
    if (other != opposite.end()) hinges.push_back(Hinge{{edge.first, edge.second, c, other->second}});
  }
  return hinges;
}

Eigen::VectorXd dyn(const Vec<12>& v) { return v; }
Vec<12> fix(const Eigen::VectorXd& v) { return v; }

TEST(DihedralAngle, EqualsConstructedFoldAngleAfterRigidMotion) {
  std::mt19937 rng(1);
  for (double theta : kTestAngles) EXPECT_NEAR(dihedral_angle(make_hinge(rng, theta)), theta, 1e-12);
}

TEST(DihedralAngle, SignPositiveWhenFoldingAwayFromNormalAndIndependentOfSide) {
  // Wing 1 has normal +z. Wing 2 bent down (-z, away from the normal) folds convexly: theta > 0.
  Vec<12> down, up;
  down << 0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, -0.8, -0.6;
  up << 0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, -0.8, 0.6;
  EXPECT_NEAR(dihedral_angle(down), std::atan2(0.6, 0.8), 1e-14);
  EXPECT_NEAR(dihedral_angle(up), -std::atan2(0.6, 0.8), 1e-14);
  // The same hinge seen from the other triangle (v1, v0, v3, v2) has the same angle.
  Vec<12> swapped;
  swapped << down.segment<3>(3), down.segment<3>(0), down.segment<3>(9), down.segment<3>(6);
  EXPECT_NEAR(dihedral_angle(swapped), dihedral_angle(down), 1e-14);
}

TEST(DihedralAngle, GradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(2);
  for (double theta : kTestAngles) {
    const Vec<12> x = make_hinge(rng, theta);
    const auto rg = test::check_gradient([](const Eigen::VectorXd& y) { return dihedral_angle(fix(y)); },
                                         dyn(x), dyn(dihedral_angle_gradient(x)));
    const auto rh = test::check_hessian(
        [](const Eigen::VectorXd& y) { return dyn(dihedral_angle_gradient(fix(y))); }, dyn(x),
        Eigen::MatrixXd(dihedral_angle_hessian(x)));
    EXPECT_GT(rg.comparisons, 0);
    EXPECT_GT(rh.comparisons, 0);
    EXPECT_GE(rg.steps_within(1e-6), 2) << "theta " << theta << " best " << rg.best_rel_error;
    EXPECT_GE(rh.steps_within(1e-5), 2) << "theta " << theta << " best " << rh.best_rel_error;
  }
}

TEST(HingeRest, WeightIsSquaredEdgeOverAreaSumAndAngleIsRestAngle) {
  Vec<12> X;  // edge length 2, areas 1 and 2, flat
  X << 0, 0, 0, 2, 0, 0, 1, 1, 0, 0.5, -2, 0;
  const HingeRest r = hinge_rest(X);
  EXPECT_NEAR(r.weight, 4.0 / 3.0, 1e-14);
  EXPECT_NEAR(r.theta_bar, 0.0, 1e-14);
  std::mt19937 rng(4);
  EXPECT_NEAR(hinge_rest(make_hinge(rng, 0.7)).theta_bar, 0.7, 1e-12);
}

TEST(HingeBending, EnergyGradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const double k = 0.37;
  for (double theta : kTestAngles) {
    const Vec<12> x = make_hinge(rng, theta);
    const HingeRest rest{theta + 0.5 * U(rng), 0.5 + std::abs(U(rng))};
    const auto rg = test::check_gradient(
        [&](const Eigen::VectorXd& y) { return hinge_bending_energy(fix(y), rest, k); }, dyn(x),
        dyn(hinge_bending_gradient(x, rest, k)));
    const auto rh = test::check_hessian(
        [&](const Eigen::VectorXd& y) { return dyn(hinge_bending_gradient(fix(y), rest, k)); }, dyn(x),
        Eigen::MatrixXd(hinge_bending_hessian(x, rest, k)));
    EXPECT_GT(rg.comparisons, 0);
    EXPECT_GT(rh.comparisons, 0);
    EXPECT_GE(rg.steps_within(1e-6), 2) << "theta " << theta << " best " << rg.best_rel_error;
    EXPECT_GE(rh.steps_within(1e-5), 2) << "theta " << theta << " best " << rh.best_rel_error;
  }
}

TEST(HingeBending, RigidMotionLeavesEnergyInvariantAndRotatesDerivatives) {
  std::mt19937 rng(6);
  for (double theta : {0.3, -2.5}) {
    const Vec<12> x = make_hinge(rng, theta);
    const HingeRest rest{0.1, 1.3};
    const Mat3 Q = random_rotation(rng);
    const Vec3 t(0.3, -1.2, 2.0);
    Vec<12> y;
    Mat<12> B = Mat<12>::Zero();
    for (int i = 0; i < 4; ++i) {
      y.segment<3>(3 * i) = Q * x.segment<3>(3 * i) + t;
      B.block<3, 3>(3 * i, 3 * i) = Q;
    }
    const Vec<12> g = hinge_bending_gradient(x, rest, 1.0);
    const Mat<12> H = hinge_bending_hessian(x, rest, 1.0);
    EXPECT_NEAR(hinge_bending_energy(y, rest, 1.0), hinge_bending_energy(x, rest, 1.0), 1e-12);
    EXPECT_LT((hinge_bending_gradient(y, rest, 1.0) - B * g).norm(), 1e-10 * g.norm());
    EXPECT_LT((hinge_bending_hessian(y, rest, 1.0) - B * H * B.transpose()).norm(), 1e-10 * H.norm());
    // Invariance also means zero net force and zero net torque.
    Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
    for (int i = 0; i < 4; ++i) {
      force += g.segment<3>(3 * i);
      torque += x.segment<3>(3 * i).cross(g.segment<3>(3 * i));
    }
    EXPECT_LT(force.norm(), 1e-12 * g.norm());
    EXPECT_LT(torque.norm(), 1e-12 * g.norm() * x.norm());
  }
}

TEST(HingeBending, ProjectedHessianIsPositiveSemiDefinite) {
  std::mt19937 rng(7);
  bool saw_indefinite = false;
  for (double theta : kTestAngles) {
    const Vec<12> x = make_hinge(rng, theta);
    const HingeRest rest{theta - 0.8, 1.0};
    const Mat<12> H = hinge_bending_hessian(x, rest, 1.0);
    saw_indefinite |= Eigen::SelfAdjointEigenSolver<Mat<12>>(H).eigenvalues().minCoeff() < -1e-6 * H.norm();
    for (HessianProjection p : {HessianProjection::Clamp, HessianProjection::Abs}) {
      const Mat<12> Hp = project_hessian<12>(H, p);
      EXPECT_GE(Eigen::SelfAdjointEigenSolver<Mat<12>>(Hp).eigenvalues().minCoeff(), -1e-10 * H.norm());
    }
  }
  EXPECT_TRUE(saw_indefinite) << "the exact Hessians were all PSD; the projection went untested";
}

TEST(HingeBending, DegenerateTriangleGivesFiniteEnergyAndZeroDerivatives) {
  Vec<12> collinear, zero_edge;
  collinear << 0, 0, 0, 1, 0, 0, 2, 0, 0, 0.5, -1, 0.2;  // x2 on the edge line: wing 1 has no area
  zero_edge << 0, 0, 0, 0, 0, 0, 0.5, 1, 0, 0.5, -1, 0;   // x1 == x0
  const HingeRest rest{0.4, 1.5};
  for (const Vec<12>& x : {collinear, zero_edge}) {
    EXPECT_EQ(dihedral_angle(x), 0.0);
    EXPECT_NEAR(hinge_bending_energy(x, rest, 2.0), 2.0 * 1.5 * 0.4 * 0.4, 1e-14);
    EXPECT_EQ(hinge_bending_gradient(x, rest, 2.0).norm(), 0.0);
    EXPECT_EQ(hinge_bending_hessian(x, rest, 2.0).norm(), 0.0);
    EXPECT_EQ(dihedral_angle_hessian(x).norm(), 0.0);
  }
}

// Regular grid of (nu + 1) x (nv + 1) vertices with quads split along one diagonal.
TriMesh grid(int nu, int nv, double du, double dv) {
  TriMesh m;
  m.V.resize((nu + 1) * (nv + 1), 3);
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) m.V.row(j * (nu + 1) + i) << i * du, j * dv, 0.0;
  m.F.resize(2 * nu * nv, 3);
  int f = 0;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const int a = j * (nu + 1) + i, b = a + 1, c = a + nu + 1, d = c + 1;
      m.F.row(f++) << a, b, d;  // split along the (1, 1) diagonal
      m.F.row(f++) << a, d, c;
    }
  return m;
}

// The hinge's four vertices (x_v0, x_v1, x_v2, x_v3) of the stacked positions x.
Vec<12> hinge_positions(const Hinge& h, const Eigen::VectorXd& x) {
  Vec<12> xe;
  for (int a = 0; a < 4; ++a) xe.segment<3>(3 * a) = x.segment<3>(3 * h.v[a]);
  return xe;
}

TEST(DihedralAngle, OctahedronWithOutwardNormalsHasConvexAnglesEverywhere) {
  // Every edge of the regular octahedron turns the normal by pi - acos(-1/3) = acos(1/3), convexly.
  Positions V(6, 3);
  V << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
  Faces F(8, 3);
  F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  const std::vector<Hinge> hinges = hinges_of(F);
  ASSERT_EQ(hinges.size(), 12u);
  for (const Hinge& h : hinges) {
    Vec<12> x;
    for (int a = 0; a < 4; ++a) x.segment<3>(3 * a) = V.row(h.v[a]).transpose();
    EXPECT_NEAR(dihedral_angle(x), std::acos(1.0 / 3.0), 1e-14);
  }
}

TEST(HingeBending, ZeroEnergyAndGradientAtCurvedRestShape) {
  // A grid pushed onto a sphere of radius 1 around the +z pole. Convex on the whole, although a quad
  // split along its "wrong" diagonal makes a slightly reflex edge (theta_bar < 0) here and there.
  TriMesh m = grid(5, 5, 0.2, 0.2);
  for (int i = 0; i < m.num_vertices(); ++i) {
    const Vec3 p(m.V(i, 0) - 0.5, m.V(i, 1) - 0.5, 1.0);
    m.V.row(i) = p.normalized().transpose();
  }
  const std::vector<Hinge> hinges = hinges_of(m.F);
  const HingeBending term(hinges, m.V, 0.02);
  ASSERT_EQ(hinges.size(), 5u * 4u * 2u + 25u);  // interior grid lines + diagonals
  double sum = 0.0;
  for (const HingeRest& r : term.rest()) sum += r.theta_bar;
  EXPECT_GT(sum / hinges.size(), 0.03);  // curved: about the 0.1 rad the grid spacing suggests
  const Eigen::VectorXd x = stacked(m.V);
  EXPECT_EQ(term.value(x), 0.0);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(x.size());
  term.add_gradient(x, g);
  EXPECT_EQ(g.norm(), 0.0);
  // Flattening it back costs energy.
  Eigen::VectorXd flat = x;
  for (int i = 0; i < m.num_vertices(); ++i) flat[3 * i + 2] = 1.0;
  EXPECT_GT(term.value(flat), 0.0);
}

// value() keeps each hinge's angle for the gradient, and their sum for a value, at the same x.
TEST(HingeBending, ValueAndGradientAfterValueEqualThoseOfATermThatNeverEvaluatedAValue) {
  TriMesh m = grid(3, 3, 0.5, 0.5);
  for (int i = 0; i < m.num_vertices(); ++i) m.V(i, 2) = 0.3 * m.V(i, 0) * m.V(i, 0) - 0.2 * m.V(i, 1);
  const std::vector<Hinge> hinges = hinges_of(m.F);
  const HingeBending term(hinges, m.V, 0.05), twin(hinges, m.V, 0.05);
  Eigen::VectorXd x = stacked(m.V), y = x;
  for (Eigen::Index i = 2; i < x.size(); i += 3) {
    x[i] += 0.1 * std::sin(5.0 * x[i - 2]);
    y[i] -= 0.2 * std::cos(3.0 * y[i - 1]);
  }
  test::expect_reuse_after_value_is_fresh(term, twin, x, y);
}

TEST(HingeBending, TermAssemblyMatchesElementSumsAndFiniteDifferences) {
  TriMesh m = grid(2, 2, 0.5, 0.5);  // 2 x 2 quads, 8 triangles, 8 interior edges
  for (int i = 0; i < m.num_vertices(); ++i) m.V(i, 2) = 0.3 * m.V(i, 0) * m.V(i, 0) - 0.2 * m.V(i, 1);
  const std::vector<Hinge> hinges = hinges_of(m.F);
  ASSERT_EQ(hinges.size(), 8u);
  const double D = 0.05;
  const HingeBending term(hinges, m.V, D);
  EXPECT_EQ(term.name(), "bending");
  EXPECT_EQ(term.stiffness(), hinge_stiffness(D));

  std::mt19937 rng(8);
  std::uniform_real_distribution<double> U(-0.1, 0.1);
  Eigen::VectorXd x = stacked(m.V);
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] += U(rng);
  const int n = static_cast<int>(x.size());

  double e_sum = 0.0;
  Eigen::VectorXd g_sum = Eigen::VectorXd::Zero(n);
  Eigen::MatrixXd H_sum = Eigen::MatrixXd::Zero(n, n);
  for (const Hinge& h : hinges) {
    const Vec<12> X = hinge_positions(h, stacked(m.V)), xe = hinge_positions(h, x);
    const HingeRest r = hinge_rest(X);
    const double k = hinge_stiffness(D);
    e_sum += hinge_bending_energy(xe, r, k);
    const Vec<12> ge = hinge_bending_gradient(xe, r, k);
    const Mat<12> He = hinge_bending_hessian(xe, r, k);
    for (int a = 0; a < 4; ++a) {
      g_sum.segment<3>(3 * h.v[a]) += ge.segment<3>(3 * a);
      for (int b = 0; b < 4; ++b) H_sum.block<3, 3>(3 * h.v[a], 3 * h.v[b]) += He.block<3, 3>(3 * a, 3 * b);
    }
  }
  auto gradient = [&](const Eigen::VectorXd& y) {
    Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
    term.add_gradient(y, g);
    return g;
  };
  auto assembled = [&](HessianProjection p) {
    HessianAssembly assembly;
    assembly.begin(n);
    term.add_hessian(x, p, assembly);
    const Eigen::MatrixXd lower(assembly.finish(nullptr));
    return Eigen::MatrixXd(lower + lower.transpose() - Eigen::MatrixXd(lower.diagonal().asDiagonal()));
  };
  const Eigen::MatrixXd H = assembled(HessianProjection::None);

  EXPECT_NEAR(term.value(x), e_sum, 1e-14);
  EXPECT_LT((gradient(x) - g_sum).norm(), 1e-13 * g_sum.norm());
  EXPECT_LT((H - H_sum).norm(), 1e-12 * H_sum.norm());
  const auto rg = test::check_gradient([&](const Eigen::VectorXd& y) { return term.value(y); }, x,
                                       gradient(x));
  const auto rh = test::check_hessian(gradient, x, H);
  EXPECT_GT(rg.comparisons, 0);
  EXPECT_GT(rh.comparisons, 0);
  EXPECT_GE(rg.steps_within(1e-6), 2) << rg.best_rel_error;
  EXPECT_GE(rh.steps_within(1e-5), 2) << rh.best_rel_error;
  const Eigen::MatrixXd Hc = assembled(HessianProjection::Clamp);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Hc).eigenvalues().minCoeff(), -1e-12 * Hc.norm());
}

// A flat periodic lattice sheet to be wrapped into a closed tube of radius R (no seam, so no folding
// edge is lost except at the two open ends). uv: flat coordinates, m; u runs around the tube.
struct Sheet {
  std::vector<Eigen::Vector2d> uv;
  Faces F;
  double period;  // flat length around the tube = 2 pi R
};

// Vertices at B (x, y) for integers x, y; each lattice cell (x, y)..(x+1, y+1) split into two
// triangles along (x+1, y)-(x, y+1) (split_ad false) or (x, y)-(x+1, y+1) (split_ad true). The
// lattice vector P (P[phi] > 0) runs once around the tube; the tube is `rows` steps of the other
// lattice coordinate long.
Sheet lattice_sheet(double R, Eigen::Matrix2d B, bool split_ad, const Eigen::Vector2i& P, int phi, int rows) {
  Sheet s;
  s.period = 2 * kPi * R;
  B *= s.period / (B * P.cast<double>()).norm();
  const Eigen::Vector2d dir = (B * P.cast<double>()).normalized(), perp(-dir.y(), dir.x());
  std::map<std::pair<int, int>, int> index;  // canonical lattice point (phi coordinate in [0, P[phi]))
  auto id = [&](Eigen::Vector2i c) {
    const int k = (c[phi] >= 0 ? c[phi] : c[phi] - P[phi] + 1) / P[phi];  // floor division
    c -= k * P;
    const auto [it, added] = index.try_emplace({c.x(), c.y()}, static_cast<int>(s.uv.size()));
    if (added) {
      const Eigen::Vector2d q = B * c.cast<double>();
      s.uv.emplace_back(dir.dot(q), perp.dot(q));
    }
    return it->second;
  };
  const double v_phi = perp.dot(B.col(phi)), v_other = perp.dot(B.col(1 - phi));  // v per step
  const double length = rows * std::abs(v_other);
  std::vector<std::array<int, 3>> faces;
  for (int i = 0; i < P[phi]; ++i) {
    const double j0 = -i * v_phi / v_other, j1 = (length - i * v_phi) / v_other;
    for (int j = static_cast<int>(std::floor(std::min(j0, j1))) - 2; j <= std::max(j0, j1) + 2; ++j) {
      Eigen::Vector2i c[4];  // cell corners a, b = a + (1, 0), c = a + (0, 1), d = a + (1, 1)
      c[0][phi] = i;
      c[0][1 - phi] = j;
      for (int k = 1; k < 4; ++k) c[k] = c[0] + Eigen::Vector2i(k % 2, k / 2);
      bool inside = true;
      for (const auto& q : c) {
        const double v = perp.dot(B * q.cast<double>());
        inside = inside && v > -1e-9 * length && v < length * (1 + 1e-9);
      }
      if (!inside) continue;
      const int a = id(c[0]), b = id(c[1]), cc = id(c[2]), d = id(c[3]);
      if (split_ad) faces.push_back({a, b, d}), faces.push_back({a, d, cc});
      else faces.push_back({a, b, cc}), faces.push_back({b, d, cc});
    }
  }
  s.F.resize(static_cast<int>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f) s.F.row(f) << faces[f][0], faces[f][1], faces[f][2];
  return s;
}

// Discrete bending energy of the sheet wrapped into the tube (rest: the flat sheet), and the continuum
// value (D/2) / R^2 * flat area, J.
std::pair<double, double> tube_energy(const Sheet& s, double R, double D) {
  // Flat position of vertex v, unwrapped across the seam to lie next to vertex `ref`.
  auto flat = [&](int v, int ref) {
    const double u = s.uv[v].x() - s.period * std::round((s.uv[v].x() - s.uv[ref].x()) / s.period);
    return Vec3(u, s.uv[v].y(), 0.0);
  };
  auto wrapped = [&](int v) {
    const double phi = s.uv[v].x() / R;
    return Vec3(R * std::cos(phi), R * std::sin(phi), s.uv[v].y());
  };
  double energy = 0.0, area = 0.0;
  for (const Hinge& h : hinges_of(s.F)) {
    Vec<12> X, x;
    for (int a = 0; a < 4; ++a) {
      X.segment<3>(3 * a) = flat(h.v[a], h.v[0]);
      x.segment<3>(3 * a) = wrapped(h.v[a]);
    }
    energy += hinge_bending_energy(x, hinge_rest(X), hinge_stiffness(D));
  }
  for (int f = 0; f < s.F.rows(); ++f) {
    const Vec3 o = flat(s.F(f, 0), s.F(f, 0));
    area += 0.5 * (flat(s.F(f, 1), s.F(f, 0)) - o).cross(flat(s.F(f, 2), s.F(f, 0)) - o).norm();
  }
  return {energy, 0.5 * D / (R * R) * area};
}

constexpr double kR = 0.3, kD = 1e-3;  // tube radius (m), bending rigidity (N m)

// Discrete / continuum energy of the bulk of the tube lattice_sheet(kR, B, split_ad, P, phi, rows):
// the difference between 200 and 100 rows cancels what the two open ends lose.
double bulk_ratio(const Eigen::Matrix2d& B, bool split_ad, const Eigen::Vector2i& P, int phi) {
  const auto [e1, c1] = tube_energy(lattice_sheet(kR, B, split_ad, P, phi, 100), kR, kD);
  const auto [e2, c2] = tube_energy(lattice_sheet(kR, B, split_ad, P, phi, 200), kR, kD);
  return (e2 - e1) / (c2 - c1);
}

// Equilateral lattice (a, 0), (a/2, a sqrt(3)/2): rows of edges along x, every other row offset by a
// half cell. The right-triangle lattice is the identity, split along the (1, 1) diagonal.
const Eigen::Matrix2d kEquilateral = (Eigen::Matrix2d() << 1, 0.5, 0, std::sqrt(0.75)).finished();

TEST(HingeBending, CylinderEnergyMatchesPlateTheoryOnEquilateralMeshWithinOnePercent) {
  // Rows around the tube: the error is the chord error O((a/R)^2).
  double previous = 1.0;
  for (int n : {30, 60, 120}) {
    const double ratio = bulk_ratio(kEquilateral, false, {n, 0}, 0);
    std::printf("equilateral, rows around the tube, %3d cells around: discrete/continuum = %.6f\n", n, ratio);
    EXPECT_NEAR(ratio, 1.0, 0.01);
    EXPECT_LT(std::abs(ratio - 1.0), 0.3 * previous);  // second order: / 4 per halving of a
    previous = std::abs(ratio - 1.0);
  }
  // Rows along the axis (P = (-30, 60) is 60 rows around): only the axis-parallel edges fold.
  const double along = bulk_ratio(kEquilateral, false, {-30, 60}, 1);
  std::printf("equilateral, rows along the axis,   60 rows around:  discrete/continuum = %.6f\n", along);
  EXPECT_NEAR(along, 1.0, 0.01);
}

TEST(HingeBending, RightTriangleGridIsExactAlongGridLinesAndThreeTimesTooStiffAcrossDiagonals) {
  auto ratio = [](Eigen::Vector2i P) { return bulk_ratio(Eigen::Matrix2d::Identity(), true, P, 0); };
  const double grid_line = ratio({60, 0}), across = ratio({60, 60}), along = ratio({60, -60});
  std::printf("right-triangle grid, axis along a grid line:          discrete/continuum = %.6f\n", grid_line);
  std::printf("right-triangle grid, axis across the split diagonals: discrete/continuum = %.6f\n", across);
  std::printf("right-triangle grid, axis along the split diagonals:  discrete/continuum = %.6f\n", along);
  EXPECT_NEAR(grid_line, 1.0, 0.01);
  EXPECT_NEAR(across, 3.0, 0.03);
  EXPECT_NEAR(along, 1.0, 0.01);
}

TEST(HingeBending, StiffnessIsHalfTheBendingRigidityAndBadHingesThrow) {
  EXPECT_EQ(hinge_stiffness(0.25), 0.125);
  Positions V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, -1, 0;
  EXPECT_THROW(HingeBending({Hinge{{0, 1, 2, 4}}}, V, 1.0), std::invalid_argument);
  V.row(2) << 2, 0, 0;  // wing 1 collinear with the edge: zero rest area
  EXPECT_THROW(HingeBending({Hinge{{0, 1, 2, 3}}}, V, 1.0), std::invalid_argument);
}


// The element loops run on several threads (physics/element_loops.h); the value, the gradient and
// the assembled projected Hessian must be the same bytes for every thread count.
// The term evaluates two hinges per pass (physics/lanes.h); each lane must give the bits of the
// one-hinge functions: an odd count (the last hinge alone), a hinge collapsed in either lane, the
// gradient after a value (angles reused) and without, on one and two threads.
TEST(HingeBending, PairedValueAndGradientGiveTheOneHingeBitsWithAnOddCountAndCollapsedHinges) {
  TriMesh m = grid(2, 2, 0.5, 0.5);
  for (int i = 0; i < m.num_vertices(); ++i) m.V(i, 2) = 0.3 * m.V(i, 0) * m.V(i, 0) - 0.2 * m.V(i, 1);
  std::vector<Hinge> hinges = hinges_of(m.F);
  hinges.resize(7);
  const double k = hinge_stiffness(0.05);
  Eigen::VectorXd x = stacked(m.V) + 0.05 * test::wavy(3 * m.num_vertices(), 0.61, 0.3);
  for (int h : {2, 5}) {  // wing 1 of hinges 2 and 5 (lanes 0 and 1) flattened onto its edge
    const Hinge& hg = hinges[static_cast<size_t>(h)];
    x.segment<3>(3 * hg.v[2]) = 0.5 * (x.segment<3>(3 * hg.v[0]) + x.segment<3>(3 * hg.v[1]));
  }
  double energy = 0.0;
  Eigen::VectorXd gradient = Eigen::VectorXd::Zero(x.size());
  int collapsed = 0;
  for (const Hinge& h : hinges) {
    const Vec<12> X = hinge_positions(h, stacked(m.V)), xe = hinge_positions(h, x);
    const HingeRest rest = hinge_rest(X);
    energy += hinge_bending_energy(xe, rest, k);
    const Vec<12> g = hinge_bending_gradient(xe, rest, k);
    collapsed += dihedral_angle(xe) == 0.0 && g.isZero(0.0);
    for (int a = 0; a < 4; ++a) gradient.segment<3>(3 * h.v[a]) += g.segment<3>(3 * a);
  }
  ASSERT_GE(collapsed, 2);
  const long compared = test::expect_value_and_gradient_bits(
      [&] { return std::make_unique<HingeBending>(hinges, m.V, 0.05); }, x, energy, gradient);
  EXPECT_EQ(compared, 4 * x.size() + 2);
}

TEST(HingeBending, ValueGradientAndHessianAreBitIdenticalOnOneTwoAndThreeThreads) {
  const TriMesh sheet = make_rectangle(1.0, 1.0, 30, 30);
  const std::vector<Hinge> hinges = hinges_of(sheet.F);
  ASSERT_GT(hinges.size(), 2000u);  // the parallel path
  const HingeBending bending(hinges, sheet.V, 0.02);
  const Eigen::VectorXd x = stacked(sheet.V) + 0.01 * test::wavy(3 * sheet.num_vertices(), 0.37, 0.1);
  const test::TermBits one = test::term_bits(bending, x, HessianProjection::Clamp, 1);
  long compared = 0;
  for (int threads : {2, 3}) compared += test::expect_same_bits(one, test::term_bits(bending, x, HessianProjection::Clamp, threads));
  EXPECT_GT(compared, 2 * 45000);  // 1 value + 2 883 gradient + 46 806 Hessian values per comparison
}

}  // namespace
}  // namespace pd
