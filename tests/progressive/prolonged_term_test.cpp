// The finest level's elasticity felt through the shell prolongation (progressive/prolonged_term.h):
// derivatives of the exact and the frozen-offset energy, the Galerkin Hessian against a dense
// J^T H J (U^T H U), the rest state, rigid motions (value, net force and torque), the coarse
// stand-in Hessian, and one term holding several energies (their sum, each named, step bounds).
#include "progressive/prolonged_term.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/shapes.h"
#include "geometry/topology.h"
#include "hierarchy/scene_hierarchy.h"
#include "physics/bending_hinge.h"
#include "physics/membrane_neo_hookean.h"
#include "progressive/test_scenes.h"
#include "support/term_eval.h"

namespace pd {
namespace {

// A 0.5 m cotton sheet (10 x 10 cells, 121 vertices) with a two-level hierarchy; P^0 maps level 0
// (about 30 vertices) to it.
struct Sheet {
  Scene scene;
  SceneHierarchy h;
  Sheet() {
    scene = test::make_scene(0.01, 1, Vec3(0, -9.81, 0));
    scene.objects.push_back(test::make_object("sheet", make_rectangle(0.5, 0.5, 10, 10), test::cotton()));
    scene.hierarchy.levels = 2;
    h = build_scene_hierarchy(scene);
  }
  const ShellProlongation& P() const { return *h.levels[0].to_finest_prolongation; }
  const TriMesh& fine() const { return h.levels[1].rest; }
  const TriMesh& coarse() const { return h.levels[0].rest; }
  std::unique_ptr<EnergyTerm> membrane(const TriMesh& m) const {
    const Material& mat = scene.objects[0].material;
    return std::make_unique<NeoHookeanMembrane>(
        m.F, m.V, MembraneMaterialParams::from(mat.youngs_modulus, mat.poisson_ratio, mat.thickness));
  }
  std::unique_ptr<EnergyTerm> bending(const TriMesh& m) const {
    return std::make_unique<HingeBending>(build_topology(m).hinges, m.V, scene.objects[0].material.bending_rigidity());
  }
  // Level 0 bent out of its plane and stretched a little: every membrane and hinge is active.
  Eigen::VectorXd deformed() const {
    Positions X = coarse().V;
    for (int i = 0; i < X.rows(); ++i) {
      const double u = X(i, 0), v = X(i, 1);
      X.row(i) = Vec3(1.02 * u, v + 0.01 * std::sin(7 * u), 0.04 * std::sin(5 * u + 3 * v)).transpose();
    }
    return stacked(X);
  }
};

TEST(ProlongedTerm, ExactGradientMatchesFiniteDifferencesOfTheFullProlongedEnergy) {
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V));
  const Eigen::VectorXd x = s.deformed();
  for (const bool bend : {false, true}) {
    SCOPED_TRACE(bend ? "bending" : "membrane");
    const ProlongedTerm term(bend ? s.bending(s.fine()) : s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
    ASSERT_GT(term.value(x), 0.0);
    // The Gauss-Newton Hessian drops grad Psi . d2a/dx2, so only the gradient is exact here (the
    // Hessian is checked at rest below and against J^T H J in the next test).
    const test::TermFdCheck c = test::check_term_derivatives(term, x);
    EXPECT_GT(c.gradient.comparisons, 0);
    EXPECT_GE(c.gradient.steps_within(1e-6), 2) << "best " << c.gradient.best_rel_error;
  }
}

// Where the fine forces vanish (the rest state), the dropped term is zero and J^T H J is the exact
// Hessian; with a pressure-free rest state both membrane and bending are at rest there.
TEST(ProlongedTerm, ExactGaussNewtonHessianMatchesFiniteDifferencesAtRest) {
  Sheet s;
  const Eigen::VectorXd rest = stacked(s.coarse().V);
  auto state = std::make_shared<ProlongationState>(s.P(), rest);
  // A tiny wave keeps the check away from the flat sheet's singular bending Hessian while grad Psi
  // stays negligible against H dx.
  const Eigen::VectorXd x = rest + 1e-7 * test::wavy(rest.size(), 0.9, 0.3);
  for (const bool bend : {false, true}) {
    SCOPED_TRACE(bend ? "bending" : "membrane");
    const ProlongedTerm term(bend ? s.bending(s.fine()) : s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
    test::expect_derivatives_match(test::check_term_derivatives(term, x), 1e-4, 1e-4);
  }
}

TEST(ProlongedTerm, FrozenOffsetEnergyDerivativesMatchFiniteDifferences) {
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V), ProlongedGradient::Frozen);
  const Eigen::VectorXd x = s.deformed();
  ASSERT_TRUE(state->refresh(x));
  for (const bool bend : {false, true}) {
    SCOPED_TRACE(bend ? "bending" : "membrane");
    const ProlongedTerm term(bend ? s.bending(s.fine()) : s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
    ASSERT_GT(term.value(x), 0.0);
    test::expect_derivatives_match(test::check_term_derivatives(term, x), 1e-6, 1e-5);
  }
}

TEST(ProlongedTerm, GradientAndGalerkinHessianAreJTransposeTimesTheFineOnes) {
  for (const ProlongedGradient mode : {ProlongedGradient::Exact, ProlongedGradient::Frozen}) {
  SCOPED_TRACE(mode == ProlongedGradient::Exact ? "exact" : "frozen");
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V), mode);
  const Eigen::VectorXd x = s.deformed();
  EXPECT_EQ(state->refresh(x), mode == ProlongedGradient::Frozen);
  const Eigen::VectorXd y = state->fine_positions(x);
  EXPECT_LT((as_rows(y) - s.P().apply(as_rows(x))).cwiseAbs().maxCoeff(), 1e-14);
  // Exact: the full Jacobian; frozen: U (x) I3.
  const Eigen::MatrixXd U = mode == ProlongedGradient::Exact ? Eigen::MatrixXd(s.P().jacobian(as_rows(x)))
                                                             : Eigen::MatrixXd(state->U());
  for (const bool bend : {false, true}) {
    SCOPED_TRACE(bend ? "bending" : "membrane");
    const auto fine = bend ? s.bending(s.fine()) : s.membrane(s.fine());
    const ProlongedTerm term(bend ? s.bending(s.fine()) : s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
    EXPECT_DOUBLE_EQ(term.value(x), fine->value(y));
    const Eigen::VectorXd g = U.transpose() * test::term_gradient(*fine, y);
    EXPECT_LE((test::term_gradient(term, x) - g).norm(), 1e-12 * g.norm());
    for (const HessianProjection p : {HessianProjection::None, HessianProjection::Clamp}) {
      const Eigen::MatrixXd H = U.transpose() * test::term_hessian(*fine, y, p) * U;
      EXPECT_LE((test::term_hessian(term, x, p) - H).norm(), 1e-10 * H.norm());
    }
  }
  }
}

