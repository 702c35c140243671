// Tests of the Neo-Hookean membrane energy (physics/membrane_neo_hookean.h).
//
// Finite-difference checks use unit-scale geometry (edges ~1 m) so that the default step sizes
// (1e-4 .. 1e-7 m) are small relative to the triangle; one test uses centimetre triangles with steps
// scaled to the edge length. The tolerances are scale-free (relative errors).
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "physics/membrane_neo_hookean.h"
#include "support/finite_difference.h"
#include "support/triangle_vectors.h"
#include "geometry/shapes.h"
#include "support/term_eval.h"

namespace pd {
namespace {

constexpr double kGradTol = 1e-6;
constexpr double kHessTol = 1e-5;
const MembraneMaterialParams kCloth = MembraneMaterialParams::from(5e5, 0.3, 1e-3);  // Pa, -, m

using test::stack;
using test::vertex;
using test::area_of;
MembraneRest rest_of(const Vec<9>& X) { return membrane_rest(vertex(X, 0), vertex(X, 1), vertex(X, 2)); }

using test::random_triangle;

// FD checks of one element's gradient and Hessian (exact, unprojected) at x.
void expect_element_derivatives_match_fd(const Vec<9>& x, const MembraneRest& rest,
                                         const MembraneMaterialParams& p,
                                         const std::vector<double>& steps = test::default_steps()) {
  auto f = [&](const Eigen::VectorXd& v) { return neo_hookean_membrane_energy(Vec<9>(v), rest, p); };
  auto g = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
    return neo_hookean_membrane_gradient(Vec<9>(v), rest, p);
  };
  const Eigen::VectorXd xd = x;
  const test::FdResult rg = test::check_gradient(f, xd, g(xd), steps);
  const test::FdResult rh = test::check_hessian(g, xd, neo_hookean_membrane_hessian(x, rest, p), steps);
  EXPECT_GT(rg.comparisons, 0);
  EXPECT_GT(rh.comparisons, 0);
  EXPECT_GE(rg.steps_within(kGradTol), 2) << "best gradient rel. error " << rg.best_rel_error;
  EXPECT_GE(rh.steps_within(kHessTol), 2) << "best Hessian rel. error " << rh.best_rel_error;
  std::printf("    FD gradient best %.2e at %.0e, Hessian best %.2e at %.0e\n", rg.best_rel_error,
              rg.best_step, rh.best_rel_error, rh.best_step);
}

double min_eigenvalue(const Eigen::MatrixXd& H) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(H, Eigen::EigenvaluesOnly).eigenvalues()[0];
}

// Rest triangle in the xy plane (not right-angled, not isosceles) and its image under the in-plane
// deformation gradient diag(sx, sy).
const Vec<9> kPlanarRest = stack(Vec3(0.1, -0.2, 0), Vec3(1.3, 0.1, 0), Vec3(0.4, 0.9, 0));
Vec<9> planar_stretch(double sx, double sy) {
  Vec<9> x = kPlanarRest;
  for (int v = 0; v < 3; ++v) { x[3 * v] *= sx; x[3 * v + 1] *= sy; }
  return x;
}

TEST(NeoHookeanMembrane, MaterialParamsFromYoungsAndPoissonUse2DLameConstants) {
  const MembraneMaterialParams p = MembraneMaterialParams::from(2e6, 0.4, 5e-4);
  EXPECT_DOUBLE_EQ(p.mu, 2e6 / (2 * 1.4));
  EXPECT_DOUBLE_EQ(p.lambda, 2e6 * 0.4 / (1 - 0.16));
  EXPECT_DOUBLE_EQ(p.thickness, 5e-4);
  EXPECT_NO_THROW(MembraneMaterialParams::from(1e5, 0.5, 1e-3));  // incompressible is fine in 2D
  EXPECT_THROW(MembraneMaterialParams::from(1e5, 1.0, 1e-3), std::invalid_argument);
  EXPECT_THROW(MembraneMaterialParams::from(1e5, 0.3, 0.0), std::invalid_argument);
  EXPECT_THROW(MembraneMaterialParams::from(-1.0, 0.3, 1e-3), std::invalid_argument);
}

