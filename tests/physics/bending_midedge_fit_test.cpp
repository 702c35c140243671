// Tests of the midedge-fit bending energy (physics/bending_midedge_fit.h). Its agreement with plate
// theory on whole meshes is tested in bending_plate_theory_test.cpp.
// GCC 12 -O2 false positive inside Eigen's self-adjoint eigensolver; silenced for Eigen's lines only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#pragma GCC diagnostic pop

#include "physics/bending_midedge_fit.h"

#include <cmath>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "geometry/shapes.h"
#include "support/delaunay_rectangle.h"
#include "support/finite_difference.h"
#include "support/term_eval.h"

namespace pd {
namespace {

Vec<36> stencil_positions(const MidedgeFitElement& el, const Eigen::VectorXd& x) {
  Vec<36> xe;
  for (int k = 0; k < kMidedgeFitStencil; ++k) xe.segment<3>(3 * k) = x.segment<3>(3 * el.v[static_cast<size_t>(k)]);
  return xe;
}

// Boundary edges of a face's stencil: 3 minus the opposite vertices it found (the stencil's first
// entries after the face are its opposite vertices, but counting them needs the mesh): from C, whose
// rank drops by one per free boundary slope.
int free_slopes(const MidedgeFitElement& el) {
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(el.rest.C);
  int zero = 0;
  for (int i = 0; i < 3; ++i) zero += eig.eigenvalues()[i] < 1e-9 * std::max(1e-300, eig.eigenvalues()[2]);
  return el.rest.C.isZero(0.0) ? 3 : zero;
}

// x perturbed by `amplitude` (m) uniform noise from `seed`.
Eigen::VectorXd perturbed(const Positions& V, double amplitude, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-amplitude, amplitude);
  Eigen::VectorXd x = stacked(V);
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] += U(rng);
  return x;
}

// Checks every element of `elements` at x against finite differences; returns the number of faces
// checked with 0, 1 and 2 free boundary slopes, and prints the entries compared.
std::array<int, 3> check_elements(const std::vector<MidedgeFitElement>& elements, const Eigen::VectorXd& x) {
  std::array<int, 3> checked{0, 0, 0};
  long gradient_entries = 0, hessian_entries = 0;
  for (const MidedgeFitElement& el : elements) {
    const Vec<36> xe = stencil_positions(el, x);
    const auto fix = [](const Eigen::VectorXd& y) { return Vec<36>(y); };
    const auto rg = test::check_gradient([&](const Eigen::VectorXd& y) { return midedge_fit_energy(fix(y), el.rest); },
                                         xe, Eigen::VectorXd(midedge_fit_gradient(xe, el.rest)));
    const auto rh = test::check_hessian(
        [&](const Eigen::VectorXd& y) { return Eigen::VectorXd(midedge_fit_gradient(fix(y), el.rest)); }, xe,
        Eigen::MatrixXd(midedge_fit_hessian(xe, el.rest)));
    EXPECT_GT(rg.comparisons, 0);
    EXPECT_GT(rh.comparisons, 0);
    EXPECT_GE(rg.steps_within(1e-6), 2) << "gradient, best " << rg.best_rel_error;
    EXPECT_GE(rh.steps_within(1e-5), 2) << "Hessian, best " << rh.best_rel_error;
    const int free = free_slopes(el);
    if (free < 3 && rg.comparisons > 0 && rh.comparisons > 0) ++checked[static_cast<size_t>(free)];
    gradient_entries += rg.comparisons;
    hessian_entries += rh.comparisons;
  }
  std::printf("finite differences: %zu faces, %ld gradient and %ld Hessian entries compared\n", elements.size(),
              gradient_entries, hessian_entries);
  return checked;
}

TEST(MidedgeFitBending, ElementGradientAndHessianMatchFiniteDifferencesOnInteriorAndBoundaryFaces) {
  // An irregular flat sheet (faces with 0, 1 and 2 boundary edges), bent and shaken.
  const TriMesh m = test::make_delaunay_rectangle(1.0, 0.8, 5, 4, 3, 0.2, 1);
  const auto elements = midedge_fit_elements(m.F, m.V, 0.7, 0.3);
  Eigen::VectorXd x = perturbed(m.V, 0.05, 11);
  for (int i = 0; i < m.num_vertices(); ++i) x[3 * i + 2] += 0.4 * m.V(i, 0) * m.V(i, 0) - 0.3 * m.V(i, 0) * m.V(i, 1);
  const auto checked = check_elements(elements, x);
  std::printf("faces checked with 0 / 1 / 2 free boundary slopes: %d / %d / %d\n", checked[0], checked[1], checked[2]);
  EXPECT_GT(checked[0], 0);
  EXPECT_GT(checked[1], 0);
  EXPECT_GT(checked[2], 0);
}

