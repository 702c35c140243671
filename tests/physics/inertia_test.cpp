// Inertia term, lumped masses and kinetic energy.
#include "physics/inertia.h"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>

#include "physics/gravity.h"
#include "support/finite_difference.h"
#include "support/term_eval.h"

namespace pd {
namespace {

// 2 x 1 m rectangle in z = 0 with 2 x 2 cells (9 vertices, 8 triangles), built by hand.
TriMesh small_sheet() {
  TriMesh m;
  m.V.resize(9, 3);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) m.V.row(3 * j + i) << 1.0 * i, 0.5 * j, 0.0;
  m.F.resize(8, 3);
  int f = 0;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const int a = 3 * j + i, b = a + 1, c = a + 4, d = a + 3;
      m.F.row(f++) << a, b, c;
      m.F.row(f++) << a, c, d;
    }
  return m;
}

TEST(LumpedMasses, SumToTotalMassAndSplitTrianglesEqually) {
  const TriMesh m = small_sheet();
  const double rho_a = 0.3;  // kg/m^2
  const Eigen::VectorXd M = lumped_masses(m.F, m.V, rho_a);
  ASSERT_EQ(M.size(), 27);
  // Total over vertices (one dof per vertex) = rho_A * area; each vertex has equal x, y, z masses.
  EXPECT_NEAR(M.sum() / 3.0, rho_a * 2.0 * 1.0, 1e-14);
  for (int i = 0; i < 9; ++i) {
    EXPECT_EQ(M[3 * i], M[3 * i + 1]);
    EXPECT_EQ(M[3 * i], M[3 * i + 2]);
  }
  // Centre vertex (index 4): every cell's diagonal runs bottom-left to top-right, so it touches both
  // triangles of the cells (0,0) and (1,1) and one of the other two: 6 triangles of 0.25 m^2.
  int faces_at_centre = 0;
  for (int f = 0; f < 8; ++f)
    for (int a = 0; a < 3; ++a) faces_at_centre += (m.F(f, a) == 4);
  ASSERT_EQ(faces_at_centre, 6);
  EXPECT_NEAR(M[12], faces_at_centre * rho_a * 0.25 / 3.0, 1e-15);

  // A single triangle: a third of its mass at each vertex.
  Faces F1(1, 3);
  F1 << 0, 1, 2;
  Positions P1(3, 3);
  P1 << 0, 0, 0, 3, 0, 0, 0, 4, 0;  // area 6 m^2
  const Eigen::VectorXd M1 = lumped_masses(F1, P1, 0.5);
  for (int k = 0; k < 9; ++k) EXPECT_NEAR(M1[k], 1.0, 1e-15);
}

TEST(KineticEnergy, HalfMassSpeedSquared) {
  Eigen::VectorXd m(6), v(6);
  m << 2, 2, 2, 4, 4, 4;
  v << 1, 0, 0, 0, 3, 4;  // speeds 1 and 5 m/s
  EXPECT_NEAR(kinetic_energy(m, v), 0.5 * 2 * 1 + 0.5 * 4 * 25, 1e-13);
}

struct InertiaFixture : ::testing::Test {
  TriMesh mesh = small_sheet();
  Eigen::VectorXd masses = lumped_masses(mesh.F, mesh.V, 0.2);
  Eigen::VectorXd x0 = stacked(mesh.V);
  Eigen::VectorXd v0 = Eigen::VectorXd::NullaryExpr(27, [](Eigen::Index i) { return std::sin(1.7 * i); });
  double h = 1.0 / 60.0;
  InertiaTerm term{masses};
  void SetUp() override { term.begin_step(StepStart{0.5, h, &x0, &v0}); }
};

