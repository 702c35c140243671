#include "solver/newton.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>

#include "geometry/mesh.h"

namespace pd {
namespace {

// E(x) = sum_i ( x_i^4 / 4 + k/2 (x_i - c_i)^2 ): strictly convex, non-quadratic, per-vertex blocks.
class QuarticTerm : public EnergyTerm {
 public:
  QuarticTerm(Eigen::VectorXd c, double k) : c_(std::move(c)), k_(k) {}
  std::string name() const override { return "quartic"; }
  double value(const Eigen::VectorXd& x) const override {
    return (x.array().pow(4) / 4).sum() + k_ / 2 * (x - c_).squaredNorm();
  }
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& g) const override {
    g += (x.array().pow(3)).matrix() + k_ * (x - c_);
  }
  void add_hessian(const Eigen::VectorXd& x, HessianProjection p, HessianAssembly& H) const override {
    for (int v = 0; v < x.size() / 3; ++v) {
      Mat3 h = Mat3::Zero();
      for (int i = 0; i < 3; ++i) h(i, i) = 3 * x[3 * v + i] * x[3 * v + i] + k_;
      H.add<1>({v}, project_hessian<3>(h, p));
    }
  }

 private:
  Eigen::VectorXd c_;
  double k_;
};

// E(x) = sum_i (x_i^2 - 1)^2 / 4: a double well per dof, element Hessian 3 x_i^2 - 1 (negative for
// |x_i| < 1/sqrt(3)). Beside a QuarticTerm its clamped Hessian is positive definite, its exact one
// is positive definite only where 3 x_i^2 - 1 + k > 0.
class DoubleWellTerm : public EnergyTerm {
 public:
  std::string name() const override { return "double_well"; }
  double value(const Eigen::VectorXd& x) const override { return ((x.array().square() - 1).square() / 4).sum(); }
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& g) const override {
    g += (x.array() * (x.array().square() - 1)).matrix();
  }
  void add_hessian(const Eigen::VectorXd& x, HessianProjection p, HessianAssembly& H) const override {
    for (int v = 0; v < x.size() / 3; ++v) {
      Mat3 h = Mat3::Zero();
      for (int i = 0; i < 3; ++i) h(i, i) = 3 * x[3 * v + i] * x[3 * v + i] - 1;
      H.add<1>({v}, project_hessian<3>(h, p));
    }
  }
};

// E(x) = sum_v 1/2 x_v^T A_v x_v with a fixed 3x3 matrix per vertex (the vertices of `forms`).
class FixedFormTerm : public EnergyTerm {
 public:
  explicit FixedFormTerm(std::vector<Mat3> forms) : forms_(std::move(forms)) {}
  std::string name() const override { return "fixed_form"; }
  double value(const Eigen::VectorXd& x) const override {
    double e = 0.0;
    for (size_t v = 0; v < forms_.size(); ++v) {
      const Vec3 u = x.segment<3>(3 * static_cast<Eigen::Index>(v));
      e += 0.5 * u.dot(forms_[v] * u);
    }
    return e;
  }
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& g) const override {
    for (size_t v = 0; v < forms_.size(); ++v)
      g.segment<3>(3 * static_cast<Eigen::Index>(v)) += forms_[v] * x.segment<3>(3 * static_cast<Eigen::Index>(v));
  }
  void add_hessian(const Eigen::VectorXd& /*x*/, HessianProjection p, HessianAssembly& H) const override {
    for (size_t v = 0; v < forms_.size(); ++v) H.add<1>({static_cast<int>(v)}, project_hessian<3>(forms_[v], p));
  }

 private:
  std::vector<Mat3> forms_;
};

// No energy; max_step returns bound(dx), as CCD caps a step near contact.
class StepBoundTerm : public EnergyTerm {
 public:
  explicit StepBoundTerm(std::function<double(const Eigen::VectorXd&)> bound) : bound_(std::move(bound)) {}
  std::string name() const override { return "step_bound"; }
  double value(const Eigen::VectorXd& /*x*/) const override { return 0.0; }
  void add_gradient(const Eigen::VectorXd& /*x*/, Eigen::VectorXd& /*g*/) const override {}
  void add_hessian(const Eigen::VectorXd& /*x*/, HessianProjection /*p*/, HessianAssembly& /*H*/) const override {}
  double max_step(const Eigen::VectorXd& /*x*/, const Eigen::VectorXd& dx) const override { return bound_(dx); }