TEST(NeoHookeanMembrane, RandomDeformedTrianglesGradientAndHessianMatchFiniteDifferences) {
  for (unsigned seed : {1u, 2u, 3u, 17u, 123u}) {
    SCOPED_TRACE(seed);
    std::mt19937 rng(seed);
    const Vec<9> X = random_triangle(rng);
    const Vec<9> x = random_triangle(rng);  // arbitrary, unrelated deformed triangle
    const MembraneMaterialParams p = MembraneMaterialParams::from(1e5 * (1 + seed % 7), 0.05 * (seed % 10), 2e-3);
    expect_element_derivatives_match_fd(x, rest_of(X), p);
  }
}

TEST(NeoHookeanMembrane, StretchedTriangleGradientAndHessianMatchFiniteDifferences) {
  expect_element_derivatives_match_fd(planar_stretch(1.6, 1.2), rest_of(kPlanarRest), kCloth);
}

TEST(NeoHookeanMembrane, CompressedTriangleHessianIsIndefiniteAndMatchesFiniteDifferences) {
  // Slight out-of-plane offset so the configuration is generic; under compression an out-of-plane
  // vertex motion relieves the compressive stress, so the exact Hessian has a negative eigenvalue.
  Vec<9> x = planar_stretch(0.6, 0.7);
  x[8] += 0.05;
  const MembraneRest rest = rest_of(kPlanarRest);
  expect_element_derivatives_match_fd(x, rest, kCloth);
  const Mat<9> H = neo_hookean_membrane_hessian(x, rest, kCloth);
  EXPECT_LT(min_eigenvalue(H), -1e-3 * H.norm());
}

TEST(NeoHookeanMembrane, CentimetreScaleTriangleDerivativesMatchFiniteDifferencesWithScaledSteps) {
  std::mt19937 rng(7);
  const double s = 0.01;  // 1 cm triangles; FD steps scaled with the geometry
  const Vec<9> X = s * random_triangle(rng);
  const Vec<9> x = X + 0.2 * s * random_triangle(rng);
  expect_element_derivatives_match_fd(x, rest_of(X), kCloth, {s * 1e-4, s * 1e-5, s * 1e-6, s * 1e-7});
}

TEST(NeoHookeanMembrane, ZeroEnergyAndZeroGradientAtRest) {
  for (unsigned seed : {4u, 5u, 6u}) {
    std::mt19937 rng(seed);
    const Vec<9> X = random_triangle(rng);
    const MembraneRest rest = rest_of(X);
    const double hAmu = kCloth.thickness * rest.area * kCloth.mu;  // J; gradient scale hAmu / 1 m
    EXPECT_NEAR(neo_hookean_membrane_energy(X, rest, kCloth), 0.0, 1e-12 * hAmu);
    EXPECT_LT(neo_hookean_membrane_gradient(X, rest, kCloth).norm(), 1e-10 * hAmu);
  }
}

