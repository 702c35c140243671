#pragma once
// Small scenes built in code for the stepping tests (no JSON involved, so these tests check the
// physics and the stepper, not the parser).
#include <functional>

#include <gtest/gtest.h>

#include "geometry/shapes.h"
#include "progressive/level_stepper.h"
#include "scene/scene.h"

namespace pd::test {

inline SceneObject make_object(const std::string& name, const TriMesh& mesh, const Material& mat) {
  SceneObject o;
  o.name = name;
  o.rest = mesh;
  o.initial = mesh.V;
  o.material = mat;
  return o;
}

inline Material cotton() {
  Material m;
  m.density = 472.6;   // kg/m^3
  m.youngs_modulus = 0.8e6;
  m.poisson_ratio = 0.3;
  m.thickness = 3.2e-4;
  return m;
}

inline Scene make_scene(double h, int frames, const Vec3& gravity) {
  Scene s;
  s.name = "test";
  s.time_step = h;
  s.frames = frames;
  s.gravity = gravity;
  return s;
}

// Steps all of the scene's frames from the system's initial state, expecting every step to
// converge. Returns the final positions; `v` (optional) receives the final velocities and
// `on_frame` (optional) sees every solved frame.
inline Eigen::VectorXd run_scene(const Scene& scene, SceneSystem& sys, Eigen::VectorXd* v = nullptr,
                                 const std::function<void(const FrameRecord&)>& on_frame = {}) {
  LevelStepper stepper(sys, scene.solver, scene.time_step);
  Eigen::VectorXd x = sys.x0, vel = sys.v0;
  for (int n = 0; n < scene.frames; ++n) {
    const FrameRecord r = stepper.step(n, x, vel);
    EXPECT_TRUE(r.newton.converged) << "frame " << n + 1 << ": " << r.newton.stop_reason;
    if (on_frame) on_frame(r);
  }
  if (v) *v = vel;
  return x;
}

}  // namespace pd::test