 private:
  std::function<double(const Eigen::VectorXd&)> bound_;
};

// Caps every step at `alpha` of the Newton step.
std::unique_ptr<EnergyTerm> step_cap(double alpha) {
  return std::make_unique<StepBoundTerm>([alpha](const Eigen::VectorXd&) { return alpha; });
}

// Caps every step so that no dof moves more than `reach`.
std::unique_ptr<EnergyTerm> reach_cap(double reach) {
  return std::make_unique<StepBoundTerm>([reach](const Eigen::VectorXd& dx) {
    const double longest = dx.lpNorm<Eigen::Infinity>();
    return longest > reach ? reach / longest : 1.0;
  });
}

// Wraps a term and assembles `scale` times its Hessian: a model Hessian, as a coarse level's lagged
// prolonged blocks are, that misjudges the curvature by a known factor; value and gradient are the
// wrapped term's own.
class ScaledModelTerm : public EnergyTerm {
 public:
  ScaledModelTerm(std::unique_ptr<EnergyTerm> term, double scale) : term_(std::move(term)), scale_(scale) {}
  const EnergyTerm& wrapped() const { return *term_; }
  std::string name() const override { return "scaled_model"; }
  double value(const Eigen::VectorXd& x) const override { return term_->value(x); }
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& g) const override { term_->add_gradient(x, g); }
  void add_hessian(const Eigen::VectorXd& x, HessianProjection p, HessianAssembly& H) const override {
    HessianAssembly own;
    own.begin(static_cast<int>(x.size()));
    term_->add_hessian(x, p, own);
    const HessianAssembly::SparseMatrix& M = own.finish(nullptr);
    for (int v = 0; 3 * v < M.cols(); ++v) {  // the wrapped terms here have per-vertex blocks only
      Mat3 block = Mat3::Zero();
      for (int c = 0; c < 3; ++c)
        for (HessianAssembly::SparseMatrix::InnerIterator it(M, 3 * v + c); it; ++it)
          if (it.row() / 3 == v) block(it.row() - 3 * v, c) = it.value();
      block.triangularView<Eigen::StrictlyUpper>() = block.transpose().triangularView<Eigen::StrictlyUpper>();
      H.add<1>({v}, scale_ * block);
    }
  }

 private:
  std::unique_ptr<EnergyTerm> term_;
  double scale_;
};

// A term with a stand-in Hessian phase, as the coarse-first prolonged term has: its first
// `stand_in_assemblies` Hessians of a step are `scale` times the wrapped term's, the later ones the
// wrapped term's own (the costlier model; counted), unless the solver kept the stand-in.
class StandInPhaseTerm : public EnergyTerm {
 public:
  StandInPhaseTerm(std::unique_ptr<EnergyTerm> term, double scale, int stand_in_assemblies)
      : stand_in_(std::move(term), scale), term_(stand_in_.wrapped()), phase_(stand_in_assemblies) {}
  std::string name() const override { return "stand_in_phase"; }
  double value(const Eigen::VectorXd& x) const override { return term_.value(x); }
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& g) const override { term_.add_gradient(x, g); }
  void add_hessian(const Eigen::VectorXd& x, HessianProjection p, HessianAssembly& H) const override {
    if (assemblies_++ < phase_ || keep_) {
      stand_in_.add_hessian(x, p, H);
    } else {
      ++costly_assemblies;
      term_.add_hessian(x, p, H);
    }
  }
  bool stand_in_hessian_ends() const override { return !keep_ && assemblies_ == phase_; }
  void keep_stand_in_hessian(bool keep) const override {
    keep_ = keep;
    ++verdicts;
  }
  mutable int costly_assemblies = 0, verdicts = 0;

 private:
  ScaledModelTerm stand_in_;
  const EnergyTerm& term_;
  int phase_;
  mutable int assemblies_ = 0;
  mutable bool keep_ = false;
};

