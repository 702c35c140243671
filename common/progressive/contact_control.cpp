#include "progressive/contact_control.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>

#include "geometry/topology.h"
#include "physics/contact/barrier_potential.h"
#include "physics/contact/friction.h"
#include "physics/contact/ground_barrier.h"
#include "physics/contact/start_check.h"
#include "physics/strain_limit.h"
#include "progressive/scene_system.h"
#include "util/input_error.h"

namespace pd {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Every face and edge of the scene, with each vertex's object and each object's self-contact flag.
ContactPrimitives scene_primitives(const Scene& scene, const SceneSystem& sys) {
  ContactPrimitives p;
  p.faces = sys.rest.F;
  p.vertex_object.resize(sys.rest.num_vertices());
  for (std::size_t o = 0; o < scene.objects.size(); ++o) {
    const int off = sys.object_offsets[o];
    for (int v = off; v < sys.object_offsets[o + 1]; ++v) p.vertex_object[v] = static_cast<int>(o);
    for (const auto& e : build_topology(scene.objects[o].rest).edges) p.edges.push_back({e[0] + off, e[1] + off});
    p.object_self_contact.push_back(scene.objects[o].self_contact ? 1 : 0);
  }
  return p;
}

// Friction coefficient per pair of objects: the scene's default, then its per-pair overrides.
Eigen::MatrixXd friction_matrix(const ContactConfig& c, int objects) {
  Eigen::MatrixXd mu = Eigen::MatrixXd::Constant(objects, objects, c.friction);
  for (const auto& p : c.pair_friction) mu(p.a, p.b) = mu(p.b, p.a) = p.mu;
  return mu;
}

std::string format_length(double metres) {
  std::ostringstream out;
  out.precision(4);
  out << metres * 1e3 << " mm";
  return out.str();
}

}  // namespace

void ContactControl::set_kappa(double kappa) {
  kappa_ = kappa;
  if (mesh) mesh->set_kappa(kappa);
  if (ground) ground->set_kappa(kappa);
}

void ContactControl::restore_kappa(double kappa) {
  if (!(kappa > 0.0) || !std::isfinite(kappa))
    throw std::invalid_argument("restore_kappa: the barrier stiffness must be finite and > 0");
  if (!has_barrier()) return;
  set_kappa(kappa);
  kappa_initialized_ = true;
}

void ContactControl::begin_step(const IncrementalPotential& ip, const StepStart& step) {
  if (!has_barrier()) return;
  const Eigen::VectorXd& x = *step.x;
  if (adaptive_ && !kappa_initialized_) {
    // Gradient balance at the start of the first step only, over free dofs (IPC). Balancing again
    // at every step refits kappa so that the barrier cancels as much as it can of the forces at
    // that instant, including in-plane ones through pairs beside a vertex (a cloth vertex near a
    // shared edge of a flat obstacle), which makes every step start close to an equilibrium: a
    // sheet on a 35 degree slope with friction 0.5 stayed put with kappa refitted every step
    // (2.1e6) and slid as Coulomb predicts with the first step's kappa (1.5e6) kept.
    Eigen::VectorXd unit = Eigen::VectorXd::Zero(x.size());
    if (mesh) unit += mesh->unit_stiffness_gradient(x);
    if (ground) unit += ground->unit_stiffness_gradient(x);
    for (Eigen::Index i = 0; i < unit.size(); ++i)
      if (fixed_[i]) unit[i] = 0;
    const Eigen::VectorXd energy_gradient = ip.gradient(x) - kappa_ * unit;
    set_kappa(initial_barrier_stiffness(energy_gradient, unit, bounds_));
    kappa_initialized_ = true;
  }
  prev_min_gap_ = min_gap(x);
  // Friction lags its normal forces from kappa: lag again now that kappa is final for this start.
  if (friction) friction->begin_step(step);
}

bool ContactControl::after_iteration(const Eigen::VectorXd& x) {
  if (!has_barrier() || !adaptive_) return false;
  const double gap = min_gap(x);
  const double kappa = update_barrier_stiffness(prev_min_gap_, gap, dhat_, kappa_, bounds_.kappa_max);
  prev_min_gap_ = gap;
  if (kappa == kappa_) return false;
  set_kappa(kappa);
  return true;
}

double ContactControl::min_gap(const Eigen::VectorXd& x) const {
  double gap = kInf;
  if (mesh) gap = std::min(gap, mesh->stats(x).min_gap);
  if (ground) gap = std::min(gap, ground->stats(x).min_gap);
  return gap;
}

std::vector<std::pair<std::string, double>> ContactControl::stats(const Eigen::VectorXd& x) const {
  std::vector<std::pair<std::string, double>> out;
  if (has_barrier()) {
    int active = 0;
    double gap = kInf;
    if (mesh) {
      const ContactStats s = mesh->stats(x);
      active += s.active_point_triangle + s.active_edge_edge;
      gap = std::min(gap, s.min_gap);
    }
    if (ground) {
      const ContactStats s = ground->stats(x);
      active += s.active_point_triangle;
      gap = std::min(gap, s.min_gap);
    }
    out.emplace_back("contact_active_pairs", active);
    out.emplace_back("contact_min_gap", gap);
    out.emplace_back("barrier_stiffness", kappa_);
  }
  if (friction) out.emplace_back("friction_contacts", static_cast<double>(friction->contacts().size()));
  if (!strain_limits.empty()) {
    double stretch = 0;
    for (const StrainLimitTerm* s : strain_limits) stretch = std::max(stretch, s->max_stretch(x));
    out.emplace_back("max_stretch", stretch);
  }
  return out;
}

