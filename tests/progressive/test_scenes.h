#pragma once
// Small scenes built in code for the stepping tests (no JSON involved, so these tests check the
// physics and the stepper, not the parser).
#include "geometry/shapes.h"
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

}  // namespace pd::test