// E(x) = sum_i sqrt(1 + x_i^2): its Newton step from |x_i| > 1 overshoots the minimum at 0 by far
// (-x (1 + x^2)), although the Hessian is exact: a line search cut that no model is to blame for.
class PseudoHuberTerm : public EnergyTerm {
 public:
  std::string name() const override { return "pseudo_huber"; }
  double value(const Eigen::VectorXd& x) const override { return (1 + x.array().square()).sqrt().sum(); }
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& g) const override {
    g += (x.array() / (1 + x.array().square()).sqrt()).matrix();
  }
  void add_hessian(const Eigen::VectorXd& x, HessianProjection p, HessianAssembly& H) const override {
    for (int v = 0; v < x.size() / 3; ++v) {
      Mat3 h = Mat3::Zero();
      for (int i = 0; i < 3; ++i) h(i, i) = std::pow(1 + x[3 * v + i] * x[3 * v + i], -1.5);
      H.add<1>({v}, project_hessian<3>(h, p));
    }
  }
};

NewtonSettings settings(double tol) {
  NewtonSettings s;
  s.h = 1.0;
  s.step_tolerance = tol;
  s.max_iterations = 50;
  s.projection = HessianProjection::None;
  return s;
}

TEST(Newton, ConvergesQuadraticallyNearTheMinimiser) {
  const int n = 30;
  IncrementalPotential ip;
  ip.add_term(std::make_unique<QuarticTerm>(Eigen::VectorXd::LinSpaced(3 * n, -2, 2), 0.5));
  Eigen::VectorXd x = Eigen::VectorXd::Zero(3 * n);
  HessianAssembly H;
  CholmodSolver solver;
  const NewtonReport r = newton_minimize(ip, x, settings(1e-14), H, solver);
  ASSERT_TRUE(r.converged) << r.stop_reason;
  EXPECT_LE(r.iterations, 12);
  // Once in the quadratic regime (step below 0.1), each step measure is bounded by C * previous^2.
  int checked = 0;
  for (size_t k = 1; k < r.step_measures.size(); ++k) {
    const double prev = r.step_measures[k - 1], cur = r.step_measures[k];
    if (prev < 0.1 && cur > 1e-13) {
      EXPECT_LT(cur, 5.0 * prev * prev) << "iteration " << k;
      ++checked;
    }
  }
  EXPECT_GE(checked, 2) << "quadratic regime must be observed over at least two iterations";
  EXPECT_LT(ip.gradient(x).norm(), 1e-10);
  EXPECT_EQ(solver.analyses(), 1) << "pattern is constant: one symbolic analysis";
}

TEST(Newton, FixedDofsNeverMove) {
  const int n = 4;
  IncrementalPotential ip;
  ip.add_term(std::make_unique<QuarticTerm>(Eigen::VectorXd::Constant(3 * n, 1.0), 1.0));
  std::vector<char> fixed(3 * n, 0);
  fixed[0] = fixed[1] = fixed[2] = 1;
  ip.set_fixed_dofs(fixed);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(3 * n, 5.0);
  HessianAssembly H;
  CholmodSolver solver;
  const NewtonReport r = newton_minimize(ip, x, settings(1e-10), H, solver);
  ASSERT_TRUE(r.converged) << r.stop_reason << " after " << r.iterations;
  EXPECT_EQ(x[0], 5.0);
  EXPECT_EQ(x[1], 5.0);
  EXPECT_EQ(x[2], 5.0);
  EXPECT_NEAR(x[3], 0.6823278038280193, 1e-10);  // root of x^3 + x - 1
}

TEST(Newton, StallAtRoundOffStopsAsNoDescentInsteadOfLooping) {
  // A tolerance far below what the potential's round-off can resolve (|E| ~ 500, so steps below
  // ~1e-7 change E by less than one ulp): Newton must stop, say why, and not burn its iterations.
  IncrementalPotential ip;
  ip.add_term(std::make_unique<QuarticTerm>(Eigen::VectorXd::Constant(12, 1.0), 1.0));
  std::vector<char> fixed(12, 0);
  fixed[0] = fixed[1] = fixed[2] = 1;
  ip.set_fixed_dofs(fixed);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(12, 5.0);
  HessianAssembly H;
  CholmodSolver solver;
  const NewtonReport r = newton_minimize(ip, x, settings(1e-30), H, solver);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.stop_reason, "no_descent");
  EXPECT_LT(r.iterations, 50);
  EXPECT_NEAR(x[3], 0.6823278038280193, 1e-6);
}