TEST(ProlongedTerm, RestStateHasNoEnergyAndNoForce) {
  Sheet s;
  const Eigen::VectorXd rest = stacked(s.coarse().V);
  auto state = std::make_shared<ProlongationState>(s.P(), rest);
  // P(rest_0) = rest_L to round-off, where the fine energies and forces vanish.
  EXPECT_LT((as_rows(state->fine_positions(rest)) - s.fine().V).cwiseAbs().maxCoeff(), 1e-12);
  const ProlongedTerm membrane(s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
  const ProlongedTerm bending(s.bending(s.fine()), state, ProlongedHessian::Galerkin);
  EXPECT_LT(std::abs(membrane.value(rest)), 1e-12);
  EXPECT_LT(std::abs(bending.value(rest)), 1e-12);
  EXPECT_LT(test::term_gradient(membrane, rest).norm(), 1e-9);
  EXPECT_LT(test::term_gradient(bending, rest).norm(), 1e-9);
}

TEST(ProlongedTerm, ValueIsUnchangedByARigidMotionOnceTheOffsetsFollow) {
  for (const ProlongedGradient mode : {ProlongedGradient::Exact, ProlongedGradient::Frozen}) {
    SCOPED_TRACE(mode == ProlongedGradient::Exact ? "exact" : "frozen");
    Sheet s;
    auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V), mode);
    const ProlongedTerm membrane(s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
    const ProlongedTerm bending(s.bending(s.fine()), state, ProlongedHessian::Galerkin);
    const Eigen::VectorXd x = s.deformed();
    state->refresh(x);  // frozen only (exact offsets always follow)
    const double em = membrane.value(x), eb = bending.value(x);
    const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, -2, 0.5).normalized()).toRotationMatrix();
    Positions moved = as_rows(x);
    for (int i = 0; i < moved.rows(); ++i) moved.row(i) = (R * moved.row(i).transpose() + Vec3(0.3, -1, 2)).transpose();
    state->refresh(stacked(moved));
    EXPECT_NEAR(membrane.value(stacked(moved)), em, 1e-10 * em);
    EXPECT_NEAR(bending.value(stacked(moved)), eb, 1e-10 * eb);
  }
}

