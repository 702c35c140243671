// Behaviour of implicit-Euler stepping on whole scenes, against closed forms and plate theory.
#include "progressive/level_stepper.h"

#include <gtest/gtest.h>

#include <cmath>

#include "geometry/shapes.h"
#include "physics/membrane_neo_hookean.h"
#include "progressive/test_scenes.h"

namespace pd {
namespace {

using test::make_object;
using test::make_scene;

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
  LevelStepper stepper(sys, scene.solver, h);
  Eigen::VectorXd x = sys.x0, v = sys.v0;
  for (int n = 0; n < scene.frames; ++n) {
    const FrameRecord r = stepper.step(n, x, v);
    ASSERT_TRUE(r.newton.converged) << "frame " << n + 1;
  }
  const int N = scene.frames;
  const Vec3 expected_shift = N * h * v0 + h * h * g * (N * (N + 1) / 2.0);
  for (int i = 0; i < sys.rest.num_vertices(); ++i) {
    const Vec3 shift = x.segment<3>(3 * i) - sys.x0.segment<3>(3 * i);
    EXPECT_LT((shift - expected_shift).norm(), 1e-9 * expected_shift.norm()) << "vertex " << i;
    EXPECT_LT((v.segment<3>(3 * i) - (v0 + N * h * g)).norm(), 1e-8) << "vertex " << i;
  }
}

TEST(LevelStepper, CurvedRestShapeStaysAtRestWithoutGravity) {
  // Rest dihedral angles come from the rest mesh, so a sphere has no bending force at rest.
  Scene scene = make_scene(0.01, 10, Vec3::Zero());
  scene.objects.push_back(make_object("sphere", make_icosphere(0.1, 2), test::cotton()));
  SceneSystem sys = build_scene_system(scene);
  LevelStepper stepper(sys, scene.solver, scene.time_step);
  Eigen::VectorXd x = sys.x0, v = sys.v0;
  for (int n = 0; n < scene.frames; ++n) stepper.step(n, x, v);
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
  LevelStepper stepper(sys, scene.solver, scene.time_step);
  Eigen::VectorXd x = sys.x0, v = sys.v0;
  for (int n = 0; n < scene.frames; ++n) stepper.step(n, x, v);
  // After the script ends (t = 0.1 s) the pins stay where it left them: rotated by 0.15 rad about
  // the origin and moved 0.02 m along x.
  const Mat3 R = Eigen::AngleAxisd(0.15, Vec3::UnitZ()).toRotationMatrix();
  for (int i : {0, 6}) {
    const Vec3 expected = R * sys.x0.segment<3>(3 * i) + Vec3(0.02, 0, 0);
    EXPECT_LT((x.segment<3>(3 * i) - expected).norm(), 1e-14) << "vertex " << i;
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
    LevelStepper stepper(sys, scene.solver, scene.time_step);
    Eigen::VectorXd x = sys.x0, v = sys.v0;
    for (int n = 0; n < scene.frames; ++n) stepper.step(n, x, v);
    return x;
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
    LevelStepper stepper(sys, scene.solver, scene.time_step);
    Eigen::VectorXd x = sys.x0, v = sys.v0;
    for (int n = 0; n < scene.frames; ++n) stepper.step(n, x, v);
    return centers_of_mass(sys, x)(0, 2);
  };
  EXPECT_NEAR(final_com_z(false), 0.0, 1e-9);  // symmetric: no out-of-plane motion without wind
  EXPECT_GT(final_com_z(true), 0.05);           // wind blows along +z
}

}  // namespace
}  // namespace pd