TEST(Newton, MaxIterationsIsReportedNotHidden) {
  IncrementalPotential ip;
  ip.add_term(std::make_unique<QuarticTerm>(Eigen::VectorXd::Constant(3, 1.0), 1.0));
  Eigen::VectorXd x = Eigen::VectorXd::Constant(3, 50.0);
  HessianAssembly H;
  CholmodSolver solver;
  NewtonSettings s = settings(1e-14);
  s.max_iterations = 2;
  const NewtonReport r = newton_minimize(ip, x, s, H, solver);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.stop_reason, "max_iterations");
  EXPECT_EQ(r.iterations, 2);
}

TEST(Newton, TheTangentialTestKeepsIteratingUntilTheContactsStepIsBelowItsOwnTolerance) {
  IncrementalPotential ip;
  ip.add_term(std::make_unique<QuarticTerm>(Eigen::VectorXd::LinSpaced(12, -2, 2), 0.5));
  HessianAssembly H;
  CholmodSolver solver;
  Eigen::VectorXd loose_x = Eigen::VectorXd::Zero(12);
  const NewtonReport loose = newton_minimize(ip, loose_x, settings(1e-2), H, solver);
  ASSERT_TRUE(loose.converged) << loose.stop_reason;
  EXPECT_TRUE(loose.tangential_measures.empty());

  // "Contact" on dof 0 only: its step must fall below 1e-10 while the rest stops at 1e-2.
  NewtonSettings s = settings(1e-2);
  s.tangential_step = [](const Eigen::VectorXd& p) { return std::abs(p[0]); };
  s.tangential_tolerance = 1e-10;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(12);
  const NewtonReport tight = newton_minimize(ip, x, s, H, solver);
  ASSERT_TRUE(tight.converged) << tight.stop_reason;
  EXPECT_GT(tight.iterations, loose.iterations);
  ASSERT_FALSE(tight.tangential_measures.empty());
  EXPECT_LT(tight.tangential_measures.back(), 1e-10);
  for (size_t k = 0; k + 1 < tight.tangential_measures.size(); ++k)
    EXPECT_GE(tight.tangential_measures[k], 1e-10) << "an earlier passing test would have stopped";
  // Checked only where the step test passed: fewer entries than iterations.
  EXPECT_LE(tight.tangential_measures.size(), static_cast<size_t>(tight.iterations));
  EXPECT_LT(std::abs(ip.gradient(x)[0]), 1e-8);
}

// Newton from `start` with `plain` settings and again with model-curvature probes (10 conjugate-
// gradient iterations to `tolerance`); both must converge.
struct PlainAndProbing {
  NewtonReport plain, probing;
  Eigen::VectorXd a, b;  // the minimisers reached
  PlainAndProbing(const IncrementalPotential& ip, const Eigen::VectorXd& start, const NewtonSettings& settings,
                  double tolerance)
      : a(start), b(start) {
    NewtonSettings with_probes = settings;
    with_probes.model_curvature_iterations = 10;
    with_probes.model_curvature_tolerance = tolerance;
    HessianAssembly H;
    CholmodSolver solver;
    plain = newton_minimize(ip, a, settings, H, solver);
    probing = newton_minimize(ip, b, with_probes, H, solver);
    EXPECT_TRUE(plain.converged) << plain.stop_reason;
    EXPECT_TRUE(probing.converged) << probing.stop_reason;
  }
};

// A model Hessian at 0.3 of the true curvature: every full step goes more than three times too far,
// the line search cuts it, and Newton converges linearly (measured: 36 iterations, 36 cuts). The
// probe finds the ratio (about 3.3, outside 1.5x), takes the refined step and refines every later
// step: Newton's quadratic rate comes back (measured: 6 iterations).
TEST(Newton, AModelHessianThatUnderestimatesTheCurvatureIsProbedAndItsStepsRefined) {
  Eigen::VectorXd c(6);
  c << 1.5, -0.7, 2.0, 0.3, -1.1, 0.9;
  IncrementalPotential ip;
  ip.add_term(std::make_unique<ScaledModelTerm>(std::make_unique<QuarticTerm>(c, 2.0), 0.3));
  NewtonSettings plain = settings(1e-6);
  plain.max_iterations = 200;
  const PlainAndProbing run(ip, Eigen::VectorXd::Zero(6), plain, 1e-3);
  const NewtonReport &ra = run.plain, &rb = run.probing;
  const Eigen::VectorXd &a = run.a, &b = run.b;
  EXPECT_EQ(ra.curvature_probes, 0) << "off unless asked for";
  EXPECT_EQ(ra.exact_curvature_iterations, 0);
  EXPECT_GE(ra.line_search_cuts, ra.iterations - 1) << "the model's full steps overshoot";
  EXPECT_EQ(rb.curvature_probes, 1) << "once the model is found wrong, steps are refined before their trial";
  EXPECT_GE(rb.exact_curvature_iterations, rb.iterations - 1);
  EXPECT_GE(ra.iterations, 15);
  EXPECT_LE(rb.iterations, 8) << rb.iterations << " against " << ra.iterations;
  EXPECT_LT((a - b).lpNorm<Eigen::Infinity>(), 1e-6) << "both reach the same minimiser";
}