TEST(MidedgeFitBending, ElementGradientAndHessianMatchFiniteDifferencesOnACurvedRestShell) {
  const TriMesh m = make_icosphere(0.5, 1);
  const auto elements = midedge_fit_elements(m.F, m.V, 0.02, 0.25);
  const auto checked = check_elements(elements, perturbed(m.V, 0.05, 12));
  EXPECT_EQ(checked[0], m.num_faces());  // closed: no free slopes
}

TEST(MidedgeFitBending, TermAssemblyMatchesFiniteDifferences) {
  const TriMesh m = make_rectangle(1.0, 0.6, 4, 3, GridDiagonals::Checkerboard);
  const MidedgeFitBending term(m.F, m.V, 0.05, 0.3);
  EXPECT_EQ(term.name(), "bending");
  EXPECT_FALSE(term.may_limit_step());
  Eigen::VectorXd x = perturbed(m.V, 0.08, 13);
  const test::TermFdCheck check = test::check_term_derivatives(term, x);
  test::expect_derivatives_match(check, 1e-6, 1e-5);
  std::printf("term finite differences: %d gradient and %d Hessian entries compared\n", check.gradient.comparisons,
              check.hessian.comparisons);
  // The assembled Hessian is the sum of the element Hessians.
  double energy = 0.0;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(x.size(), x.size());
  for (const MidedgeFitElement& el : term.elements()) {
    const Vec<36> xe = stencil_positions(el, x);
    energy += midedge_fit_energy(xe, el.rest);
    const Mat<36> He = midedge_fit_hessian(xe, el.rest);
    for (int a = 0; a < kMidedgeFitStencil; ++a)
      for (int b = 0; b < kMidedgeFitStencil; ++b)
        H.block<3, 3>(3 * el.v[a], 3 * el.v[b]) += He.block<3, 3>(3 * a, 3 * b);
  }
  EXPECT_NEAR(term.value(x), energy, 1e-14 * std::abs(energy));
  EXPECT_LT((check.H - H).norm(), 1e-12 * H.norm());
  const Eigen::MatrixXd Hc = test::term_hessian(term, x, HessianProjection::Clamp);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Hc).eigenvalues().minCoeff(), -1e-10 * Hc.norm());
}

TEST(MidedgeFitBending, ZeroEnergyAndGradientAtCurvedRestShapes) {
  for (const TriMesh& m : {make_icosphere(0.3, 2), make_box(Vec3(0.4, 0.3, 0.2), 3)}) {
    const MidedgeFitBending term(m.F, m.V, 0.01, 0.3);
    const Eigen::VectorXd x = stacked(m.V);
    EXPECT_EQ(term.value(x), 0.0);
    EXPECT_EQ(test::term_gradient(term, x).norm(), 0.0);
    // Denting the shell costs energy (an affine squash would not: the box's angles stay 90 degrees).
    Eigen::VectorXd dented = x;
    for (int i = 0; i < m.num_vertices(); ++i) dented[3 * i + 2] += 0.02 * std::sin(20.0 * x[3 * i]);
    EXPECT_GT(term.value(dented), 0.0);
  }
}

// Small heights z = eps (u^T S u / 2 + linear) on a flat mesh: every face whose three edges are
// interior must see beta = eps S in its frame, whatever the triangulation (the hinge cannot).
TEST(MidedgeFitBending, ReproducesTheHessianOfQuadraticHeightsOnIrregularAndGridMeshes) {
  Eigen::Matrix2d S;
  S << 1.3, -0.4, -0.4, 0.7;
  const double eps = 1e-5;
  for (const TriMesh& m : {test::make_delaunay_rectangle(1.0, 1.0, 8, 8, 5), make_rectangle(1.0, 1.0, 8, 8),
                           make_rectangle_equilateral(1.0, 1.0, 8)}) {
    const auto elements = midedge_fit_elements(m.F, m.V, 1.0, 0.3);
    Eigen::VectorXd x = stacked(m.V);
    for (int i = 0; i < m.num_vertices(); ++i) {
      const Eigen::Vector2d u(m.V(i, 0), m.V(i, 1));
      x[3 * i + 2] = eps * (0.5 * u.dot(S * u) + 0.3 * u.x() - 0.2 * u.y() + 0.1);
    }
    int interior = 0;
    for (size_t f = 0; f < elements.size(); ++f) {
      if (free_slopes(elements[f]) != 0) continue;
      const Eigen::Vector2d e1 = (m.V.row(m.F(f, 1)) - m.V.row(m.F(f, 0))).head<2>().normalized().transpose();
      const Eigen::Vector2d e2(-e1.y(), e1.x());
      const Vec3 expected(e1.dot(S * e1), e2.dot(S * e2), e1.dot(S * e2));
      const Vec3 beta = midedge_fit_curvature(stencil_positions(elements[f], x), elements[f].rest) / eps;
      EXPECT_LT((beta - expected).norm(), 1e-6 * expected.norm()) << "face " << f;
      ++interior;
    }
    EXPECT_GT(interior, m.num_faces() / 2);
  }
}

