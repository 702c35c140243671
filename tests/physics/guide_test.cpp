// GuideTerm (physics/guide.h): value, gradient and Hessian against finite differences (counted), the
// value and force by hand, weight 0 adding no force, the target as a stationary point at every
// weight, and bad input.
#include "physics/guide.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "support/term_eval.h"

namespace pd {
namespace {

// Three vertices, masses 1, 2, 3 kg on every dof; h = 0.1 s.
struct Fixture {
  Eigen::VectorXd masses = (Eigen::VectorXd(9) << 1, 1, 1, 2, 2, 2, 3, 3, 3).finished();
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(9), v0 = Eigen::VectorXd::Zero(9);
  GuideTerm term{masses};
  Fixture() {
    StepStart s;
    s.h = 0.1;
    s.x = &x0;
    s.v = &v0;
    term.begin_step(s);
  }
};

TEST(Guide, ValueAndForceByHandAndDerivativesMatchFiniteDifferences) {
  Fixture f;
  const Eigen::VectorXd y = test::wavy(9, 0.7, 0.3);
  f.term.set_guide(y, 2.5);
  Eigen::VectorXd x = y;
  x[4] += 0.2;  // vertex 1 (2 kg), y coordinate, 0.2 m from its target
  // E = 1/2 * 2.5 * 2 kg * (0.2 m)^2 / (0.1 s)^2 = 10 J; force on that dof 2.5 * 2 * 0.2 / 0.01 = 100 N.
  EXPECT_NEAR(f.term.value(x), 10.0, 1e-12);
  const Eigen::VectorXd g = test::term_gradient(f.term, x);
  EXPECT_NEAR(g[4], 100.0, 1e-10);
  EXPECT_NEAR(g.norm(), 100.0, 1e-10);
  const Eigen::VectorXd far = y + test::wavy(9, 1.3, 0.1);
  const test::TermFdCheck check = test::check_term_derivatives(f.term, far);
  test::expect_derivatives_match(check, 1e-6, 1e-6);
  EXPECT_EQ(check.gradient.comparisons, 9 * 4);
  EXPECT_EQ(check.hessian.comparisons, 81 * 4);
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(check.H(i, i), 2.5 * f.masses[i] / 0.01, 1e-9);
}

TEST(Guide, WeightZeroAddsNothingAndTheTargetIsStationaryAtEveryWeight) {
  Fixture f;
  const Eigen::VectorXd y = test::wavy(9, 0.4, 0.9);
  const Eigen::VectorXd x = y + test::wavy(9, 2.1, 0.2);
  f.term.set_guide(y, 3.0);
  f.term.set_weight(0.0);
  EXPECT_EQ(f.term.value(x), 0.0);
  EXPECT_EQ(test::term_gradient(f.term, x).norm(), 0.0);
  for (double w : {0.5, 1.0, 1e6}) {
    f.term.set_guide(y, w);
    EXPECT_EQ(test::term_gradient(f.term, y).norm(), 0.0) << w;
    EXPECT_GT(f.term.value(x), 0.0) << w;
  }
}

TEST(Guide, BadInputThrows) {
  Fixture f;
  EXPECT_THROW(GuideTerm(Eigen::VectorXd::Ones(4)), std::invalid_argument);
  EXPECT_THROW(GuideTerm(-Eigen::VectorXd::Ones(3)), std::invalid_argument);
  EXPECT_THROW(f.term.set_guide(Eigen::VectorXd::Zero(6), 1.0), std::invalid_argument);
  EXPECT_THROW(f.term.set_guide(Eigen::VectorXd::Zero(9), -1.0), std::invalid_argument);
  EXPECT_THROW(f.term.set_weight(std::nan("")), std::invalid_argument);
  GuideTerm fresh(f.masses);
  EXPECT_THROW(fresh.value(Eigen::VectorXd::Zero(9)), std::logic_error);
  EXPECT_THROW(f.term.value(Eigen::VectorXd::Zero(3)), std::invalid_argument);
}

}  // namespace
}  // namespace pd