TEST(NeoHookeanMembrane, RigidMotionLeavesEnergyUnchangedAndRotatesGradientAndHessian) {
  std::mt19937 rng(11);
  const Vec<9> X = random_triangle(rng);
  const Vec<9> x = X + 0.3 * random_triangle(rng);
  const MembraneRest rest = rest_of(X);
  const Mat3 R = Eigen::AngleAxisd(1.1, Vec3(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  const Vec3 t(2.0, -3.0, 0.5);
  Vec<9> y;
  Mat<9> Rb = Mat<9>::Zero();  // block-diagonal rotation of the three vertices
  for (int v = 0; v < 3; ++v) {
    y.segment<3>(3 * v) = R * vertex(x, v) + t;
    Rb.block<3, 3>(3 * v, 3 * v) = R;
  }
  const double E = neo_hookean_membrane_energy(x, rest, kCloth);
  EXPECT_NEAR(neo_hookean_membrane_energy(y, rest, kCloth), E, 1e-12 * std::abs(E));
  const Vec<9> g = neo_hookean_membrane_gradient(x, rest, kCloth);
  EXPECT_LT((neo_hookean_membrane_gradient(y, rest, kCloth) - Rb * g).norm(), 1e-10 * g.norm());
  const Mat<9> H = neo_hookean_membrane_hessian(x, rest, kCloth);
  EXPECT_LT((neo_hookean_membrane_hessian(y, rest, kCloth) - Rb * H * Rb.transpose()).norm(), 1e-10 * H.norm());
  // Translations are zero modes: the gradient sums to zero over the vertices.
  EXPECT_LT((vertex(g, 0) + vertex(g, 1) + vertex(g, 2)).norm(), 1e-10 * g.norm());
}

TEST(NeoHookeanMembrane, ProjectedHessianIsPsdForClampAndAbs) {
  Vec<9> x = planar_stretch(0.6, 0.7);
  x[8] += 0.05;
  const Mat<9> H = neo_hookean_membrane_hessian(x, rest_of(kPlanarRest), kCloth);
  ASSERT_LT(min_eigenvalue(H), 0.0);  // the case must actually need projecting
  for (HessianProjection proj : {HessianProjection::Clamp, HessianProjection::Abs}) {
    const Mat<9> Hp = project_hessian<9>(H, proj);
    EXPECT_LT((Hp - Hp.transpose()).norm(), 1e-12 * H.norm()) << to_string(proj);
    EXPECT_GE(min_eigenvalue(Hp), -1e-10 * H.norm()) << to_string(proj);
  }
}

TEST(NeoHookeanMembrane, ProjectedHessianEqualsExactWhenAlreadyPsd) {
  // Equibiaxial stretch (tension everywhere) and the rest state: exact Hessian is PSD up to the
  // round-off of its zero modes (rigid motions; at rest also out-of-plane ones).
  for (const Vec<9>& x : {planar_stretch(1.3, 1.3), kPlanarRest}) {
    const Mat<9> H = neo_hookean_membrane_hessian(x, rest_of(kPlanarRest), kCloth);
    ASSERT_GE(min_eigenvalue(H), -1e-10 * H.norm());
    for (HessianProjection proj : {HessianProjection::Clamp, HessianProjection::Abs})
      EXPECT_LT((project_hessian<9>(H, proj) - H).norm(), 1e-10 * H.norm()) << to_string(proj);
  }
}

TEST(NeoHookeanMembrane, UniaxialAndEquibiaxialStretchMatchClosedFormEnergy) {
  const MembraneRest rest = rest_of(kPlanarRest);
  const double hA = kCloth.thickness * area_of(kPlanarRest), mu = kCloth.mu, lam = kCloth.lambda;
  for (double s : {0.5, 0.9, 1.1, 2.0}) {
    SCOPED_TRACE(s);
    const double ls = std::log(s);
    // Uniaxial: F = diag(s, 1): tr M = s^2 + 1, det M = s^2.
    const double uni = hA * (0.5 * mu * (s * s - 1 - 2 * ls) + 0.5 * lam * ls * ls);
    EXPECT_NEAR(neo_hookean_membrane_energy(planar_stretch(s, 1.0), rest, kCloth), uni, 1e-12 * uni);
    // Equibiaxial: F = s I: tr M = 2 s^2, det M = s^4, ln J = 2 ln s.
    const double equi = hA * (mu * (s * s - 1 - 2 * ls) + 2 * lam * ls * ls);
    EXPECT_NEAR(neo_hookean_membrane_energy(planar_stretch(s, s), rest, kCloth), equi, 1e-12 * equi);
  }
}

TEST(NeoHookeanMembrane, SmallUniaxialTensionRecoversPlaneStressYoungsModulusAndPoissonRatio) {
  // Stretch x by 1 + eps, let y relax: the lateral stretch t solves dW/dt = 0, i.e.
  // mu (t^2 - 1) + lambda ln((1 + eps) t) = 0. For small eps, t - 1 -> -nu eps and W -> E eps^2 / 2.
  const double E = 3e5, nu = 0.35, eps = 1e-4;
  const MembraneMaterialParams p = MembraneMaterialParams::from(E, nu, 1e-3);
  double t = 1.0;
  for (int it = 0; it < 50; ++it)
    t -= (p.mu * (t * t - 1) + p.lambda * std::log((1 + eps) * t)) / (2 * p.mu * t + p.lambda / t);
  EXPECT_NEAR((t - 1) / eps, -nu, 1e-3);
  const double W = neo_hookean_membrane_energy(planar_stretch(1 + eps, t), rest_of(kPlanarRest), p) /
                   (p.thickness * area_of(kPlanarRest));
  EXPECT_NEAR(W / (0.5 * E * eps * eps), 1.0, 1e-3);
}

TEST(NeoHookeanMembrane, DegenerateDeformedTriangleGivesInfiniteEnergy) {
  const MembraneRest rest = rest_of(kPlanarRest);
  const double inf = std::numeric_limits<double>::infinity();
  const Vec<9> collinear = stack(Vec3(0, 0, 0), Vec3(1, 1, 1), Vec3(2, 2, 2));
  const Vec<9> coincident = stack(Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(1, 0, 0));
  EXPECT_EQ(neo_hookean_membrane_energy(collinear, rest, kCloth), inf);
  EXPECT_EQ(neo_hookean_membrane_energy(coincident, rest, kCloth), inf);
  EXPECT_TRUE(neo_hookean_membrane_gradient(collinear, rest, kCloth).array().isNaN().all());
  EXPECT_TRUE(neo_hookean_membrane_hessian(collinear, rest, kCloth).array().isNaN().all());
  // Barrier: the energy grows without bound as the triangle collapses.
  EXPECT_GT(neo_hookean_membrane_energy(planar_stretch(1.0, 1e-6), rest, kCloth),
            neo_hookean_membrane_energy(planar_stretch(1.0, 1e-3), rest, kCloth));
}

TEST(NeoHookeanMembrane, MirroredTriangleHasSameFiniteEnergyBecauseMetricIgnoresOrientation) {
  // Documented limitation: a 3D membrane cannot tell a triangle from its mirror image.
  const MembraneRest rest = rest_of(kPlanarRest);
  const Vec<9> x = planar_stretch(1.2, 0.9);
  const Vec<9> mirrored = planar_stretch(1.2, -0.9);  // y -> -y flips the normal
  const double E = neo_hookean_membrane_energy(x, rest, kCloth);
  EXPECT_TRUE(std::isfinite(E));
  EXPECT_NEAR(neo_hookean_membrane_energy(mirrored, rest, kCloth), E, 1e-12 * E);
}

// Small mesh: 5 triangles over vertices 1..6 of a 7-vertex scene (vertex 0 belongs to another
// object and is not referenced), slightly curved rest shape.
struct SmallMesh {
  Positions rest;
  Faces faces;
  SmallMesh() : rest(7, 3), faces(5, 3) {
    rest << 9, 9, 9,  0, 0, 0.1,  1, 0, 0,  1, 1, 0.05,  0, 1, 0,  -0.8, 0.5, 0.2,  0.5, -0.9, 0.1;
    faces << 1, 2, 3,  1, 3, 4,  1, 4, 5,  1, 6, 2,  2, 6, 3;
  }
};

Eigen::MatrixXd dense_hessian(const NeoHookeanMembrane& term, const Eigen::VectorXd& x,
                              HessianProjection proj) {
  HessianAssembly assembly;
  assembly.begin(static_cast<int>(x.size()));
  term.add_hessian(x, proj, assembly);
  const Eigen::MatrixXd lower = Eigen::MatrixXd(assembly.finish(nullptr));
  Eigen::MatrixXd full = lower + lower.transpose();
  full.diagonal() = lower.diagonal();
  return full;
}

TEST(NeoHookeanMembrane, AssembledTermGradientAndHessianMatchFiniteDifferences) {
  const SmallMesh mesh;
  const NeoHookeanMembrane term(mesh.faces, mesh.rest, kCloth);
  EXPECT_EQ(term.name(), "membrane");
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  Eigen::VectorXd x = stacked(mesh.rest);
  for (Eigen::Index i = 3; i < x.size(); ++i) x[i] += u(rng);

  // value() is the sum of the element energies.
  double sum = 0.0;
  for (int f = 0; f < mesh.faces.rows(); ++f) {
    Vec<9> xe, Xe;
    for (int k = 0; k < 3; ++k) {
      xe.segment<3>(3 * k) = x.segment<3>(3 * mesh.faces(f, k));
      Xe.segment<3>(3 * k) = mesh.rest.row(mesh.faces(f, k)).transpose();
    }
    sum += neo_hookean_membrane_energy(xe, rest_of(Xe), kCloth);
  }
  EXPECT_NEAR(term.value(x), sum, 1e-12 * sum);

  auto f = [&](const Eigen::VectorXd& v) { return term.value(v); };
  auto g = [&](const Eigen::VectorXd& v) {
    Eigen::VectorXd out = Eigen::VectorXd::Zero(v.size());
    term.add_gradient(v, out);
    return out;
  };
  const Eigen::VectorXd grad = g(x);
  EXPECT_EQ(grad.head<3>().norm(), 0.0);  // unreferenced vertex 0 gets nothing
  const test::FdResult rg = test::check_gradient(f, x, grad);
  const test::FdResult rh = test::check_hessian(g, x, dense_hessian(term, x, HessianProjection::None));
  EXPECT_GT(rg.comparisons, 0);
  EXPECT_GT(rh.comparisons, 0);
  EXPECT_GE(rg.steps_within(kGradTol), 2) << rg.best_rel_error;
  EXPECT_GE(rh.steps_within(kHessTol), 2) << rh.best_rel_error;
  std::printf("    FD gradient best %.2e, Hessian best %.2e\n", rg.best_rel_error, rh.best_rel_error);

  // add_gradient adds to what is already there.
  Eigen::VectorXd acc = Eigen::VectorXd::Ones(x.size());
  term.add_gradient(x, acc);
  EXPECT_LT((acc - Eigen::VectorXd::Ones(x.size()) - grad).norm(), 1e-14 * grad.norm());
}

// value() keeps each face's stress for the gradient, and its sum for a value, at the same x; a
// stretched state and one with two collapsed faces (whose gradient entries are NaN either way).
TEST(NeoHookeanMembrane, ValueAndGradientAfterValueEqualThoseOfATermThatNeverEvaluatedAValue) {
  const SmallMesh mesh;
  const NeoHookeanMembrane term(mesh.faces, mesh.rest, kCloth), twin(mesh.faces, mesh.rest, kCloth);
  std::mt19937 rng(22);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  Eigen::VectorXd x = stacked(mesh.rest);
  for (Eigen::Index i = 3; i < x.size(); ++i) x[i] += u(rng);
  Eigen::VectorXd collapsed = x;
  collapsed.segment<3>(3 * 3) = collapsed.segment<3>(3 * 1);  // faces 0 and 1
  ASSERT_TRUE(test::term_gradient(twin, collapsed).hasNaN());
  test::expect_reuse_after_value_is_fresh(term, twin, x, collapsed);
  test::expect_reuse_after_value_is_fresh(term, twin, x, 1.1 * x);
}

TEST(NeoHookeanMembrane, AssembledProjectedHessianIsPsdUnderCompression) {
  const SmallMesh mesh;
  const NeoHookeanMembrane term(mesh.faces, mesh.rest, kCloth);
  Eigen::VectorXd x = 0.7 * stacked(mesh.rest);  // uniform compression
  x[3 * 3 + 2] += 0.1;                            // and a small bump
  const Eigen::MatrixXd exact = dense_hessian(term, x, HessianProjection::None);
  ASSERT_LT(min_eigenvalue(exact), -1e-3 * exact.norm());
  for (HessianProjection proj : {HessianProjection::Clamp, HessianProjection::Abs})
    EXPECT_GE(min_eigenvalue(dense_hessian(term, x, proj)), -1e-10 * exact.norm()) << to_string(proj);
}

TEST(NeoHookeanMembrane, TermRejectsCollapsedTriangleAndBadInput) {
  const SmallMesh mesh;
  const NeoHookeanMembrane term(mesh.faces, mesh.rest, kCloth);
  Eigen::VectorXd x = stacked(mesh.rest);
  EXPECT_NEAR(term.value(x), 0.0, 1e-12);
  x.segment<3>(3 * 3) = x.segment<3>(3 * 1);  // vertex 3 onto vertex 1: faces 0, 1 collapse
  EXPECT_EQ(term.value(x), std::numeric_limits<double>::infinity());
  EXPECT_THROW(term.value(Eigen::VectorXd::Zero(6)), std::invalid_argument);

  Positions flat_rest = mesh.rest;
  flat_rest.row(3) = 0.5 * (flat_rest.row(1) + flat_rest.row(2));  // face 0 has zero rest area
  EXPECT_THROW(NeoHookeanMembrane(mesh.faces, flat_rest, kCloth), std::invalid_argument);
  Faces bad = mesh.faces;
  bad(2, 1) = 7;
  EXPECT_THROW(NeoHookeanMembrane(bad, mesh.rest, kCloth), std::invalid_argument);
}


// The element loops run on several threads (physics/element_loops.h); the value, the gradient and
// the assembled projected Hessian must be the same bytes for every thread count.
// value() takes two faces per pass (physics/lanes.h); each lane must give the bits of the one-face
// functions, in each branch of ln det M and of s - log1p(s) and with the pair's lanes in different
// branches: an odd count (the last face alone), a stretch of 1e-4 (series in both lanes), one vertex
// pulled away (large and small strains side by side), a triangle squashed to less than half its area
// (s < -1/2) and a collapsed one; the gradient after that value (stresses reused) and without, on one
// and two threads.
TEST(NeoHookeanMembrane, PairedValueAndGradientGiveTheOneFaceBitsInEveryBranch) {
  const TriMesh sheet = make_rectangle(1.0, 0.8, 3, 2);
  const Faces faces = sheet.F.topRows(11);
  const Eigen::VectorXd rest = stacked(sheet.V);
  Eigen::VectorXd small = rest;
  for (Eigen::Index i = 0; i < small.size(); i += 3) small[i] *= 1.0 + 1e-4;
  Eigen::VectorXd pulled = small;
  pulled.segment<3>(3 * 5) += Vec3(0.3, -0.2, 0.25);
  Eigen::VectorXd squashed = pulled;
  {  // face 0's third vertex 80 % of the way to the middle of its first edge: a fifth of its area
    const int a = faces(0, 0), b = faces(0, 1), c = faces(0, 2);
    squashed.segment<3>(3 * c) = 0.4 * (squashed.segment<3>(3 * a) + squashed.segment<3>(3 * b)) + 0.2 * squashed.segment<3>(3 * c);
  }
  squashed.segment<3>(3 * 10) = squashed.segment<3>(3 * 9);  // the faces on edge 9-10 collapse
  const auto one_face_sums = [&](const Eigen::VectorXd& x, double& energy, Eigen::VectorXd& gradient, int& branches) {
    energy = 0.0;
    gradient = Eigen::VectorXd::Zero(x.size());
    for (int f = 0; f < faces.rows(); ++f) {
      Vec<9> xe, Xe;
      for (int k = 0; k < 3; ++k) {
        xe.segment<3>(3 * k) = x.segment<3>(3 * faces(f, k));
        Xe.segment<3>(3 * k) = rest.segment<3>(3 * faces(f, k));
      }
      const double det_M = std::pow(area_of(xe) / area_of(Xe), 2);  // bits: series, direct, s < -1/2, collapsed
      branches |= std::abs(det_M - 1.0) < 1e-2 ? 1 : det_M < 1e-18 ? 8 : det_M < 0.5 ? 4 : 2;
      energy += neo_hookean_membrane_energy(xe, rest_of(Xe), kCloth);
      const Vec<9> g = neo_hookean_membrane_gradient(xe, rest_of(Xe), kCloth);
      for (int k = 0; k < 3; ++k) gradient.segment<3>(3 * faces(f, k)) += g.segment<3>(3 * k);
    }
  };
  int branches = 0;
  long compared = 0;
  for (const Eigen::VectorXd& x : {small, pulled, squashed}) {
    double energy = 0.0;
    Eigen::VectorXd gradient;
    one_face_sums(x, energy, gradient, branches);
    compared += test::expect_value_and_gradient_bits(
        [&] { return std::make_unique<NeoHookeanMembrane>(faces, sheet.V, kCloth); }, x, energy, gradient);
  }
  EXPECT_EQ(branches, 1 | 2 | 4 | 8);  // every branch taken by some face
  EXPECT_EQ(compared, 3 * (4 * rest.size() + 2));
}

TEST(NeoHookeanMembrane, ValueGradientAndHessianAreBitIdenticalOnOneTwoAndThreeThreads) {
  const TriMesh sheet = make_rectangle(1.0, 1.0, 30, 30);  // 1800 faces: the parallel path
  const NeoHookeanMembrane membrane(sheet.F, sheet.V, kCloth);
  const Eigen::VectorXd x = stacked(sheet.V) + 0.01 * test::wavy(3 * sheet.num_vertices(), 0.37, 0.1);
  const test::TermBits one = test::term_bits(membrane, x, HessianProjection::Clamp, 1);
  long compared = 0;
  for (int threads : {2, 3}) compared += test::expect_same_bits(one, test::term_bits(membrane, x, HessianProjection::Clamp, threads));
  EXPECT_GT(compared, 2 * 30000);  // 1 value + 2 883 gradient + 30 606 Hessian values per comparison
}

}  // namespace
}  // namespace pd
