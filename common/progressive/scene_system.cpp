#include "progressive/scene_system.h"

#include <algorithm>
#include <memory>

#include <Eigen/Geometry>

#include "geometry/topology.h"
#include "physics/bending_hinge.h"
#include "physics/bending_midedge_fit.h"
#include "physics/gravity.h"
#include "physics/inertia.h"
#include "physics/membrane_neo_hookean.h"
#include "physics/pin_target.h"
#include "physics/pressure.h"
#include "physics/wind.h"

namespace pd {

namespace {

// Faces of object k shifted to global vertex indices.
Faces offset_faces(const Faces& F, int offset) {
  Faces out = F;
  out.array() += offset;
  return out;
}

// Pins an object's group (object-local vertices, object's first global vertex `offset`).
void add_pins(const PinGroup& group, int offset, SceneSystem& sys) {
  int script = -1;
  if (group.script) {
    script = static_cast<int>(sys.scripts.size());
    sys.scripts.push_back(*group.script);
  }
  // An animated obstacle's vertex v follows the animation's vertex v: its level mesh is its finest
  // mesh on every level (scene_hierarchy.cpp keeps it whole), so the ids agree.
  const bool animated = group.script && group.script->animation;
  for (int v : group.vertices)
    sys.pins.push_back({offset + v, sys.x0.segment<3>(3 * (offset + v)), script, animated ? v : -1});
}

// Where a vertex starting at X is at time t under keyframed motion (see PinScript).
Vec3 keyframed_position(const std::vector<Keyframe>& keys, const Vec3& X, double t) {
  if (t <= keys.front().time) return keys.front().rotation * X + keys.front().translation;
  if (t >= keys.back().time) return keys.back().rotation * X + keys.back().translation;
  const auto next = std::upper_bound(keys.begin(), keys.end(), t,
                                     [](double time, const Keyframe& k) { return time < k.time; });
  const Keyframe& a = *(next - 1);
  const Keyframe& b = *next;
  const double s = (t - a.time) / (b.time - a.time);
  return a.rotation.slerp(s, b.rotation) * X + (1.0 - s) * a.translation + s * b.translation;
}

}  // namespace

void add_shell_forces(const SceneObject& obj, const Faces& faces, int offset, const Positions& rest,
                      const Eigen::VectorXd& initial, std::vector<std::unique_ptr<EnergyTerm>>& terms) {
  const Material& mat = obj.material;
  terms.push_back(std::make_unique<NeoHookeanMembrane>(
      faces, rest, MembraneMaterialParams::from(mat.youngs_modulus, mat.poisson_ratio, mat.thickness)));
  // Bending needs an interior edge (a lone triangle cannot bend); the material picks the model.
  std::vector<Hinge> hinges = build_topology(obj.rest).hinges;
  if (!hinges.empty() && mat.bending_model == BendingModel::MidedgeFit) {
    terms.push_back(std::make_unique<MidedgeFitBending>(faces, rest, mat.bending_rigidity(), mat.poisson_ratio));
  } else if (!hinges.empty()) {
    for (auto& hg : hinges)
      for (int& v : hg.v) v += offset;
    terms.push_back(std::make_unique<HingeBending>(hinges, rest, mat.bending_rigidity()));
  }
  if (obj.pressure) terms.push_back(std::make_unique<PressureTerm>(faces, initial, *obj.pressure));
}

SceneSystem build_scene_system(const Scene& scene, bool own_shell_forces) {
  SceneSystem sys;
  int n = 0, m = 0;
  sys.object_offsets.push_back(0);
  sys.object_face_offsets.push_back(0);
  for (const auto& obj : scene.objects) {
    n += obj.rest.num_vertices();
    m += obj.rest.num_faces();
    sys.object_offsets.push_back(n);
    sys.object_face_offsets.push_back(m);
    sys.object_names.push_back(obj.name);
  }
  sys.rest.V.resize(n, 3);
  sys.rest.F.resize(m, 3);
  sys.masses = Eigen::VectorXd::Zero(3 * n);
  sys.x0.resize(3 * n);
  sys.v0.resize(3 * n);

  // Per-object terms; each object has its own material, so its own term instances.
  std::vector<std::unique_ptr<EnergyTerm>> terms;
  int face_offset = 0;
  for (size_t k = 0; k < scene.objects.size(); ++k) {
    const SceneObject& obj = scene.objects[k];
    const int off = sys.object_offsets[k];
    const int nv = obj.rest.num_vertices();
    sys.rest.V.middleRows(off, nv) = obj.rest.V;
    const Faces F = offset_faces(obj.rest.F, off);
    sys.rest.F.middleRows(face_offset, obj.rest.num_faces()) = F;
    face_offset += obj.rest.num_faces();
    for (int i = 0; i < nv; ++i) {
      sys.x0.segment<3>(3 * (off + i)) = obj.initial.row(i).transpose();
      sys.v0.segment<3>(3 * (off + i)) = obj.initial_velocity;
    }
    if (obj.obstacle) {
      // Every vertex follows the motion (or stays); nothing else about an obstacle is simulated.
      PinGroup all;
      all.vertices.resize(nv);
      for (int i = 0; i < nv; ++i) all.vertices[i] = i;
      all.script = obj.motion;
      add_pins(all, off, sys);
      continue;
    }
    const Material& mat = obj.material;
    sys.masses.segment(3 * off, 3 * nv) = lumped_masses(obj.rest.F, obj.rest.V, mat.density * mat.thickness);

    if (own_shell_forces) add_shell_forces(obj, F, off, sys.rest.V, sys.x0, terms);
    if (scene.wind && obj.wind) terms.push_back(std::make_unique<WindTerm>(F, *scene.wind));

    for (const auto& group : obj.pins) add_pins(group, off, sys);
  }

  // Inertia first, gravity (only when non-zero) next, then elasticity and the rest.
  auto inertia = std::make_unique<InertiaTerm>(sys.masses);
  sys.inertia = inertia.get();
  sys.ip.add_term(std::move(inertia));
  if (scene.gravity.squaredNorm() > 0) sys.ip.add_term(std::make_unique<GravityTerm>(sys.masses, scene.gravity));
  for (auto& t : terms) sys.ip.add_term(std::move(t));

  std::vector<int> scripted;
  for (const auto& pin : sys.pins)
    if (pin.script >= 0) scripted.push_back(pin.vertex);
  if (!scripted.empty()) {
    auto pull = std::make_unique<PinTargetTerm>(std::move(scripted));
    sys.pin_target = pull.get();
    sys.ip.add_term(std::move(pull));
  }
  double mass_sum = 0;
  int massive = 0;
  for (int i = 0; i < n; ++i)
    if (sys.masses[3 * i] > 0) mass_sum += sys.masses[3 * i], ++massive;
  sys.average_free_mass = massive ? mass_sum / massive : 0.0;

  std::vector<char> fixed(3 * n, 0);
  for (const auto& pin : sys.pins) fixed[3 * pin.vertex] = fixed[3 * pin.vertex + 1] = fixed[3 * pin.vertex + 2] = 1;
  sys.ip.set_fixed_dofs(std::move(fixed));

  const auto X = as_rows(sys.x0);
  sys.bbox_diagonal = (X.colwise().maxCoeff() - X.colwise().minCoeff()).norm();
  add_contact_terms(scene, sys);
  return sys;
}

Vec3 pin_position(const SceneSystem& sys, const PinnedVertex& pin, double t) {
  if (pin.script < 0) return pin.start;
  const PinScript& s = sys.scripts[pin.script];
  if (s.animation) return s.animation->position(pin.source, t);
  if (!s.keyframes.empty()) return keyframed_position(s.keyframes, pin.start, t);
  const double tau = std::clamp(t - s.start, 0.0, s.end - s.start);
  const double rate = s.angular_velocity.norm();
  Mat3 R = Mat3::Identity();
  if (rate > 0) R = Eigen::AngleAxisd(rate * tau, s.angular_velocity / rate).toRotationMatrix();
  return s.center + R * (pin.start - s.center) + s.velocity * tau;
}

Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> centers_of_mass(const SceneSystem& sys,
                                                                          const Eigen::VectorXd& x) {
  const int k = static_cast<int>(sys.object_names.size());
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> com(k, 3);
  for (int o = 0; o < k; ++o) {
    Vec3 sum = Vec3::Zero();
    double mass = 0;
    for (int v = sys.object_offsets[o]; v < sys.object_offsets[o + 1]; ++v) {
      sum += sys.masses[3 * v] * x.segment<3>(3 * v);
      mass += sys.masses[3 * v];
    }
    if (mass > 0) {
      com.row(o) = (sum / mass).transpose();
    } else {
      const int first = sys.object_offsets[o], count = sys.object_offsets[o + 1] - first;
      com.row(o) = as_rows(x).middleRows(first, count).colwise().mean();
    }
  }
  return com;
}

}  // namespace pd
