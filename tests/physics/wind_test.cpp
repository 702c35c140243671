// Wind drag, quadratic drag linearised about the start of the step.
#include "physics/wind.h"

#include <cmath>

#include <gtest/gtest.h>

#include "support/finite_difference.h"
#include "support/term_eval.h"

namespace pd {
namespace {

// Square plate of side L centred at c, spanned by orthonormal e1, e2 (normal e1 x e2), as two
// triangles (0,1,2), (0,2,3): vertices 0 and 2 carry both triangles.
struct Plate {
  Faces F;
  Eigen::VectorXd x;
  Vec3 n;
  double area;
  Plate(const Vec3& c, const Vec3& e1, const Vec3& e2, double L) : x(12), n(e1.cross(e2)), area(L * L) {
    F.resize(2, 3);
    F << 0, 1, 2, 0, 2, 3;
    const double s[4][2] = {{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}};
    for (int i = 0; i < 4; ++i) x.segment<3>(3 * i) = c + L * (s[i][0] * e1 + s[i][1] * e2);
  }
};

Plate tilted_plate() {
  const Vec3 e1 = Vec3(1, 2, 0.5).normalized();
  const Vec3 e2 = e1.cross(Vec3(0.3, -0.2, 1.0)).normalized();
  return Plate(Vec3(0.2, 1.0, -0.4), e1, e2, 0.5);
}

// Sum over vertices of the force -grad.
Vec3 total_force(const Eigen::VectorXd& grad) {
  Vec3 f = Vec3::Zero();
  for (Eigen::Index i = 0; i < grad.size() / 3; ++i) f -= grad.segment<3>(3 * i);
  return f;
}

// A 3 x 3-vertex sheet, crumpled out of plane, with velocities, in a gusty wind.
struct WindFixture : ::testing::Test {
  Faces F;
  Eigen::VectorXd xs, vs;
  Wind params;
  double h = 0.01, t_end = 0.37;
  void SetUp() override {
    F.resize(8, 3);
    int f = 0;
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        const int a = 3 * j + i;
        F.row(f++) << a, a + 1, a + 4;
        F.row(f++) << a, a + 4, a + 3;
      }
    xs.resize(27);
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) xs.segment<3>(3 * (3 * j + i)) = Vec3(0.4 * i, 0.4 * j, 0.0);
    xs += 0.05 * test::wavy(27, 1.3, 0.2);
    vs = 2.0 * test::wavy(27, 0.7, 1.1);
    params.air_velocity = Vec3(3.0, -1.0, 5.0);
    params.air_density = 1.2;
    params.drag_coefficient = 1.3;
    params.gust_amplitude = 0.4;
    params.gust_frequency = 1.5;
  }
};

TEST_F(WindFixture, GradientAndHessianMatchFiniteDifferencesAndArePsd) {
  WindTerm term(F, params);
  EXPECT_EQ(term.name(), "wind");
  term.begin_step(StepStart{t_end, h, &xs, &vs});
  const Eigen::VectorXd x = xs + h * vs + 0.003 * test::wavy(27, 2.1, 0.4);
  const test::TermFdCheck fd = test::check_term_derivatives(term, x);
  test::expect_derivatives_match(fd, 1e-7, 1e-7);
  const Eigen::MatrixXd& H = fd.H;
  const test::FdResult& rg = fd.gradient;
  const test::FdResult& rh = fd.hessian;
  std::printf("wind: gradient FD rel err %.2e, Hessian FD rel err %.2e\n", rg.best_rel_error,
              rh.best_rel_error);

  // Already PSD: projection changes nothing beyond round-off, and the potential is >= 0.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H);
  EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-10 * eig.eigenvalues().maxCoeff());
  EXPECT_LT((test::term_hessian(term, x, HessianProjection::Clamp) - H).norm(), 1e-10 * H.norm());
  EXPECT_GT(term.value(x), 0.0);
}

// Only the velocity relative to the air matters: air and cloth both moving U faster gives the
// same potential and forces (gusts off, so the air moves exactly U faster).
TEST_F(WindFixture, DependsOnlyOnRelativeVelocity) {
  params.gust_amplitude = 0.0;
  const Vec3 U(-2.0, 0.5, 7.0);
  Wind moved = params;
  moved.air_velocity += U;
  Eigen::VectorXd vs_moved = vs, dx = Eigen::VectorXd::Zero(27);
  for (int i = 0; i < 9; ++i) {
    vs_moved.segment<3>(3 * i) += U;
    dx.segment<3>(3 * i) = h * U;  // end-of-step velocity (x - x_start) / h also U faster
  }
  WindTerm a(F, params), b(F, moved);
  a.begin_step(StepStart{t_end, h, &xs, &vs});
  b.begin_step(StepStart{t_end, h, &xs, &vs_moved});
  const Eigen::VectorXd x = xs + h * vs + 0.003 * test::wavy(27, 2.1, 0.4);
  EXPECT_NEAR(a.value(x), b.value(x + dx), 1e-12 * a.value(x));
  const Eigen::VectorXd ga = test::term_gradient(a, x);
  EXPECT_LT((ga - test::term_gradient(b, x + dx)).norm(), 1e-12 * ga.norm());
  EXPECT_GT(ga.norm(), 0.0);
}

