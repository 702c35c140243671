// The finest level's elasticity felt through the shell prolongation (progressive/prolonged_term.h):
// derivatives of the frozen-offset energy, the Galerkin Hessian against a dense U^T H U, the rest
// state, rigid motions, and the coarse stand-in Hessian.
#include "progressive/prolonged_term.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

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

TEST(ProlongedTerm, FrozenOffsetEnergyDerivativesMatchFiniteDifferences) {
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V));
  const Eigen::VectorXd x = s.deformed();
  ASSERT_TRUE(state->refresh(x));
  for (const bool bend : {false, true}) {
    SCOPED_TRACE(bend ? "bending" : "membrane");
    const ProlongedTerm term(bend ? s.bending(s.fine()) : s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
    ASSERT_GT(term.value(x), 0.0);
    test::expect_derivatives_match(test::check_term_derivatives(term, x), 1e-6, 1e-5);
  }
}

TEST(ProlongedTerm, GradientAndGalerkinHessianAreUTransposeTimesTheFineOnes) {
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V));
  const Eigen::VectorXd x = s.deformed();
  ASSERT_TRUE(state->refresh(x));
  const Eigen::VectorXd y = state->fine_positions(x);
  const Eigen::MatrixXd U = Eigen::MatrixXd(state->U());
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
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V));
  const ProlongedTerm membrane(s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
  const ProlongedTerm bending(s.bending(s.fine()), state, ProlongedHessian::Galerkin);
  const Eigen::VectorXd x = s.deformed();
  ASSERT_TRUE(state->refresh(x));
  const double em = membrane.value(x), eb = bending.value(x);
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, -2, 0.5).normalized()).toRotationMatrix();
  Positions moved = as_rows(x);
  for (int i = 0; i < moved.rows(); ++i) moved.row(i) = (R * moved.row(i).transpose() + Vec3(0.3, -1, 2)).transpose();
  ASSERT_TRUE(state->refresh(stacked(moved)));
  EXPECT_NEAR(membrane.value(stacked(moved)), em, 1e-10 * em);
  EXPECT_NEAR(bending.value(stacked(moved)), eb, 1e-10 * eb);
}

TEST(ProlongedTerm, CoarseHessianIsTheStandInsWhileValueAndGradientStayProlonged) {
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V));
  const Eigen::VectorXd x = s.deformed();
  ASSERT_TRUE(state->refresh(x));
  const ProlongedTerm galerkin(s.membrane(s.fine()), state, ProlongedHessian::Galerkin);
  const ProlongedTerm coarse(s.membrane(s.fine()), state, ProlongedHessian::Coarse, s.membrane(s.coarse()));
  const auto stand_in = s.membrane(s.coarse());
  EXPECT_EQ(coarse.value(x), galerkin.value(x));
  EXPECT_TRUE(test::term_gradient(coarse, x) == test::term_gradient(galerkin, x));
  EXPECT_TRUE(test::term_hessian(coarse, x, HessianProjection::Clamp) ==
              test::term_hessian(*stand_in, x, HessianProjection::Clamp));
  EXPECT_EQ(coarse.name(), "membrane");
}

// The lagged Galerkin Hessian: exact at a step's first assembly, then reused (whatever x is) until
// the kLaggedRefreshEvery-th assembly, a new step or a different projection recomputes it.
TEST(ProlongedTerm, LaggedHessianIsGalerkinAtRefreshesAndReusedBetweenThem) {
  Sheet s;
  auto state = std::make_shared<ProlongationState>(s.P(), stacked(s.coarse().V));
  const Eigen::VectorXd x1 = s.deformed();
  const Eigen::VectorXd x2 = 1.01 * x1 + Eigen::VectorXd::Constant(x1.size(), 0.002);
  ASSERT_TRUE(state->refresh(x1));
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
  EXPECT_TRUE(test::term_hessian(lagged, x2, clamp) == test::term_hessian(galerkin, x2, clamp));  // so does a new projection
  // Value and gradient are never lagged.
  EXPECT_EQ(lagged.value(x2), galerkin.value(x2));
  EXPECT_TRUE(test::term_gradient(lagged, x2) == test::term_gradient(galerkin, x2));
}

TEST(ProlongedTerm, HessianNamesParseAndUnknownOnesAreRefused) {
  EXPECT_EQ(parse_prolonged_hessian("galerkin"), ProlongedHessian::Galerkin);
  EXPECT_EQ(parse_prolonged_hessian("lagged"), ProlongedHessian::Lagged);
  EXPECT_EQ(parse_prolonged_hessian("coarse"), ProlongedHessian::Coarse);
  EXPECT_THROW(parse_prolonged_hessian("Galerkin"), std::invalid_argument);
}

TEST(ProlongedTerm, DegenerateCoarseFaceKeepsTheLastOffsetsAndBadInputIsRefused) {
  Sheet s;
  const Eigen::VectorXd rest = stacked(s.coarse().V);
  auto state = std::make_shared<ProlongationState>(s.P(), rest);
  const Eigen::VectorXd before = state->fine_positions(rest);
  Eigen::VectorXd flat = rest;
  for (Eigen::Index i = 0; i < flat.size(); i += 3) flat[i] = 0.0;  // every face collapses to a line
  EXPECT_FALSE(state->refresh(flat));
  EXPECT_TRUE(state->fine_positions(rest) == before);

  EXPECT_THROW(ProlongedTerm(nullptr, state, ProlongedHessian::Galerkin), std::invalid_argument);
  EXPECT_THROW(ProlongedTerm(s.membrane(s.fine()), nullptr, ProlongedHessian::Galerkin), std::invalid_argument);
  EXPECT_THROW(ProlongedTerm(s.membrane(s.fine()), state, ProlongedHessian::Coarse), std::invalid_argument);
  EXPECT_THROW(ProlongationState(s.P(), rest.head(6)), std::invalid_argument);
}

}  // namespace
}  // namespace pd
