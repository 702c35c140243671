#pragma once
// The discrete system of one level of a scene's hierarchy for Progressive Dynamics (PD eqs. 4 and 6):
//
//   1/(2h^2) ||x - xhat||^2_{M_l} + gravity, wind, pressure on level l + C_l(x) + Psi_L(P^l(x))
//
// Level l's own mesh carries the inertia (masses lumped on its rest shape), gravity, wind, pins,
// obstacles, contact and strain limits (C_l: "the sum of remaining current level-l contact and
// strain-limiting potentials"); the shell forces (membrane, bending and internal pressure) are the
// finest level's, evaluated on the prolonged shape P^l(x) with its exact gradient
// (progressive/prolonged_term.h). At the finest level P^L is the identity and the system is the
// plain one (build_scene_system).
//
// Pressure is prolonged with the elasticity: the gas fills the finest surface, whose volume a coarse
// polyhedron underestimates (ball-drop's 40-vertex level holds 6.7% less than its 642-vertex one). Wind
// stays on level l: it is a drag on the surface the level moves, lagged from its own velocities.
//
// Conventions: level 0 = coarsest, L = hierarchy.finest(); global vertex ids of the level (objects
// stacked as in SceneLevel); stacked vectors x[3i + k] (m).
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hierarchy/scene_hierarchy.h"
#include "progressive/prolonged_term.h"
#include "progressive/scene_system.h"
#include "scene/scene.h"

namespace pd {

// The scene with every object replaced by its level-l mesh: rest shape, initial positions (level
// rest + the finest initial displacement of the same vertex: level vertices are finest vertices,
// so a posed start carries over vertex by vertex), pins mapped to the level's ids (pinned vertices
// are kept at every level by the decimation), no grid lattice (SceneObject::grid describes the
// finest mesh). Level L gives the scene itself. Throws std::invalid_argument for a level outside
// [0, L], or a pinned vertex missing from the level.
Scene scene_at_level(const Scene& scene, const SceneHierarchy& hierarchy, int level);

// Level `level`'s initial positions, stacked (m): the x0 of build_level_system, and every level's
// frame 0. Throws as scene_at_level.
Eigen::VectorXd level_initial_positions(const Scene& scene, const SceneHierarchy& hierarchy, int level);

// The prolonged Hessian of level `level` when a run names none ("auto", the default): coarse-first
// for the preview (level 0), lagged for the levels between it and the finest. Measured per level
// (docs/performance.md, issue 16): coarse-first previews took 0.52-0.83x lagged's time on 7 of 8
// scenes (ball-drop 1.07x), but coarse-first on every level made cube-trampoline's level 1 2.8x
// slower and ball-drop's whole run 1.3x.
ProlongedHessian auto_prolonged_hessian(int level);

// The names a run may give (--hessian, SubmitJob.hessian): "auto", then parse_prolonged_hessian's.
const std::vector<std::string>& level_hessian_names();

// "auto" (nullopt: auto_prolonged_hessian per level) or a name parse_prolonged_hessian accepts, for
// every coarse level; throws std::invalid_argument naming level_hessian_names() for anything else.
std::optional<ProlongedHessian> parse_level_hessian(const std::string& name);

struct LevelSystemOptions {
  // coarse levels only (see prolonged_term.h); nullopt: auto_prolonged_hessian(level)
  std::optional<ProlongedHessian> hessian;
  // Exact (the default) or PSQ's frozen offsets; library-only, for measuring the difference.
  ProlongedGradient gradient = ProlongedGradient::Exact;
  // Direct simulation of the level (PD eq. 3): its own mesh's elasticity instead of the finest
  // level's through P^l, for comparison with the progressive run.
  bool direct = false;
};

// Level l's system as above. `hierarchy` must outlive the system (its P^l is referenced).
SceneSystem build_level_system(const Scene& scene, const SceneHierarchy& hierarchy, int level,
                               const LevelSystemOptions& options = {});

}  // namespace pd