// Internal forces of a free body have zero net force and zero net torque. The exact prolonged
// forces -J^T grad Psi do (Psi(P(x)) is rigid-invariant); the frozen ones -U^T grad Psi have the net
// torque -sum_i A_i x f_i (docs/stress.md, finding 2): this test tells the two apart.
TEST(ProlongedTerm, ExactForcesHaveNoNetTorqueWhereFrozenOffsetForcesDo) {
  Sheet s;
  const Eigen::VectorXd x = s.deformed();
  double torque_ratio[2] = {0, 0};  // |net torque| / sum_j |x_j - c| |F_j|, exact then frozen
  for (const ProlongedGradient mode : {ProlongedGradient::Exact, ProlongedGradient::Frozen}) {
    SCOPED_TRACE(mode == ProlongedGradient::Exact ? "exact" : "frozen");
    auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V), mode);
    state->refresh(x);
    const ProlongedTerm membrane(s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
    const ProlongedTerm bending(s.bending(s.fine()), state, ProlongedHessian::Galerkin);
    const Eigen::VectorXd F = -(test::term_gradient(membrane, x) + test::term_gradient(bending, x));
    const Positions Xr = as_rows(x), Fr = as_rows(F);
    const Vec3 c = Xr.colwise().mean().transpose();
    Vec3 net_force = Vec3::Zero(), net_torque = Vec3::Zero();
    double force_scale = 0, torque_scale = 0;
    for (int j = 0; j < Xr.rows(); ++j) {
      const Vec3 f = Fr.row(j).transpose(), r = Xr.row(j).transpose() - c;
      net_force += f;
      net_torque += r.cross(f);
      force_scale += f.norm();
      torque_scale += r.norm() * f.norm();
    }
    ASSERT_GT(force_scale, 0.0);
    EXPECT_LT(net_force.norm(), 1e-9 * force_scale);  // U's rows sum to 1: both modes
    torque_ratio[mode == ProlongedGradient::Exact ? 0 : 1] = net_torque.norm() / torque_scale;
  }
  EXPECT_LT(torque_ratio[0], 1e-9);
  EXPECT_GT(torque_ratio[1], 1e-4) << "the frozen-offset torque this test relies on vanished";
}

TEST(ProlongedTerm, CoarseHessianIsTheStandInsWhileValueAndGradientStayProlonged) {
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V));
  const Eigen::VectorXd x = s.deformed();
  const ProlongedTerm galerkin(s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
  const ProlongedTerm coarse(s.membrane(s.fine()), state, ProlongedHessian::Coarse, s.membrane(s.coarse()));
  const auto stand_in = s.membrane(s.coarse());
  EXPECT_EQ(coarse.value(x), galerkin.value(x));
  EXPECT_TRUE(test::term_gradient(coarse, x) == test::term_gradient(galerkin, x));
  EXPECT_TRUE(test::term_hessian(coarse, x, HessianProjection::Clamp) ==
              test::term_hessian(*stand_in, x, HessianProjection::Clamp));
  EXPECT_EQ(coarse.name(), "membrane");
}

// A fine term that records the direction it was asked about and bounds every step at 0.25.
class StepBound : public EnergyTerm {
 public:
  std::string name() const override { return "bound"; }
  double value(const Eigen::VectorXd&) const override { return 0.0; }
  void add_gradient(const Eigen::VectorXd&, Eigen::VectorXd&) const override {}
  void add_hessian(const Eigen::VectorXd&, HessianProjection, HessianAssembly&) const override {}
  double max_step(const Eigen::VectorXd&, const Eigen::VectorXd& dy) const override {
    asked = dy;
    return 0.25;
  }
  mutable Eigen::VectorXd asked;
};

