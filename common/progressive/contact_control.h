#pragma once
// The contact part of a scene's discrete system: builds the contact terms a scene declares (mesh
// barrier, ground, friction, strain limits) into its incremental potential, adapts the shared
// barrier stiffness kappa (IPC), refuses start states that already intersect, and reports
// per-frame contact statistics.
//
// kappa (J/m^4) is one value for the mesh barrier and the ground, as in IPC: at the start of the
// first step it is set by gradient balance (barrier.h: initial_barrier_stiffness), and after every
// Newton iteration it is doubled when the smallest gap keeps shrinking below 1e-6 dhat
// (update_barrier_stiffness); it never decreases. A scene that gives contact.stiffness keeps that
// value throughout.
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "physics/contact/barrier.h"
#include "physics/energy_term.h"
#include "scene/scene.h"

namespace pd {

class BarrierPotential;
class GroundBarrier;
class FrictionTerm;
class StrainLimitTerm;
class IncrementalPotential;
struct SceneSystem;

class ContactControl {
 public:
  // Terms (owned by the system's incremental potential); null / empty when the scene lacks them.
  BarrierPotential* mesh = nullptr;
  GroundBarrier* ground = nullptr;
  FrictionTerm* friction = nullptr;
  std::vector<StrainLimitTerm*> strain_limits;
  std::vector<int> strain_limit_objects;  // object index of each strain-limit term

  bool has_barrier() const { return mesh || ground; }

  // Before the Newton iterations of a step, after the potential's begin_step (the inertia target
  // must be set for the gradient balance): sets the initial kappa on the first step, then re-lags
  // friction with the current kappa.
  void begin_step(const IncrementalPotential& ip, const StepStart& step);
  // After each accepted Newton iterate x: the IPC doubling rule. Returns true if kappa changed.
  bool after_iteration(const Eigen::VectorXd& x);

  double kappa() const { return kappa_; }
  // Continues a run whose barrier stiffness was `kappa` (J/m^4, > 0; the barrier_stiffness stat of
  // the frame it continues from) instead of balancing it afresh at the first step: a task that
  // continues a level from its own frames then repeats the single run bit for bit.
  void restore_kappa(double kappa);
  // Frame statistics at x (names as stored under /levels/<l>/stats/): contact_active_pairs,
  // contact_min_gap (m, +inf without pairs within dhat), barrier_stiffness (J/m^4),
  // friction_contacts, max_stretch (strain-limited objects only).
  std::vector<std::pair<std::string, double>> stats(const Eigen::VectorXd& x) const;

  // Smallest gap (distance minus offset, m) over active mesh pairs and ground vertices; +inf if none.
  double min_gap(const Eigen::VectorXd& x) const;

 private:
  friend void add_contact_terms(const Scene& scene, SceneSystem& sys);
  void set_kappa(double kappa);

  bool adaptive_ = true;
  double dhat_ = 0.0;
  BarrierStiffnessBounds bounds_;
  double kappa_ = 0.0;
  bool kappa_initialized_ = false;
  double prev_min_gap_ = 0.0;
  std::vector<char> fixed_;  // per dof, as the potential's (pinned gradients do not count)
};

// Adds the scene's contact and strain-limit terms to sys.ip and fills sys.contact. Call after the
// elastic terms and pins are in place (needs masses, fixed dofs and the bounding box).
void add_contact_terms(const Scene& scene, SceneSystem& sys);

// Throws InputError "<scene file>: <what>" when the initial state already violates the contact
// (an intersection, a gap at or below the offset, a vertex under the ground) or a strain limit:
// IPC cannot start from there. Names the objects and primitives involved.
void check_start_state(const Scene& scene, const SceneSystem& sys);

}  // namespace pd