void add_contact_terms(const Scene& scene, SceneSystem& sys) {
  ContactControl& c = sys.contact;
  c.fixed_ = sys.ip.fixed_dofs();
  for (std::size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    if (!obj.strain_limit) continue;
    const Faces F = sys.rest.F.middleRows(sys.object_face_offsets[o], obj.rest.num_faces());
    StrainLimitSettings s =
        StrainLimitSettings::from(obj.strain_limit->limit, obj.material.youngs_modulus, obj.material.thickness);
    if (obj.strain_limit->barrier_start) s.activation = s.limit - *obj.strain_limit->barrier_start;
    if (obj.strain_limit->stiffness) s.stiffness = *obj.strain_limit->stiffness;
    check_strain_limit_settings(s);
    auto term = std::make_unique<StrainLimitTerm>(F, sys.rest.V, s);
    c.strain_limits.push_back(term.get());
    c.strain_limit_objects.push_back(static_cast<int>(o));
    sys.ip.add_term(std::move(term));
  }
  if (!scene.contact) return;
  const ContactConfig& cfg = *scene.contact;
  ContactSettings settings;
  settings.dhat = cfg.dhat;
  settings.offset = cfg.offset;
  settings.ccd_ratio = cfg.ccd_ratio;
  c.dhat_ = cfg.dhat;
  c.adaptive_ = !cfg.stiffness;
  const double h = scene.time_step;
  c.bounds_ = barrier_stiffness_bounds(cfg.dhat, cfg.offset, sys.bbox_diagonal, sys.average_free_mass > 0 ? sys.average_free_mass : 1.0, h);
  settings.kappa = cfg.stiffness ? *cfg.stiffness : c.bounds_.kappa_min;
  c.kappa_ = settings.kappa;

  const int objects = static_cast<int>(scene.objects.size());
  const Eigen::MatrixXd mu = friction_matrix(cfg, objects);
  auto mesh = std::make_unique<BarrierPotential>(scene_primitives(scene, sys), sys.rest.V, settings);
  if (mu.maxCoeff() > 0) mesh->set_friction(mu);
  c.mesh = mesh.get();
  sys.ip.add_term(std::move(mesh));

  if (scene.ground) {
    std::vector<int> vertices;
    for (int o = 0; o < objects; ++o)
      if (scene.objects[o].ground_contact)
        for (int v = sys.object_offsets[o]; v < sys.object_offsets[o + 1]; ++v) vertices.push_back(v);
    if (!vertices.empty()) {
      auto ground = std::make_unique<GroundBarrier>(std::move(vertices), scene.ground->normal,
                                                    scene.ground->height, settings, scene.ground->friction);
      c.ground = ground.get();
      sys.ip.add_term(std::move(ground));
    }
  }

  const bool any_friction = mu.maxCoeff() > 0 || (c.ground && scene.ground->friction > 0);
  if (any_friction) {
    auto friction = std::make_unique<FrictionTerm>(cfg.eps_v);
    friction->add_source(c.mesh);
    if (c.ground) friction->add_source(c.ground);
    c.friction = friction.get();
    sys.ip.add_term(std::move(friction));
  }
}

void check_start_state(const Scene& scene, const SceneSystem& sys) {
  const std::string where = scene.source_path.empty() ? scene.name : scene.source_path;
  const ContactControl& c = sys.contact;
  if (c.mesh) {
    const auto violations = find_start_violations(c.mesh->primitives(), as_rows(sys.x0), c.mesh->settings().offset);
    if (!violations.empty()) {
      std::string msg = where + ": contact: the objects start intersecting or closer than the contact offset (" +
                        format_length(c.mesh->settings().offset) + "), which IPC cannot start from:";
      for (const auto& v : violations) msg += "\n  " + describe(v, sys.object_names);
      throw InputError(msg);
    }
  }
  if (c.ground) {
    const std::vector<int> below = c.ground->vertices_below(sys.x0);
    if (!below.empty()) {
      const int v = below.front();
      const int o = static_cast<int>(std::upper_bound(sys.object_offsets.begin(), sys.object_offsets.end(), v) -
                                     sys.object_offsets.begin()) - 1;
      throw InputError(where + ": ground: " + std::to_string(below.size()) +
                       " vertices start at or below the ground plus the contact offset, e.g. object '" +
                       sys.object_names[o] + "' vertex " + std::to_string(v - sys.object_offsets[o]) +
                       " (move the object up or the ground down)");
    }
  }
  for (std::size_t k = 0; k < c.strain_limits.size(); ++k) {
    const double stretch = c.strain_limits[k]->max_stretch(sys.x0);
    const double limit = c.strain_limits[k]->settings().limit;
    if (!(stretch < limit)) {
      std::ostringstream msg;
      msg << where << ": objects[" << c.strain_limit_objects[k] << "].strain_limit.limit: object '"
          << sys.object_names[c.strain_limit_objects[k]] << "' starts stretched to " << stretch
          << " (largest singular value of a triangle's deformation gradient), at or above its limit " << limit
          << "; raise the limit or start from a less stretched pose";
      throw InputError(msg.str());
    }
  }
}

}  // namespace pd