// An exact Hessian whose full steps still fail (the pseudo-Huber overshoot): the probe measures the
// true curvature along the step equal to the model's, blames the nonlinearity and leaves the step to
// the line search, so every iterate is the one an unprobed Newton takes, bit for bit; and the solve
// probes no more, although later steps are cut too.
TEST(Newton, AStepCutForNonlinearityFartherAlongIsNotBlamedOnAnExactModel) {
  IncrementalPotential ip;
  ip.add_term(std::make_unique<PseudoHuberTerm>());
  Eigen::VectorXd start(3);
  start << 3.0, -2.5, 1.8;
  const PlainAndProbing run(ip, start, settings(1e-10), 0.1);
  const NewtonReport &ra = run.plain, &rb = run.probing;
  const Eigen::VectorXd &a = run.a, &b = run.b;
  // The first iteration alone, to show that later iterations are cut too.
  NewtonSettings one = settings(1e-10);
  one.max_iterations = 1;
  Eigen::VectorXd first = start;
  HessianAssembly H;
  CholmodSolver solver;
  const NewtonReport r1 = newton_minimize(ip, first, one, H, solver);
  EXPECT_GE(r1.line_search_cuts, 1) << "the full step from |x| > 1 overshoots";
  EXPECT_GT(ra.line_search_cuts, r1.line_search_cuts) << "later steps are cut too";
  EXPECT_EQ(rb.curvature_probes, 1) << "one probe that finds the model right ends the probing";
  EXPECT_EQ(rb.iterations, ra.iterations);
  EXPECT_EQ(rb.line_search_cuts, ra.line_search_cuts);
  EXPECT_TRUE(a == b) << "the probes changed no step";
}

// A stand-in Hessian phase of two assemblies, then the exact Hessian. Newton with model probes
// measures the stand-in along its step when its phase ends: at 1.05x the true curvature (ratio
// 0.95, within 1.1x) it keeps the stand-in for the whole solve, and no costlier Hessian is
// assembled; at 3x (ratio 0.33, a stand-in too stiff) it lets it go, as Newton without probes does.
TEST(Newton, AStandInHessianIsKeptPastItsPhaseOnlyWhereTheTrueCurvatureAlongItsStepMatchesIt) {
  Eigen::VectorXd c(6);
  c << 1.5, -0.7, 2.0, 0.3, -1.1, 0.9;
  struct Run {
    NewtonReport report;
    int costly = 0, verdicts = 0;
  };
  const auto run = [&](double scale, int probe_iterations) {
    IncrementalPotential ip;
    auto term = std::make_unique<StandInPhaseTerm>(std::make_unique<QuarticTerm>(c, 2.0), scale, 2);
    const StandInPhaseTerm& phase = *term;
    ip.add_term(std::move(term));
    NewtonSettings s = settings(1e-6);  // a linear rate of 0.05 per iterate would meet round-off at 1e-10
    s.model_curvature_iterations = probe_iterations;
    Eigen::VectorXd x = Eigen::VectorXd::Zero(6);
    HessianAssembly H;
    CholmodSolver solver;
    Run out;
    out.report = newton_minimize(ip, x, s, H, solver);
    EXPECT_TRUE(out.report.converged) << "scale " << scale << ": " << out.report.stop_reason;
    out.costly = phase.costly_assemblies;
    out.verdicts = phase.verdicts;
    return out;
  };
  const Run close = run(1.05, 10), stiff = run(3.0, 10), unprobed = run(1.05, 0);
  EXPECT_EQ(unprobed.verdicts, 0) << "no probes, no verdicts";
  EXPECT_EQ(unprobed.report.curvature_probes, 0);
  EXPECT_GE(unprobed.report.iterations, 4) << "the solve outlasts the stand-in's phase";
  EXPECT_EQ(unprobed.costly, unprobed.report.iterations - 2) << "every iterate after the phase";

  EXPECT_EQ(close.report.curvature_probes, 1) << "probed once, when the phase ends";
  EXPECT_EQ(close.verdicts, 1);
  EXPECT_EQ(close.costly, 0) << "the stand-in was kept";
  EXPECT_GE(close.report.iterations, 4);

  EXPECT_EQ(stiff.report.curvature_probes, 1);
  EXPECT_EQ(stiff.verdicts, 1);
  EXPECT_EQ(stiff.costly, stiff.report.iterations - 2) << "let go: the costlier Hessian from the next iterate on";
}

}  // namespace
}  // namespace pd