std::vector<std::unique_ptr<EnergyTerm>> terms(std::unique_ptr<EnergyTerm> a, std::unique_ptr<EnergyTerm> b) {
  std::vector<std::unique_ptr<EnergyTerm>> out;
  out.push_back(std::move(a));
  out.push_back(std::move(b));
  return out;
}

// One prolonged term holding membrane and bending (what a coarse level builds) is, to round-off,
// the sum of the two single ones, for each Hessian mode that uses the fine terms; each energy keeps
// its own name and exact value in named_values (the frame statistics); the coarse mode sums the
// stand-ins' Hessians.
TEST(ProlongedTerm, OneTermForSeveralEnergiesIsTheirSumAndNamesEachValue) {
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V));
  const Eigen::VectorXd x = s.deformed();
  const Eigen::VectorXd y = state->fine_positions(x);
  const ProlongedTerm membrane(s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
  const ProlongedTerm bending(s.bending(s.fine()), state, ProlongedHessian::Galerkin);
  const ProlongedTerm both(terms(s.membrane(s.fine()), s.bending(s.fine())), state, ProlongedHessian::Galerkin);
  EXPECT_EQ(both.name(), "membrane+bending");
  const double sum = membrane.value(x) + bending.value(x);
  EXPECT_LE(std::abs(both.value(x) - sum), 1e-14 * std::abs(sum));
  const auto named = both.named_values(x);
  ASSERT_EQ(named.size(), 2u);
  EXPECT_EQ(named[0].first, "membrane");
  EXPECT_EQ(named[0].second, s.membrane(s.fine())->value(y));
  EXPECT_EQ(named[1].first, "bending");
  EXPECT_EQ(named[1].second, s.bending(s.fine())->value(y));
  const Eigen::VectorXd g = test::term_gradient(membrane, x) + test::term_gradient(bending, x);
  EXPECT_LE((test::term_gradient(both, x) - g).norm(), 1e-13 * g.norm());
  for (const HessianProjection p : {HessianProjection::None, HessianProjection::Clamp}) {
    const Eigen::MatrixXd H = test::term_hessian(membrane, x, p) + test::term_hessian(bending, x, p);
    EXPECT_LE((test::term_hessian(both, x, p) - H).norm(), 1e-13 * H.norm());
  }
  const ProlongedTerm coarse(terms(s.membrane(s.fine()), s.bending(s.fine())), state, ProlongedHessian::Coarse,
                             terms(s.membrane(s.coarse()), s.bending(s.coarse())));
  const Eigen::MatrixXd stand_ins = test::term_hessian(*s.membrane(s.coarse()), x, HessianProjection::Clamp) +
                                    test::term_hessian(*s.bending(s.coarse()), x, HessianProjection::Clamp);
  EXPECT_LE((test::term_hessian(coarse, x, HessianProjection::Clamp) - stand_ins).norm(), 1e-13 * stand_ins.norm());
  EXPECT_THROW(ProlongedTerm(terms(s.membrane(s.fine()), nullptr), state, ProlongedHessian::Galerkin),
               std::invalid_argument);
  EXPECT_THROW(ProlongedTerm(std::vector<std::unique_ptr<EnergyTerm>>{}, state, ProlongedHessian::Galerkin),
               std::invalid_argument);
}

// Membrane and bending never bound a step, so the term does not compute J dx for them; a fine term
// that may bound it is asked along J dx, and the smallest bound wins.
TEST(ProlongedTerm, MaxStepAsksTheFineTermsAlongJdxOnlyWhenOneMayBoundIt) {
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V));
  const Eigen::VectorXd x = s.deformed();
  const Eigen::VectorXd dx = test::wavy(x.size(), 0.7, 0.3);
  const ProlongedTerm shell(terms(s.membrane(s.fine()), s.bending(s.fine())), state, ProlongedHessian::Galerkin);
  EXPECT_FALSE(shell.may_limit_step());
  EXPECT_EQ(shell.max_step(x, dx), 1.0);
  auto bound = std::make_unique<StepBound>();
  const StepBound* seen = bound.get();
  const ProlongedTerm bounded(terms(s.membrane(s.fine()), std::move(bound)), state, ProlongedHessian::Galerkin);
  EXPECT_TRUE(bounded.may_limit_step());
  EXPECT_EQ(bounded.max_step(x, dx), 0.25);
  const Eigen::VectorXd Jdx = Eigen::MatrixXd(s.P().jacobian(as_rows(x))) * dx;
  ASSERT_EQ(seen->asked.size(), Jdx.size());
  EXPECT_LE((seen->asked - Jdx).norm(), 1e-13 * Jdx.norm());
}