TEST(MidedgeFitBending, RigidMotionLeavesEnergyInvariantWithZeroNetForceAndTorque) {
  const TriMesh m = test::make_delaunay_rectangle(1.0, 1.0, 4, 4, 9, 0.2, 1);
  const auto elements = midedge_fit_elements(m.F, m.V, 0.3, 0.2);
  const Eigen::VectorXd x = perturbed(m.V, 0.1, 14);
  const Mat3 Q = Eigen::AngleAxisd(0.7, Vec3(1, -2, 0.5).normalized()).toRotationMatrix();
  const Vec3 t(0.3, -1.2, 2.0);
  int checked = 0;
  for (const MidedgeFitElement& el : elements) {
    const Vec<36> xe = stencil_positions(el, x);
    Vec<36> ye;
    for (int k = 0; k < kMidedgeFitStencil; ++k) ye.segment<3>(3 * k) = Q * xe.segment<3>(3 * k) + t;
    const double E = midedge_fit_energy(xe, el.rest);
    EXPECT_NEAR(midedge_fit_energy(ye, el.rest), E, 1e-12 * std::max(E, 1e-12));
    const Vec<36> g = midedge_fit_gradient(xe, el.rest);
    Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
    for (int k = 0; k < kMidedgeFitStencil; ++k) {
      force += g.segment<3>(3 * k);
      torque += xe.segment<3>(3 * k).cross(g.segment<3>(3 * k));
    }
    EXPECT_LT(force.norm(), 1e-10 * g.norm());
    EXPECT_LT(torque.norm(), 1e-10 * g.norm() * xe.norm());
    checked += g.norm() > 0.0;
  }
  EXPECT_GT(checked, 0);
}

// A collapsed face has no normal: the angles of the hinges it is a wing of are taken as 0
// (physics/bending_hinge.h), without force or stiffness; the other hinges still act; nothing is NaN.
TEST(MidedgeFitBending, DegenerateFaceGivesFiniteEnergyAndDerivatives) {
  const TriMesh m = make_rectangle(1.0, 1.0, 2, 2, GridDiagonals::Uniform);
  const auto elements = midedge_fit_elements(m.F, m.V, 1.0, 0.3);
  const MidedgeFitElement& el = elements[3];
  Eigen::VectorXd x = perturbed(m.V, 0.05, 15);
  x.segment<3>(3 * el.v[1]) = x.segment<3>(3 * el.v[0]);  // collapse the face's first edge
  const Vec<36> xe = stencil_positions(el, x);
  EXPECT_TRUE(std::isfinite(midedge_fit_energy(xe, el.rest)));
  EXPECT_TRUE(midedge_fit_gradient(xe, el.rest).allFinite());
  EXPECT_TRUE(midedge_fit_hessian(xe, el.rest).allFinite());
}

TEST(MidedgeFitBending, LoneTriangleCannotBendAndBadMeshesThrow) {
  Positions V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0;
  Faces one(1, 3);
  one << 0, 1, 2;
  EXPECT_TRUE(midedge_fit_elements(one, V, 1.0, 0.3)[0].rest.C.isZero(0.0));
  Faces outside(1, 3);
  outside << 0, 1, 4;
  EXPECT_THROW(MidedgeFitBending(outside, V, 1.0, 0.3), std::invalid_argument);
  Faces flipped(2, 3);
  flipped << 0, 1, 2, 1, 2, 3;  // both traverse 1 -> 2
  EXPECT_THROW(MidedgeFitBending(flipped, V, 1.0, 0.3), std::invalid_argument);
  V.row(2) << 2, 0, 0;  // collinear: zero rest area
  EXPECT_THROW(MidedgeFitBending(one, V, 1.0, 0.3), std::invalid_argument);
}

// The element loops run on several threads (physics/element_loops.h); the value, the gradient and
// the assembled projected Hessian must be the same bytes for every thread count.
TEST(MidedgeFitBending, ValueGradientAndHessianAreBitIdenticalForAnyThreadCount) {
  const TriMesh m = test::make_delaunay_rectangle(1.0, 1.0, 9, 7, 21);
  const MidedgeFitBending term(m.F, m.V, 0.02, 0.3);
  const Eigen::VectorXd x = perturbed(m.V, 0.05, 16);
  const test::TermBits one = test::term_bits(term, x, HessianProjection::Clamp, 1);
  long compared = 0;
  for (int threads : {2, 3})
    compared += test::expect_same_bits(one, test::term_bits(term, x, HessianProjection::Clamp, threads));
  EXPECT_GT(compared, 1000);
}

}  // namespace
}  // namespace pd