namespace pd {
namespace {

IncrementalPotential double_well_beside_quartic() {
  IncrementalPotential ip;
  ip.add_term(std::make_unique<DoubleWellTerm>());
  // Quartic x^4/4 + 0.25 x^2: adds 3 x^2 + 0.5 to each diagonal entry, so the exact sum is
  // indefinite where 6 x^2 - 0.5 < 0, |x| < 0.289.
  ip.add_term(std::make_unique<QuarticTerm>(Eigen::VectorXd::Zero(6), 0.5));
  return ip;
}

TEST(Newton, ExactFirstFallsBackToClampOnlyWhileTheExactHessianIsIndefinite) {
  const IncrementalPotential ip = double_well_beside_quartic();
  NewtonSettings s = settings(1e-7);  // above what the potential's round-off can resolve
  s.projection = HessianProjection::ExactFirst;
  Eigen::VectorXd x(6);
  x << 0.05, 0.9, -0.1, 1.2, 0.2, -0.8;  // dofs 0, 2, 4 start in the indefinite region
  HessianAssembly H;
  CholmodSolver solver;
  const NewtonReport r = newton_minimize(ip, x, s, H, solver);
  ASSERT_TRUE(r.converged) << r.stop_reason;
  // The first iterate is indefinite; near the minimiser (|x_i| near 1) the exact sum is positive
  // definite again, so not every iteration falls back.
  EXPECT_GE(r.projection_fallbacks, 1);
  EXPECT_GE(r.exact_hessians, 1) << "the exact Hessian must come back once it is positive definite";
  EXPECT_LE(r.exact_hessians + r.projection_fallbacks, r.iterations);
  EXPECT_EQ(solver.last_shift(), 0.0) << "the clamped Hessian needed no damping";
  EXPECT_LT(ip.gradient(x).norm(), 1e-7);
}

TEST(Newton, ExactFirstOnAPositiveDefiniteSystemIsTheExactNewtonBitForBit) {
  const IncrementalPotential ip = double_well_beside_quartic();
  Eigen::VectorXd start(6);
  start << 0.9, 1.1, -0.7, 1.2, 0.6, -0.8;  // every dof where the exact sum is positive definite
  NewtonSettings exact_first = settings(1e-7), exact = settings(1e-7);
  exact_first.projection = HessianProjection::ExactFirst;
  exact.projection = HessianProjection::None;
  Eigen::VectorXd a = start, b = start;
  HessianAssembly H;
  CholmodSolver solver;
  const NewtonReport ra = newton_minimize(ip, a, exact_first, H, solver);
  const NewtonReport rb = newton_minimize(ip, b, exact, H, solver);
  ASSERT_TRUE(ra.converged && rb.converged);
  EXPECT_EQ(ra.projection_fallbacks, 0);
  EXPECT_EQ(ra.exact_hessians, ra.iterations);
  EXPECT_EQ(rb.exact_hessians, 0) << "counted under exact_first only";
  EXPECT_EQ(ra.iterations, rb.iterations);
  EXPECT_EQ(ra.step_measures, rb.step_measures);
  EXPECT_TRUE(a == b);
}

// After a capped step (max_step < 1, as CCD near contact) the next iterate is clamped without
// trying the exact Hessian: with every step capped at half, only the first iterate (no step before
// it) tries the exact Hessian, and on an indefinite start that one try is the only fallback.
TEST(Newton, ExactFirstClampsEveryIterateThatFollowsACappedStep) {
  for (const bool indefinite_start : {false, true}) {
    IncrementalPotential ip = double_well_beside_quartic();
    ip.add_term(step_cap(0.5));
    Eigen::VectorXd x(6);
    if (indefinite_start) x << 0.05, 0.9, -0.1, 1.2, 0.2, -0.8;
    else x << 0.9, 1.1, -0.7, 1.2, 0.6, -0.8;
    NewtonSettings s = settings(1e-6);
    s.projection = HessianProjection::ExactFirst;
    HessianAssembly H;
    CholmodSolver solver;
    const NewtonReport r = newton_minimize(ip, x, s, H, solver);
    SCOPED_TRACE(indefinite_start ? "indefinite start" : "positive-definite start");
    ASSERT_TRUE(r.converged) << r.stop_reason;
    ASSERT_GE(r.iterations, 5) << "halved steps converge linearly: several iterates to check";
    EXPECT_EQ(r.exact_hessians, indefinite_start ? 0 : 1);
    EXPECT_EQ(r.projection_fallbacks, indefinite_start ? 1 : 0);
  }
}

// A saddle: double well beside x^4/4 + 0.45 x^2 (k = 0.9), every dof starting near 0, where the
// exact Hessian (6 x^2 - 0.1 per dof) is indefinite and the clamped one is 3 x^2 + 0.9. Each clamped
// step multiplies x by about 1 / k = 1.11, so clamped Newton needs about ln(0.22 / 1e-3) / ln(1.11)
// = 51 iterations to come near the minimiser |x| = sqrt((1 - k) / 2) = 0.224. Measured: Clamp 113
// iterations in all (it also converges linearly near the minimiser), ExactFirst 57 without the
// extensions (kGrowthsBeforeExtension set out of reach) and 17 with them.
IncrementalPotential saddle() {
  IncrementalPotential ip;
  ip.add_term(std::make_unique<DoubleWellTerm>());
  ip.add_term(std::make_unique<QuarticTerm>(Eigen::VectorXd::Zero(6), 0.9));
  return ip;
}

Eigen::VectorXd near_the_saddle() {
  Eigen::VectorXd x(6);
  x << 1e-3, -1.2e-3, 0.8e-3, 1.1e-3, -0.9e-3, 1e-3;
  return x;
}

TEST(Newton, ExactFirstExtendsGrowingClampedStepsToLeaveASaddle) {
  const IncrementalPotential ip = saddle();
  NewtonSettings exact_first = settings(1e-7), clamp = settings(1e-7);
  exact_first.projection = HessianProjection::ExactFirst;
  clamp.projection = HessianProjection::Clamp;
  exact_first.max_iterations = clamp.max_iterations = 200;
  Eigen::VectorXd a = near_the_saddle(), b = near_the_saddle();
  HessianAssembly H;
  CholmodSolver solver;
  const NewtonReport ra = newton_minimize(ip, a, exact_first, H, solver);
  const NewtonReport rb = newton_minimize(ip, b, clamp, H, solver);
  ASSERT_TRUE(ra.converged) << ra.stop_reason;
  ASSERT_TRUE(rb.converged) << rb.stop_reason;
  EXPECT_GE(ra.extended_steps, 1);
  EXPECT_EQ(rb.extended_steps, 0) << "clamp keeps its steps as they were";
  EXPECT_GE(rb.iterations, 40) << "the clamped escape is as slow as the comment says";
  EXPECT_LE(3 * ra.iterations, rb.iterations) << ra.iterations << " against " << rb.iterations;
  // Both reach a minimiser: every dof at +-sqrt(0.05), the sign it started with.
  const Eigen::VectorXd start = near_the_saddle();
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(a[i], std::copysign(std::sqrt(0.05), start[i]), 1e-6) << "dof " << i;
    EXPECT_NEAR(b[i], std::copysign(std::sqrt(0.05), start[i]), 1e-6) << "dof " << i;
  }
}

// An extension is admissible only as far as max_step allows: with every step capped at `reach` per
// dof, no accepted iterate moves a dof further, and the extensions still happen below that cap.
TEST(Newton, ExtendedStepsStayWithinTheStepBound) {
  IncrementalPotential ip = saddle();
  const double reach = 0.02;
  ip.add_term(reach_cap(reach));
  NewtonSettings s = settings(1e-7);
  s.projection = HessianProjection::ExactFirst;
  s.max_iterations = 200;
  Eigen::VectorXd x = near_the_saddle();
  Eigen::VectorXd last = x;
  double longest_move = 0.0;
  int accepted = 0;
  s.after_iteration = [&](const Eigen::VectorXd& next) {
    longest_move = std::max(longest_move, (next - last).lpNorm<Eigen::Infinity>());
    last = next;
    ++accepted;
    return false;
  };
  HessianAssembly H;
  CholmodSolver solver;
  const NewtonReport r = newton_minimize(ip, x, s, H, solver);
  ASSERT_TRUE(r.converged) << r.stop_reason;
  ASSERT_GT(accepted, 0);
  EXPECT_GE(r.extended_steps, 1);
  EXPECT_LE(longest_move, reach * (1 + 1e-12));
  EXPECT_GT(longest_move, 0.5 * reach) << "the cap was reached, so it was tested";
}

// A soft but stable mode that the clamp stiffens, beside a saddle that keeps the exact Hessian
// indefinite at every iterate. Vertex 0: the form [[1, 2], [2, 1]] (eigenvalues 3 and -1) plus
// x^4/4 + 0.6 |x - c|^2; the exact curvature along (1, -1) is 0.2 + 3 x^2, the clamped one 1.2 + 3 x^2,
// so with c small (the minimiser near 0.06 (1, -1)) clamped steps shrink that mode's error by only
// about 1 - 0.21 / 1.21 per iterate. Vertex 1: the form -2 on its first dof beside the same quartic:
// curvature -0.8 there at x = 0, where its gradient is zero and it stays. Every iterate therefore
// falls back to the clamp. Measured: 74 clamped iterations, 5 with the refinement (9 CG iterations).
TEST(Newton, ExactCurvatureRefinementMendsTheClampedStepOfASoftStableMode) {
  Mat3 pair = Mat3::Zero(), saddle_dof = Mat3::Zero();
  pair(0, 0) = pair(1, 1) = 1.0;
  pair(0, 1) = pair(1, 0) = 2.0;
  saddle_dof(0, 0) = -2.0;
  Eigen::VectorXd c = Eigen::VectorXd::Zero(6);
  c << 0.01, -0.01, 0.5, 0.0, 0.3, -0.2;
  IncrementalPotential ip;
  ip.add_term(std::make_unique<FixedFormTerm>(std::vector<Mat3>{pair, saddle_dof}));
  ip.add_term(std::make_unique<QuarticTerm>(c, 1.2));

  NewtonSettings plain = settings(1e-8);
  plain.projection = HessianProjection::ExactFirst;
  plain.max_iterations = 200;
  NewtonSettings refined = plain;
  refined.exact_curvature_iterations = 10;
  Eigen::VectorXd a = Eigen::VectorXd::Zero(6), b = Eigen::VectorXd::Zero(6);
  HessianAssembly H;
  CholmodSolver solver;
  const NewtonReport ra = newton_minimize(ip, a, plain, H, solver);
  const NewtonReport rb = newton_minimize(ip, b, refined, H, solver);
  ASSERT_TRUE(ra.converged) << ra.stop_reason;
  ASSERT_TRUE(rb.converged) << rb.stop_reason;
  EXPECT_EQ(ra.projection_fallbacks, ra.iterations) << "the saddle dof keeps every exact Hessian indefinite";
  EXPECT_EQ(rb.projection_fallbacks, rb.iterations);
  EXPECT_EQ(ra.exact_curvature_iterations, 0) << "off unless asked for";
  EXPECT_GE(rb.exact_curvature_iterations, rb.iterations - 1);
  EXPECT_GE(ra.iterations, 40) << "the clamped creep is as slow as the comment says";
  EXPECT_LE(rb.iterations, 8) << rb.iterations << " against " << ra.iterations;
  EXPECT_LT((a - b).lpNorm<Eigen::Infinity>(), 1e-6) << "both reach the same minimiser";
  EXPECT_EQ(b[3], 0.0) << "the saddle dof has no gradient and stays";
}

}  // namespace
}  // namespace pd