// Plate moving along its normal at speed s through wind w: at x = x_start + h v_start the
// end-of-step velocity equals v_start, so the force is the quadratic drag -1/2 rho C_d A |u| u n,
// u = s - n . w, a third of each triangle's half on each of its vertices.
TEST(Wind, FlatPlateMovingNormalToItselfFeelsQuadraticDrag) {
  const Plate p = tilted_plate();
  Wind params;
  params.air_velocity = Vec3(1.0, -2.0, 0.5);
  params.air_density = 1.2;
  params.drag_coefficient = 1.1;
  const double s = 3.0, h = 0.02;
  Eigen::VectorXd v(12);
  for (int i = 0; i < 4; ++i) v.segment<3>(3 * i) = s * p.n;
  WindTerm term(p.F, params);
  term.begin_step(StepStart{0.0, h, &p.x, &v});
  const double u = s - p.n.dot(params.air_velocity);
  ASSERT_GT(std::abs(u), 1.0);
  const Vec3 expected = -0.5 * 1.2 * 1.1 * p.area * std::abs(u) * u * p.n;
  const Eigen::VectorXd grad = test::term_gradient(term, p.x + h * v);
  EXPECT_LT((total_force(grad) - expected).norm(), 1e-12 * expected.norm());
  const double share[4] = {1.0 / 3, 1.0 / 6, 1.0 / 3, 1.0 / 6};
  for (int i = 0; i < 4; ++i)
    EXPECT_LT((-grad.segment<3>(3 * i) - share[i] * expected).norm(), 1e-12 * expected.norm());
  // Drag potential h c u^2 / 2 there (c = 1/2 rho C_d A |u|).
  const double D = h * 0.5 * (0.5 * 1.2 * 1.1 * p.area * std::abs(u)) * u * u;
  EXPECT_NEAR(term.value(p.x + h * v), D, 1e-12 * D);
}

// Plate at rest at x = x_start in a gusty wind: pushed along the wind's normal component, with the
// air velocity evaluated at the end of the step.
TEST(Wind, PlateAtRestIsPushedByGustAtEndOfStep) {
  const Plate p = tilted_plate();
  Wind params;
  params.air_velocity = Vec3(0.0, 0.0, 6.0);
  params.gust_amplitude = 0.5;
  params.gust_frequency = 2.0;
  const double t_end = 0.1, h = 0.01;
  const Eigen::VectorXd v = Eigen::VectorXd::Zero(12);
  WindTerm term(p.F, params);
  term.begin_step(StepStart{t_end, h, &p.x, &v});
  const Vec3 w = params.air_velocity * (1.0 + 0.5 * std::sin(2.0 * std::acos(-1.0) * 2.0 * t_end));
  EXPECT_LT((term.air_velocity(t_end) - w).norm(), 1e-14);
  const double wn = p.n.dot(w);
  const Vec3 expected = 0.5 * 1.2 * 1.0 * p.area * std::abs(wn) * wn * p.n;
  EXPECT_LT((total_force(test::term_gradient(term, p.x)) - expected).norm(), 1e-12 * expected.norm());
}

// Air flowing along the plate: no force at rest; the lagged coefficient falls back to the floor
// speed, so moving the plate normal to itself meets a small linear drag.
TEST(Wind, EdgeOnAirGivesNoForceAndFloorDrag) {
  const Plate p = tilted_plate();
  const Vec3 e1 = (p.x.segment<3>(3) - p.x.segment<3>(0)).normalized();
  Wind params;
  params.air_velocity = 4.0 * e1;
  const double h = 0.01;
  const Eigen::VectorXd v = Eigen::VectorXd::Zero(12);
  WindTerm term(p.F, params);
  term.begin_step(StepStart{0.0, h, &p.x, &v});
  EXPECT_LT(total_force(test::term_gradient(term, p.x)).norm(), 1e-12);
  Eigen::VectorXd x = p.x;
  const double s = 0.2;  // end-of-step normal speed, m/s
  for (int i = 0; i < 4; ++i) x.segment<3>(3 * i) += h * s * p.n;
  const Vec3 expected = -0.5 * 1.2 * 1.0 * p.area * WindTerm::kMinRelativeSpeed * s * p.n;
  EXPECT_LT((total_force(test::term_gradient(term, x)) - expected).norm(), 1e-12 * expected.norm());
}

// A missing step, a non-positive step and positions that do not hold every face's vertices are
// errors in every build (they were asserts); the statistics' value before any step is 0.
TEST_F(WindFixture, AMissingStepAndPositionsShortOfTheFacesAreRefusedInEveryBuild) {
  WindTerm term(F, params);
  EXPECT_THROW(term.value(xs), std::logic_error);
  // The frame statistics of frame 0 ask before any step: no drag potential yet, 0 (it was NaN).
  const auto before = term.named_values(xs);
  ASSERT_EQ(before.size(), 1u);
  EXPECT_EQ(before[0].first, "wind");
  EXPECT_EQ(before[0].second, 0.0);
  const Eigen::VectorXd short_x = xs.head(24), short_v = vs.head(24);
  EXPECT_THROW(term.begin_step(StepStart{t_end, h, &short_x, &short_v}), std::invalid_argument);
  EXPECT_THROW(term.begin_step(StepStart{t_end, h, &xs, &short_v}), std::invalid_argument);
  EXPECT_THROW(term.begin_step(StepStart{t_end, -h, &xs, &vs}), std::invalid_argument);
  EXPECT_NO_THROW(term.begin_step(StepStart{t_end, h, &xs, &vs}));
  EXPECT_THROW(term.value(short_x), std::invalid_argument);
  const Eigen::VectorXd moved = xs + 0.01 * vs;
  EXPECT_GT(term.value(moved), 0.0);
  EXPECT_EQ(term.named_values(moved)[0].second, term.value(moved)) << "after a step, the value itself";
}

}  // namespace
}  // namespace pd
