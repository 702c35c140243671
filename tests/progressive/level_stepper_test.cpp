// Behaviour of implicit-Euler stepping on whole scenes, against closed forms and plate theory.
#include "progressive/level_stepper.h"

#include <gtest/gtest.h>

#include <cmath>

#include "geometry/shapes.h"
#include "physics/membrane_neo_hookean.h"
#include "progressive/test_scenes.h"
#include "scene/scene_file.h"
#include "support/test_paths.h"

namespace pd {
namespace {

using test::make_object;
using test::make_scene;
using test::run_scene;

double enclosed_volume(const Faces& F, const Eigen::VectorXd& x) {
  double v = 0;
  for (int f = 0; f < F.rows(); ++f)
    v += x.segment<3>(3 * F(f, 0)).dot(x.segment<3>(3 * F(f, 1)).cross(x.segment<3>(3 * F(f, 2)))) / 6;
  return v;
}

TEST(LevelStepper, FreeFallMatchesClosedFormImplicitEuler) {
  // An unpinned sheet with an initial velocity falls rigidly: elastic forces stay zero, so implicit
  // Euler gives v_n = v0 + n h g and x_n = x_0 + n h v0 + h^2 g n(n+1)/2 exactly.
  const double h = 0.02;
  const Vec3 g(0, -9.81, 0), v0(0.3, 1.0, -0.2);
  Scene scene = make_scene(h, 25, g);
  scene.objects.push_back(make_object("sheet", make_rectangle(0.5, 0.5, 4, 4), test::cotton()));
  scene.objects[0].initial_velocity = v0;
  scene.solver.tolerance = 1e-9;
  SceneSystem sys = build_scene_system(scene);
  Eigen::VectorXd v;
  const Eigen::VectorXd x = run_scene(scene, sys, &v);
  const int N = scene.frames;
  const Vec3 expected_shift = N * h * v0 + h * h * g * (N * (N + 1) / 2.0);
  for (int i = 0; i < sys.rest.num_vertices(); ++i) {
    const Vec3 shift = x.segment<3>(3 * i) - sys.x0.segment<3>(3 * i);
    EXPECT_LT((shift - expected_shift).norm(), 1e-9 * expected_shift.norm()) << "vertex " << i;
    EXPECT_LT((v.segment<3>(3 * i) - (v0 + N * h * g)).norm(), 1e-8) << "vertex " << i;
  }
}

// A state no shot reaches stops the run by name. A free fall at the scene format's largest gravity
// (1000 m/s^2) and time step (1 s) has x_n = x_0 + h^2 g n (n + 1) / 2: past kDivergedDistance
// (1e6 m) at n = 45 (1.035e6 m), still inside at n = 44 (0.99e6 m).
TEST(LevelStepper, AStateBeyondTheDivergenceBoundsStopsTheRunNamingFrameObjectAndValue) {
  ASSERT_EQ(kDivergedDistance, 1e6);
  Scene scene = make_scene(1.0, 50, Vec3(0, -1000, 0));
  scene.objects.push_back(make_object("sheet", make_rectangle(0.5, 0.5, 2, 2), test::cotton()));
  SceneSystem sys = build_scene_system(scene);
  LevelStepper stepper(sys, scene.solver, scene.time_step);
  Eigen::VectorXd x = sys.x0, v = sys.v0;
  int stepped = 0;
  std::string message;
  try {
    for (int n = 0; n < scene.frames; ++n, ++stepped) stepper.step(n, x, v);
  } catch (const StateDiverged& e) {
    message = e.what();
  }
  EXPECT_EQ(stepped, 44);  // frames 1..44 solved, frame 45 refused
  EXPECT_EQ(message.rfind("frame 45: the simulation diverged: object 'sheet' vertex 0: a coordinate of 1.0", 0), 0u)
      << message;
  EXPECT_NE(message.find("beyond 1e+06 m"), std::string::npos) << message;
}

TEST(LevelStepper, ClampedStripSettlesToPlateTheoryDeflection) {
  // scenes/strip-cantilever.json: a strip clamped by two pinned vertex columns (one column would be a
  // hinge), Poisson ratio 0 so that plate and beam theory agree. Small-deflection theory: tip
  // deflection q L^4 / (8 D), q = rho t g, D = E t^3 / 12. Two pinned columns impose zero slope
  // across the first cell, so the clamp acts at mid-cell: L = 0.2 m free + dx/2. The scene's default
  // bending (midedge fit) gives the plate value on any split; the grid's diagonals alternate by row,
  // on which the hinge would be exact too (tests/physics/bending_plate_theory_test.cpp compares both
  // on every split). What remains is O(dx^2) discretisation, load lumping, (w/L)^2 ~ 1e-4 geometric
  // nonlinearity and the 1e-5 solver tolerance: measured 2e-4 (6e-4 with the hinge).
  const Scene scene = load_scene(test::source_dir() + "/scenes/strip-cantilever.json");
  SceneSystem sys = build_scene_system(scene);
  const Eigen::VectorXd x = run_scene(scene, sys);

  const Material& m = scene.objects[0].material;
  const double dx = 0.205 / 41, L = 0.2 + dx / 2, q = m.density * m.thickness * 9.81;
  const double D = m.youngs_modulus * std::pow(m.thickness, 3) / 12.0;
  const double theory = q * std::pow(L, 4) / (8 * D);
  const auto X = as_rows(sys.x0);
  const double x_tip = X.col(0).maxCoeff();
  double sag = 0;
  int tip_vertices = 0;
  for (int i = 0; i < sys.rest.num_vertices(); ++i)
    if (X(i, 0) > x_tip - 1e-9) {
      sag += X(i, 1) - x[3 * i + 1];
      ++tip_vertices;
    }
  sag /= tip_vertices;
  ASSERT_EQ(tip_vertices, 9);
  RecordProperty("tip_deflection_m", std::to_string(sag));
  RecordProperty("plate_theory_m", std::to_string(theory));
  std::printf("strip tip deflection %.6g m, plate theory %.6g m, ratio %.4f\n", sag, theory, sag / theory);
  EXPECT_NEAR(sag / theory, 1.0, 0.005);
}

TEST(LevelStepper, PressurisedSphereGrowsToTheStableVolumeOfTheNeoHookeanBalance) {
  // scenes/balloon.json: ideal gas (p V0 / V) inside a Neo-Hookean sphere. Under a uniform stretch s
  // (V = s^3 V0) the membrane density is mu (s^2 - 1 - 2 ln s) + 2 lambda (ln s)^2, so equilibrium is
  //   t A0 (2 mu (s^2 - 1) + 4 lambda ln s) = 3 p V0,
  // solved here by bisection with the discrete mesh's A0 and V0. The discrete equilibrium is not
  // exactly a uniform scaling (icosphere triangles differ), hence the tolerance.
  const Scene scene = load_scene(test::source_dir() + "/scenes/balloon.json");
  SceneSystem sys = build_scene_system(scene);
  const Faces& F = sys.rest.F;
  const double V0 = enclosed_volume(F, sys.x0);
  double A0 = 0;
  for (int f = 0; f < F.rows(); ++f) {
    const Vec3 a = sys.rest.V.row(F(f, 0)), b = sys.rest.V.row(F(f, 1)), c = sys.rest.V.row(F(f, 2));
    A0 += 0.5 * (b - a).cross(c - a).norm();
  }
  const Material& m = scene.objects[0].material;
  const auto params = MembraneMaterialParams::from(m.youngs_modulus, m.poisson_ratio, m.thickness);
  const double p = scene.objects[0].pressure->pressure;
  auto balance = [&](double s) {
    return m.thickness * A0 * (2 * params.mu * (s * s - 1) + 4 * params.lambda * std::log(s)) - 3 * p * V0;
  };
  double lo = 1.0, hi = 10.0;
  for (int i = 0; i < 200; ++i) (balance(0.5 * (lo + hi)) > 0 ? hi : lo) = 0.5 * (lo + hi);
  const double s_theory = 0.5 * (lo + hi);

  std::vector<double> volumes;
  run_scene(scene, sys, nullptr, [&](const FrameRecord& r) { volumes.push_back(enclosed_volume(F, r.x)); });
  const double s_sim = std::cbrt(volumes.back() / V0);
  std::printf("balloon stretch: simulated %.6f, theory %.6f\n", s_sim, s_theory);
  EXPECT_GT(s_theory, 1.05) << "the scene must inflate noticeably for this test to mean anything";
  EXPECT_NEAR(s_sim, s_theory, 0.01 * (s_theory - 1.0));
  // Stable: the volume has stopped changing over the last 20 frames.
  const double drift = std::abs(volumes.back() - volumes[volumes.size() - 21]) / volumes.back();
  EXPECT_LT(drift, 1e-6);
}

TEST(LevelStepper, NewtonConvergesQuadraticallyOnAHangingSheetStep) {
  // A sheet hanging from its whole top edge (Poisson ratio 0, so it is in tension with no lateral
  // compression: the potential is convex near the solution), 10 frames in; then one long step
  // (h = 0.1 s, so Newton starts far from the solution) solved with the exact Hessian and a tight
  // tolerance. Once the step is small, each Newton step must shrink at least quadratically.
  // (Where cloth is compressed the potential is non-convex and projected Newton is only linear.)
  Scene scene = make_scene(0.01, 10, Vec3(0, -9.81, 0));
  Material mat = test::cotton();
  mat.poisson_ratio = 0.0;
  scene.objects.push_back(make_object("sheet", make_rectangle(1.0, 1.0, 10, 10), mat));
  PinGroup pins;
  for (int i = 110; i <= 120; ++i) pins.vertices.push_back(i);  // the top row
  scene.objects[0].pins.push_back(pins);
  SceneSystem sys = build_scene_system(scene);
  Eigen::VectorXd v;
  Eigen::VectorXd x = run_scene(scene, sys, &v);

  SolverSettings exact = scene.solver;
  exact.projection = HessianProjection::None;
  exact.tolerance = 1e-12;
  LevelStepper exact_stepper(sys, exact, 0.1);
  const FrameRecord r = exact_stepper.step(scene.frames, x, v);
  const auto& m = r.newton.step_measures;
  ASSERT_GE(m.size(), 3u) << r.newton.stop_reason;
  int checked = 0;
  for (size_t k = 1; k < m.size(); ++k) {
    // Quadratic regime: relative to the first step, below 1e-2, and above round-off (1e-14).
    const double prev = m[k - 1] / m[0], cur = m[k] / m[0];
    if (prev < 1e-2 && cur > 1e-14) {
      EXPECT_LT(cur, 10.0 * prev * prev) << "iteration " << k;
      ++checked;
    }
  }
  std::string trace;
  char buf[32];
  for (double s : m) trace += (std::snprintf(buf, sizeof buf, "%.3e ", s), buf);
  EXPECT_GE(checked, 1) << "no iteration in the quadratic regime; step measures: " << trace;
}

TEST(LevelStepper, ExactFirstSolvesASaggingSheetInNoMoreIterationsThanClampAndRefinesItsFallbacks) {
  // A sheet held at its two top corners sags into folds: compressed membrane triangles and bent
  // hinges with indefinite element Hessians, the case exact_first is for (docs/performance.md,
  // "Which Hessian projection"). Same equations, same tolerance: the frames agree to within the
  // motion's sensitivity, and the exact Hessian must not cost iterations.
  // A direct system's Hessian is the potential's own, so the stepper refines the fallbacks' clamped
  // steps on it (solver/exact_curvature_step.h).
  const auto run = [](HessianProjection projection, int* iterations, int* fallbacks, int* exact, int* refined) {
    // Long steps (h = 0.05 s) so the inertia term's M / h^2 no longer keeps every assembled
    // system positive definite.
    Scene scene = make_scene(0.05, 20, Vec3(0, -9.81, 0));
    scene.objects.push_back(make_object("sheet", make_rectangle(1.0, 1.0, 16, 16), test::cotton()));
    PinGroup pins;
    pins.vertices = {272, 288};  // the top corners of the 17 x 17 grid
    scene.objects[0].pins.push_back(pins);
    scene.solver.projection = projection;
    SceneSystem sys = build_scene_system(scene);
    *iterations = *fallbacks = *exact = *refined = 0;
    return run_scene(scene, sys, nullptr, [&](const FrameRecord& r) {
      *iterations += r.newton.iterations;
      *fallbacks += r.newton.projection_fallbacks;
      *exact += r.newton.exact_hessians;
      *refined += r.newton.exact_curvature_iterations;
    });
  };
  int clamp_its = 0, clamp_fallbacks = 0, clamp_exact = 0, clamp_refined = 0;
  int exact_its = 0, exact_fallbacks = 0, exact_solves = 0, exact_refined = 0;
  const Eigen::VectorXd clamp = run(HessianProjection::Clamp, &clamp_its, &clamp_fallbacks, &clamp_exact, &clamp_refined);
  const Eigen::VectorXd exact =
      run(HessianProjection::ExactFirst, &exact_its, &exact_fallbacks, &exact_solves, &exact_refined);
  std::printf("sagging sheet, 20 steps: clamp %d Newton iterations, exact_first %d (%d exact, %d fallbacks, "
              "%d CG iterations refining them)\n",
              clamp_its, exact_its, exact_solves, exact_fallbacks, exact_refined);
  EXPECT_EQ(clamp_exact, 0) << "only exact_first counts exact solves";
  EXPECT_GT(exact_solves, 0) << "the exact Hessian must be used, or this compares clamp with itself";
  EXPECT_EQ(clamp_fallbacks, 0) << "only exact_first falls back";
  EXPECT_GT(exact_fallbacks, 0) << "the long steps must make an exact system indefinite, or the fallback is untested";
  EXPECT_EQ(clamp_refined, 0) << "clamp never assembles the exact Hessian";
  EXPECT_GT(exact_refined, 0) << "the stepper must turn the refinement on for a direct system";
  EXPECT_LE(exact_its, clamp_its);
  EXPECT_LT((clamp - exact).lpNorm<Eigen::Infinity>(), 1e-3) << "m, same equations and tolerance";
}

TEST(LevelStepper, CurvedRestShapeStaysAtRestWithoutGravity) {
  // Rest dihedral angles come from the rest mesh, so a sphere has no bending force at rest.
  Scene scene = make_scene(0.01, 10, Vec3::Zero());
  scene.objects.push_back(make_object("sphere", make_icosphere(0.1, 2), test::cotton()));
  SceneSystem sys = build_scene_system(scene);
  Eigen::VectorXd v;
  const Eigen::VectorXd x = run_scene(scene, sys, &v);
  EXPECT_LT((x - sys.x0).lpNorm<Eigen::Infinity>(), 1e-12);
  EXPECT_LT(v.lpNorm<Eigen::Infinity>(), 1e-10);
}

TEST(LevelStepper, ScriptedPinsFollowTheirScriptExactly) {
  Scene scene = make_scene(0.01, 20, Vec3(0, -9.81, 0));
  scene.objects.push_back(make_object("sheet", make_rectangle(1.0, 1.0, 6, 6), test::cotton()));
  PinGroup pins;
  pins.vertices = {0, 6};  // the two bottom corners
  PinScript script;
  script.angular_velocity = Vec3(0, 0, 1.5);
  script.velocity = Vec3(0.2, 0, 0);
  script.end = 0.1;
  pins.script = script;
  scene.objects[0].pins.push_back(pins);
  SceneSystem sys = build_scene_system(scene);
  const Eigen::VectorXd x = run_scene(scene, sys);
  // After the script ends (t = 0.1 s) the pins stay where it left them: rotated by 0.15 rad about
  // the origin and moved 0.02 m along x.
  const Mat3 R = Eigen::AngleAxisd(0.15, Vec3::UnitZ()).toRotationMatrix();
  for (int i : {0, 6}) {
    const Vec3 expected = R * sys.x0.segment<3>(3 * i) + Vec3(0.02, 0, 0);
    EXPECT_LT((x.segment<3>(3 * i) - expected).norm(), 1e-14) << "vertex " << i;
  }
}

TEST(LevelStepper, KeyframedPinsFollowTheInterpolatedPoses) {
  Scene scene = make_scene(0.01, 15, Vec3(0, -9.81, 0));
  scene.objects.push_back(make_object("sheet", make_rectangle(1.0, 1.0, 6, 6), test::cotton()));
  PinGroup pins;
  pins.vertices = {0, 6};
  PinScript script;
  Keyframe up;
  up.time = 0.1;
  up.translation = Vec3(0, 0.05, 0);
  up.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Vec3::UnitY()));
  script.keyframes = {Keyframe{}, up};
  pins.script = script;
  scene.objects[0].pins.push_back(pins);
  SceneSystem sys = build_scene_system(scene);
  // Half way (t = 0.05 s): half the translation and half the rotation angle (slerp).
  const Mat3 half = Eigen::AngleAxisd(0.15, Vec3::UnitY()).toRotationMatrix();
  const Vec3 x0 = sys.x0.segment<3>(0);
  EXPECT_LT((pin_position(sys, sys.pins[0], 0.05) - (half * x0 + Vec3(0, 0.025, 0))).norm(), 1e-14);
  // After the last keyframe the pose is held.
  const Eigen::VectorXd x = run_scene(scene, sys);
  const Mat3 full = Eigen::AngleAxisd(0.3, Vec3::UnitY()).toRotationMatrix();
  for (int k = 0; k < 2; ++k) {
    const int i = sys.pins[k].vertex;
    EXPECT_LT((x.segment<3>(3 * i) - (full * sys.x0.segment<3>(3 * i) + Vec3(0, 0.05, 0))).norm(), 1e-14);
  }
}