// The lagged Galerkin Hessian: exact at a step's first assembly, then reused (whatever x is) until
// the kLaggedRefreshEvery-th assembly or a new step recomputes it. Each element projection keeps its
// own (exact_first alternates exact and clamped assemblies): a projection's first assembly in a
// step computes its blocks, and switching back reuses the other's while they are younger than
// kLaggedRefreshEvery assemblies of either projection.
TEST(ProlongedTerm, LaggedHessianIsGalerkinAtRefreshesAndReusedBetweenThem) {
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V));
  const Eigen::VectorXd x1 = s.deformed();
  const Eigen::VectorXd x2 = 1.01 * x1 + Eigen::VectorXd::Constant(x1.size(), 0.002);
  const ProlongedTerm galerkin(s.bending(s.fine()), state, ProlongedHessian::Galerkin);
  ProlongedTerm lagged(s.bending(s.fine()), state, ProlongedHessian::Lagged);
  const HessianProjection none = HessianProjection::None, clamp = HessianProjection::Clamp;
  const Eigen::MatrixXd at_x1 = test::term_hessian(galerkin, x1, none);
  const Eigen::MatrixXd at_x2 = test::term_hessian(galerkin, x2, none);
  ASSERT_GT((at_x1 - at_x2).norm(), 1e-3 * at_x1.norm());  // the two states must be told apart

  static_assert(kLaggedRefreshEvery >= 2, "a lagged Hessian that is never reused is the Galerkin one");
  EXPECT_TRUE(test::term_hessian(lagged, x1, none) == at_x1);  // first assembly: computed
  int reused = 0;  // assemblies at x2 that returned x1's Hessian
  for (int k = 1; k < kLaggedRefreshEvery; ++k) reused += test::term_hessian(lagged, x2, none) == at_x1;
  EXPECT_EQ(reused, kLaggedRefreshEvery - 1);
  EXPECT_TRUE(test::term_hessian(lagged, x2, none) == at_x2);  // the refresh
  EXPECT_TRUE(test::term_hessian(lagged, x1, none) == at_x2);  // reused again

  const Eigen::VectorXd v = Eigen::VectorXd::Zero(x1.size());
  lagged.begin_step({0.01, 0.01, &x1, &v});
  EXPECT_TRUE(test::term_hessian(lagged, x1, none) == at_x1);  // a new step recomputes
  const Eigen::MatrixXd clamped_at_x2 = test::term_hessian(galerkin, x2, clamp);
  ASSERT_FALSE(clamped_at_x2 == at_x2) << "the clamp must change this Hessian for the test to tell them apart";
  EXPECT_TRUE(test::term_hessian(lagged, x2, clamp) == clamped_at_x2);  // so does a projection's first use
  EXPECT_TRUE(test::term_hessian(lagged, x2, none) == at_x1);           // the exact blocks were kept
  EXPECT_TRUE(test::term_hessian(lagged, x1, clamp) == clamped_at_x2);  // and so were the clamped ones
  // Value and gradient are never lagged.
  EXPECT_EQ(lagged.value(x2), galerkin.value(x2));
  EXPECT_TRUE(test::term_gradient(lagged, x2) == test::term_gradient(galerkin, x2));
}

