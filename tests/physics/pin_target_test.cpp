// The augmented-Lagrangian pull of scripted pins toward their targets.
#include "physics/pin_target.h"

#include <gtest/gtest.h>

#include "support/term_eval.h"

namespace pd {
namespace {

Eigen::VectorXd targets_for(const Eigen::VectorXd& x) { return x + test::wavy(x.size(), 0.7, 0.3) * 0.05; }

TEST(PinTarget, InactiveTermIsZeroAndAddsNothing) {
  const PinTargetTerm term({0, 2});
  const Eigen::VectorXd x = test::wavy(12, 1.3, 0.2);
  EXPECT_EQ(term.name(), "pin_target");
  EXPECT_EQ(term.value(x), 0.0);
  EXPECT_EQ(test::term_gradient(term, x).norm(), 0.0);
  EXPECT_EQ(test::term_hessian(term, x, HessianProjection::None).norm(), 0.0);
}

TEST(PinTarget, GradientAndHessianMatchFiniteDifferencesWithMultipliers) {
  PinTargetTerm term({0, 2, 3});
  const Eigen::VectorXd x = test::wavy(12, 1.3, 0.2);
  term.activate(targets_for(x), 250.0);
  // Multipliers from an iterate away from the targets, so the linear part is non-zero.
  term.update_multipliers(x + test::wavy(12, 0.4, 1.1) * 0.01);
  const auto check = test::check_term_derivatives(term, x);
  test::expect_derivatives_match(check, 1e-6, 1e-6);
  // Only the pulled vertices appear, each with k I.
  EXPECT_NEAR(check.H(0, 0), 250.0, 1e-12);
  EXPECT_EQ((check.H.block<3, 3>(3, 3).norm()), 0.0);
}

TEST(PinTarget, ValueIsZeroAtTheTargetsAndTheMinimumMovesWithTheMultipliers) {
  PinTargetTerm term({1});
  const Eigen::VectorXd x = Eigen::VectorXd::Zero(6);
  Eigen::VectorXd t = x;
  t.segment<3>(3) = Vec3(0.1, -0.2, 0.3);
  term.activate(t, 100.0);
  EXPECT_EQ(term.value(t), 0.0);
  EXPECT_NEAR(term.max_distance(x), Vec3(0.1, -0.2, 0.3).norm(), 1e-15);
  // An external force f on the pin holds it at y = t + f / k against the pull. The multiplier
  // update makes lambda = -f, so the term's force at the target itself, -grad = lambda, is -f:
  // the next solve with the same external force ends exactly at the target.
  const Vec3 f(0, -5.0, 0);
  Eigen::VectorXd y = t;
  y.segment<3>(3) += f / 100.0;
  term.update_multipliers(y);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(6);
  term.add_gradient(t, g);
  EXPECT_LT((-g.segment<3>(3) + f).norm(), 1e-12);
}

}  // namespace
}  // namespace pd