TEST(LevelStepper, SameInputsGiveBitIdenticalFrames) {
  auto run = [] {
    Scene scene = make_scene(0.01, 15, Vec3(0, -9.81, 0));
    scene.objects.push_back(make_object("sheet", make_rectangle(1.0, 1.0, 8, 8), test::cotton()));
    PinGroup pins;
    pins.vertices = {72, 80};  // top corners
    scene.objects[0].pins.push_back(pins);
    Wind wind;
    wind.air_velocity = Vec3(0, 0, 3);
    wind.gust_amplitude = 0.5;
    wind.gust_frequency = 2;
    scene.wind = wind;
    SceneSystem sys = build_scene_system(scene);
    return run_scene(scene, sys);
  };
  const Eigen::VectorXd a = run(), b = run();
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), sizeof(double) * a.size()), 0);
}

TEST(LevelStepper, WindPushesAHangingSheetDownwind) {
  auto final_com_z = [](bool with_wind) {
    Scene scene = make_scene(0.02, 30, Vec3(0, -9.81, 0));
    scene.objects.push_back(make_object("sheet", make_rectangle(1.0, 1.0, 6, 6), test::cotton()));
    PinGroup pins;
    pins.vertices = {42, 48};
    scene.objects[0].pins.push_back(pins);
    if (with_wind) {
      Wind wind;
      wind.air_velocity = Vec3(0, 0, 5);
      scene.wind = wind;
    }
    SceneSystem sys = build_scene_system(scene);
    return centers_of_mass(sys, run_scene(scene, sys))(0, 2);
  };
  EXPECT_NEAR(final_com_z(false), 0.0, 1e-9);  // symmetric: no out-of-plane motion without wind
  EXPECT_GT(final_com_z(true), 0.05);           // wind blows along +z
}

}  // namespace
}  // namespace pd