// Coarse-first: the stand-in's Hessian for a step's first kCoarseFirstAssemblies assemblies, then the
// lagged Galerkin one (computed at the switch, reused after it); a new step starts coarse again. Both
// phases give the assembly one stencil sequence from the first assembly on, so its pattern stays put.
// A coarse-first term on the test sheet, two states, and the Galerkin term and stand-in it stands
// between.
struct CoarseFirstSheet {
  Sheet s;
  std::shared_ptr<ProlongationState> state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V));
  Eigen::VectorXd x1 = s.deformed();
  Eigen::VectorXd x2 = 1.01 * x1 + Eigen::VectorXd::Constant(x1.size(), 0.002);
  HessianProjection clamp = HessianProjection::Clamp;
  ProlongedTerm galerkin{s.membrane(s.fine()), state, ProlongedHessian::Galerkin};
  std::unique_ptr<EnergyTerm> stand_in = s.membrane(s.coarse());
  ProlongedTerm first{s.membrane(s.fine()), state, ProlongedHessian::CoarseFirst, s.membrane(s.coarse())};
};

TEST(ProlongedTerm, CoarseFirstHessianIsTheStandInsAtAStepsStartThenTheLaggedGalerkinOnOnePattern) {
  CoarseFirstSheet c;
  auto& [s, state, x1, x2, clamp, galerkin, stand_in, first] = c;
  const Eigen::MatrixXd coarse_x1 = test::term_hessian(*stand_in, x1, clamp);
  const Eigen::MatrixXd galerkin_x2 = test::term_hessian(galerkin, x2, clamp);
  ASSERT_GT((coarse_x1 - test::term_hessian(galerkin, x1, clamp)).norm(), 1e-3 * coarse_x1.norm());

  const Eigen::VectorXd v = Eigen::VectorXd::Zero(x1.size());
  HessianAssembly assembly;  // kept across assemblies, as Newton keeps it
  std::vector<bool> pattern_changed;
  const auto assemble = [&](const Eigen::VectorXd& x) {
    assembly.begin(static_cast<int>(x.size()));
    first.add_hessian(x, clamp, assembly);
    bool changed = false;
    const Eigen::MatrixXd H = test::symmetric_from_lower(assembly.finish(&changed));
    pattern_changed.push_back(changed);
    return H;
  };
  static_assert(kCoarseFirstAssemblies >= 1, "coarse-first without a coarse assembly is the lagged Hessian");
  int checked = 0;
  for (int step = 0; step < 2; ++step) {
    first.begin_step({0.01, 0.01, &x1, &v});
    for (int k = 0; k < kCoarseFirstAssemblies; ++k) checked += assemble(x1) == coarse_x1;
    checked += assemble(x2) == galerkin_x2;  // the switch: Galerkin at x2
    checked += assemble(x1) == galerkin_x2;  // then reused
  }
  EXPECT_EQ(checked, 2 * (kCoarseFirstAssemblies + 2));
  // The union of both block lists from the very first assembly on: the pattern is set once and never
  // changes, so a run continued from stored frames (a new term) assembles the same matrices.
  ASSERT_EQ(pattern_changed.size(), 2 * static_cast<std::size_t>(kCoarseFirstAssemblies + 2));
  EXPECT_TRUE(pattern_changed[0]);
  for (std::size_t i = 1; i < pattern_changed.size(); ++i) EXPECT_FALSE(pattern_changed[i]) << "assembly " << i;
  EXPECT_THROW(ProlongedTerm(s.membrane(s.fine()), state, ProlongedHessian::CoarseFirst), std::invalid_argument);
}