TEST_F(InertiaFixture, ZeroAtPredictionAndGradientAndHessianMatchFiniteDifferences) {
  const Eigen::VectorXd xhat = x0 + h * v0;
  EXPECT_NEAR((term.predicted_positions() - xhat).norm(), 0.0, 1e-15);
  EXPECT_EQ(term.value(xhat), 0.0);
  EXPECT_EQ(test::term_gradient(term, xhat).norm(), 0.0);

  const Eigen::VectorXd x = xhat + 0.01 * Eigen::VectorXd::NullaryExpr(27, [](Eigen::Index i) {
    return std::cos(0.9 * i + 0.3);
  });
  const test::TermFdCheck fd = test::check_term_derivatives(term, x);
  test::expect_derivatives_match(fd, 1e-7, 1e-8);
  const Eigen::MatrixXd& H = fd.H;
  const test::FdResult& rg = fd.gradient;
  const test::FdResult& rh = fd.hessian;
  // Diagonal M / h^2 and nothing else.
  EXPECT_NEAR((H - Eigen::MatrixXd((masses / (h * h)).asDiagonal())).norm(), 0.0, 1e-12);
  std::printf("inertia: gradient FD rel err %.2e, Hessian FD rel err %.2e\n", rg.best_rel_error,
              rh.best_rel_error);
}

// With gravity alone, the minimiser of inertia + gravity is implicit Euler free fall:
// M (x - xhat) / h^2 = M g  =>  x1 = x0 + h v0 + h^2 g. One Newton step from any x lands on it.
TEST_F(InertiaFixture, MinimiserUnderGravityIsImplicitEulerFreeFall) {
  const Vec3 g(0.3, -9.81, 0.1);
  const GravityTerm gravity(masses, g);
  const Eigen::VectorXd start = x0 + 0.05 * Eigen::VectorXd::Ones(27);
  Eigen::VectorXd grad = Eigen::VectorXd::Zero(27);
  term.add_gradient(start, grad);
  gravity.add_gradient(start, grad);
  HessianAssembly A;
  A.begin(27);
  term.add_hessian(start, HessianProjection::Clamp, A);
  gravity.add_hessian(start, HessianProjection::Clamp, A);
  const Eigen::MatrixXd L(A.finish(nullptr));
  const Eigen::VectorXd x1 = start - L.diagonal().cwiseInverse().cwiseProduct(grad);  // H is diagonal
  EXPECT_EQ((L - Eigen::MatrixXd(L.diagonal().asDiagonal())).norm(), 0.0);

  Eigen::VectorXd expected = x0 + h * v0;
  for (int i = 0; i < 9; ++i) expected.segment<3>(3 * i) += h * h * g;
  EXPECT_LT((x1 - expected).cwiseAbs().maxCoeff(), 1e-14);
  // And it is a stationary point of the sum.
  Eigen::VectorXd g1 = test::term_gradient(term, x1);
  gravity.add_gradient(x1, g1);
  EXPECT_LT(g1.cwiseAbs().maxCoeff(), 1e-9);
}

// Wrong sizes and a missing step are errors in every build (they were asserts, so a Release build
// read past the mass vector and returned garbage).
TEST_F(InertiaFixture, WrongSizesBadMassesAndAMissingStepAreRefusedInEveryBuild) {
  EXPECT_THROW(InertiaTerm(Eigen::VectorXd::Ones(7)), std::invalid_argument);
  Eigen::VectorXd negative = masses;
  negative[4] = -1.0;
  EXPECT_THROW(InertiaTerm{negative}, std::invalid_argument);
  negative[4] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(InertiaTerm{negative}, std::invalid_argument);

  InertiaTerm fresh{masses};
  EXPECT_THROW(fresh.value(x0), std::logic_error) << "no begin_step yet";
  const Eigen::VectorXd short_x = x0.head(24);
  EXPECT_THROW(fresh.begin_step(StepStart{0.5, h, &short_x, &v0}), std::invalid_argument);
  EXPECT_THROW(fresh.begin_step(StepStart{0.5, 0.0, &x0, &v0}), std::invalid_argument);
  EXPECT_THROW(fresh.begin_step(StepStart{0.5, h, &x0, nullptr}), std::invalid_argument);
  EXPECT_THROW(term.value(short_x), std::invalid_argument);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(24);
  EXPECT_THROW(term.add_gradient(short_x, g), std::invalid_argument);
  EXPECT_NO_THROW(term.value(x0));
}

}  // namespace
}  // namespace pd
