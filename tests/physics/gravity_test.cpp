// Gravity potential -sum m g . x.
#include "physics/gravity.h"

#include <gtest/gtest.h>

#include "support/finite_difference.h"
#include "support/term_eval.h"

namespace pd {
namespace {

struct GravityFixture : ::testing::Test {
  Eigen::VectorXd masses;
  Eigen::VectorXd x;
  Vec3 g{0.5, -9.81, 0.25};
  void SetUp() override {
    masses.resize(12);
    masses << 1, 1, 1, 2, 2, 2, 0.5, 0.5, 0.5, 3, 3, 3;  // kg per dof, 4 vertices
    x = Eigen::VectorXd::NullaryExpr(12, [](Eigen::Index i) { return std::sin(2.3 * i + 0.1); });
  }
};

TEST_F(GravityFixture, ValueIsMinusMassTimesGDotX) {
  const GravityTerm term(masses, g);
  EXPECT_EQ(term.name(), "gravity");
  double expected = 0.0;
  for (int i = 0; i < 4; ++i) expected -= masses[3 * i] * g.dot(x.segment<3>(3 * i));
  EXPECT_NEAR(term.value(x), expected, 1e-13);
  // Translating everything by d changes the potential by -M_total g . d (M_total = 6.5 kg).
  const Vec3 d(0.1, 2.0, -0.3);
  Eigen::VectorXd y = x;
  for (int i = 0; i < 4; ++i) y.segment<3>(3 * i) += d;
  EXPECT_NEAR(term.value(y) - term.value(x), -6.5 * g.dot(d), 1e-12);
  // The force -gradient on each vertex is m g.
  const Eigen::VectorXd grad = test::term_gradient(term, x);
  for (int i = 0; i < 4; ++i)
    EXPECT_LT((-grad.segment<3>(3 * i) - masses[3 * i] * g).norm(), 1e-15);
}

TEST_F(GravityFixture, GradientAndZeroHessianMatchFiniteDifferences) {
  const GravityTerm term(masses, g);
  auto f = [&](const Eigen::VectorXd& y) { return term.value(y); };
  auto gr = [&](const Eigen::VectorXd& y) { return test::term_gradient(term, y); };
  const test::FdResult rg = test::check_gradient(f, x, gr(x));
  EXPECT_GT(rg.comparisons, 0);
  EXPECT_GE(rg.steps_within(1e-8), 2) << "best " << rg.best_rel_error;

  // add_hessian adds nothing at all: the assembled matrix is the zero diagonal of the pattern.
  HessianAssembly A;
  A.begin(12);
  term.add_hessian(x, HessianProjection::None, A);
  const Eigen::MatrixXd L(A.finish(nullptr));
  EXPECT_EQ(L.norm(), 0.0);
  const test::FdResult rh = test::check_hessian(gr, x, Eigen::MatrixXd::Zero(12, 12));
  EXPECT_GT(rh.comparisons, 0);
  EXPECT_GE(rh.steps_within(1e-8), 2) << "best " << rh.best_rel_error;
  std::printf("gravity: gradient FD rel err %.2e, Hessian FD err %.2e (analytic Hessian is zero)\n",
              rg.best_rel_error, rh.best_rel_error);
}

TEST(Gravity, MassesThatAreNotThreePerVertexAreRefused) {
  EXPECT_THROW(GravityTerm(Eigen::VectorXd::Ones(10), Vec3(0, -9.81, 0)), std::invalid_argument);
  EXPECT_NO_THROW(GravityTerm(Eigen::VectorXd::Ones(9), Vec3(0, -9.81, 0)));
}

}  // namespace
}  // namespace pd