// The solver's verdict on the stand-in (solver/newton.cpp): kept, the stand-in's Hessian goes on
// past kCoarseFirstAssemblies; let go, the next assembly is the Galerkin one; the next step forgets
// the verdict. The phase's end is announced exactly once per step, and never by the lagged mode.
TEST(ProlongedTerm, CoarseFirstKeepsTheStandInForTheStepWhenToldAndTurnsToGalerkinWhenLetGo) {
  CoarseFirstSheet c;
  auto& [s, state, x1, x2, clamp, galerkin, stand_in, first] = c;
  const Eigen::MatrixXd coarse_x2 = test::term_hessian(*stand_in, x2, clamp);
  const Eigen::MatrixXd galerkin_x2 = test::term_hessian(galerkin, x2, clamp);
  ASSERT_GT((coarse_x2 - galerkin_x2).norm(), 1e-3 * coarse_x2.norm());

  const Eigen::VectorXd v = Eigen::VectorXd::Zero(x1.size());
  HessianAssembly assembly;
  const auto assemble = [&](const Eigen::VectorXd& x) {
    assembly.begin(static_cast<int>(x.size()));
    first.add_hessian(x, clamp, assembly);
    return Eigen::MatrixXd(test::symmetric_from_lower(assembly.finish(nullptr)));
  };
  int checked = 0;
  for (int step = 0; step < 2; ++step) {
    first.begin_step({0.01, 0.01, &x1, &v});
    for (int k = 0; k < kCoarseFirstAssemblies; ++k) {
      checked += !first.stand_in_hessian_ends();
      assemble(x1);
    }
    checked += first.stand_in_hessian_ends();
    if (step == 0) {
      first.keep_stand_in_hessian(true);
      checked += !first.stand_in_hessian_ends();
      for (int k = 0; k < 3; ++k) checked += assemble(x2) == coarse_x2;  // kept
      first.keep_stand_in_hessian(false);
    }
    checked += assemble(x2) == galerkin_x2;  // let go, or never kept: the lagged Galerkin Hessian
    checked += !first.stand_in_hessian_ends();
  }
  EXPECT_EQ(checked, 2 * (kCoarseFirstAssemblies + 3) + 4);

  ProlongedTerm lagged(s.membrane(s.fine()), state, ProlongedHessian::Lagged, s.membrane(s.coarse()));
  lagged.begin_step({0.01, 0.01, &x1, &v});
  int announced = 0;
  for (int k = 0; k <= kCoarseFirstAssemblies; ++k) {
    announced += lagged.stand_in_hessian_ends();
    assembly.begin(static_cast<int>(x1.size()));
    lagged.add_hessian(x1, clamp, assembly);
    assembly.finish(nullptr);
  }
  EXPECT_EQ(announced, 0) << "only coarse-first has a stand-in phase";
}

TEST(ProlongedTerm, HessianNamesParseAndUnknownOnesAreRefused) {
  EXPECT_EQ(parse_prolonged_hessian("galerkin"), ProlongedHessian::Galerkin);
  EXPECT_EQ(parse_prolonged_hessian("lagged"), ProlongedHessian::Lagged);
  EXPECT_EQ(parse_prolonged_hessian("coarse"), ProlongedHessian::Coarse);
  EXPECT_EQ(parse_prolonged_hessian("coarse-first"), ProlongedHessian::CoarseFirst);
  EXPECT_THROW(parse_prolonged_hessian("Galerkin"), std::invalid_argument);
}

// A state where coarse faces collapse to lines has no prolongation: frozen offsets stay as they were,
// the exact energy is +infinity there (a line search rejects it).
TEST(ProlongedTerm, DegenerateCoarseFaceKeepsFrozenOffsetsOrHasInfiniteEnergyAndBadInputIsRefused) {
  Sheet s;
  const Eigen::VectorXd rest = stacked(s.coarse().V);
  Eigen::VectorXd flat = rest;
  for (Eigen::Index i = 0; i < flat.size(); i += 3) flat[i] = 0.0;  // every face collapses to a line
  auto frozen = std::make_shared<ProlongationState>(s.P(), rest, ProlongedGradient::Frozen);
  const Eigen::VectorXd before = frozen->fine_positions(rest);
  EXPECT_FALSE(frozen->refresh(flat));
  EXPECT_TRUE(frozen->fine_positions(rest) == before);

  auto state = std::make_shared<ProlongationState>(s.P(), rest);
  const ProlongedTerm membrane(s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
  EXPECT_TRUE(std::isinf(membrane.value(flat)));
  EXPECT_THROW(state->fine_positions(flat), DegenerateProlongationTriangle);
  EXPECT_LT(std::abs(membrane.value(rest)), 1e-12);  // a failed state leaves no stale cache behind

  EXPECT_THROW(ProlongedTerm(nullptr, state, ProlongedHessian::Galerkin), std::invalid_argument);
  EXPECT_THROW(ProlongedTerm(s.membrane(s.fine()), nullptr, ProlongedHessian::Galerkin), std::invalid_argument);
  EXPECT_THROW(ProlongedTerm(s.membrane(s.fine()), state, ProlongedHessian::Coarse), std::invalid_argument);
  EXPECT_THROW(ProlongationState(s.P(), rest.head(6)), std::invalid_argument);
}

}  // namespace
}  // namespace pd
