#pragma once
// A parsed, validated scene: everything a simulation needs, in SI units.
// docs/scene-format.md documents the JSON keys that fill these fields.
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/mesh.h"
#include "hierarchy/grid_coarsening.h"
#include "physics/hessian_projection.h"
#include "scene/vertex_animation.h"

namespace pd {

// The bending energy of a shell (material key "bending_model"). MidedgeFit
// (physics/bending_midedge_fit.h) deflects within 1 % of plate theory on every triangulation tested,
// at about 1.7x the hinge's cost per Newton iteration; Hinge (physics/bending_hinge.h, "Discrete
// Shells", the papers' choice) deflects 0.56 to 1.21 times plate theory depending on the grid
// (exact for strips on row-alternating grids, within 1 % for plates on equilateral meshes):
// tests/physics/bending_plate_theory_test.cpp.
enum class BendingModel { MidedgeFit, Hinge };

struct Material {
  double density = 0.0;          // kg/m^3 (volumetric; mass per area = density * thickness)
  double youngs_modulus = 0.0;   // Pa, membrane
  double poisson_ratio = 0.0;    // dimensionless, in [0, 0.5)
  double thickness = 0.0;        // m
  // Young's modulus used for bending only, Pa. Cloth bends far more easily than its membrane
  // stiffness and thickness predict; scenes set this to match measured bending rigidity.
  std::optional<double> bending_youngs_modulus;
  BendingModel bending_model = BendingModel::MidedgeFit;

  // Plate bending rigidity D = E_b t^3 / (12 (1 - nu^2)), N m.
  double bending_rigidity() const;
};

// One pose of a keyframed rigid motion: at `time` (s) a vertex with initial position X is at
// rotation * X + translation (m).
struct Keyframe {
  double time = 0.0;
  Vec3 translation = Vec3::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
};

// Rigid motion applied to pinned vertices over time: a pinned vertex with rest-frame position X
// (its initial position) is at  c + R(omega * s) (X - c) + velocity * s,  s = clamp(t - start, 0, end - start),
// or, when `keyframes` is not empty, at the keyframed pose (translation interpolated linearly,
// rotation by quaternion slerp; held before the first and after the last keyframe; the first
// keyframe is at t = 0 with the identity pose, added by the reader if the file starts later).
struct PinScript {
  Vec3 velocity = Vec3::Zero();          // m/s
  Vec3 angular_velocity = Vec3::Zero();  // rad/s, axis * rate (right-hand rule)
  Vec3 center = Vec3::Zero();            // m, centre of rotation at time `start`
  double start = 0.0;                    // s
  double end = 1e300;                    // s
  std::vector<Keyframe> keyframes;       // times strictly increasing; replaces the fields above
  // A deforming obstacle's vertex animation (obstacles only): vertex i of the object is at
  // animation->position(i, t); replaces every field above. Shared, read-only: the levels and their
  // systems all point at the one cache.
  std::shared_ptr<const VertexAnimation> animation;
};

struct PinGroup {
  std::vector<int> vertices;          // object-local, 0-based, sorted, unique
  std::optional<PinScript> script;    // absent: the vertices stay where they start
};

// Internal pressure of a closed shell. Constant: potential -p V. Ideal gas (isothermal): the
// pressure is `pressure` at the initial volume V0 and falls as p V0 / V; potential -p V0 ln V.
struct Pressure {
  enum class Model { Constant, IdealGas } model = Model::Constant;
  double pressure = 0.0;  // Pa (gauge)
};

// C-IPC strain limiting: the largest singular value of each triangle's deformation gradient stays
// below `limit` (1.1 = at most 10% stretch in any direction), held by a barrier on the principal
// stretches that acts from `barrier_start` on (physics/strain_limit.h).
struct StrainLimit {
  double limit = 1.1;        // dimensionless stretch, > 1
  // Stretch at which the barrier starts to act, in [1, limit); absent: limit - (limit - 1) / 10, the
  // last tenth of the allowed stretch. C-IPC's scenes use 1 (the whole range): a wider band lets
  // Newton's model see the limit coming instead of running into it (docs/performance.md).
  std::optional<double> barrier_start;
  // Barrier stiffness kappa_s, J/m^2 (energy per rest area), > 0; absent: E * thickness of the
  // object's material (physics/strain_limit.h: default_strain_limit_stiffness).
  std::optional<double> stiffness;
};

// IPC contact between all objects (and each object with itself where self_contact is set).
struct ContactConfig {
  double dhat = 1e-3;        // activation gap, m: barriers act while the gap is below dhat
  double offset = 0.0;       // m: contact happens at this distance between mid-surfaces (thickness)
  double ccd_ratio = 0.9;    // fraction of each certified-safe CCD advance that a step may take
  double friction = 0.0;     // Coulomb coefficient of every pair of objects without an override
  double eps_v = 1e-3;       // m/s: tangential speed below which friction is smoothed (static)
  // Coefficients for particular pairs of objects (indices into Scene::objects, a <= b; a == b is
  // an object's self-friction).
  struct PairFriction {
    int a = 0, b = 0;
    double mu = 0.0;
  };
  std::vector<PairFriction> pair_friction;
  std::optional<double> stiffness;  // kappa, J/m^4; absent: adaptive (IPC)
};

// The analytic ground: the half-space n . p >= height is free space.
struct Ground {
  Vec3 normal = Vec3(0, 1, 0);  // unit
  double height = 0.0;          // m
  double friction = 0.0;        // Coulomb coefficient against every object
};

// An object's level hierarchy settings (docs/scene-format.md, "hierarchy"; hierarchy/scene_hierarchy.h).
struct ObjectHierarchyConfig {
  // Vertex counts of the coarser levels, next-to-finest first (level L-1, ..., level 0): exactly
  // Scene::hierarchy.levels - 1 entries, each >= 3, non-increasing, <= the finest vertex count. A
  // count equal to the next finer level's keeps that level's mesh unchanged (e.g. an 8-vertex box
  // obstacle). Empty: level l gets round(n_L / ratio^(L-l)) vertices (Scene::hierarchy.ratio).
  std::vector<int> vertex_counts;
  // Keep every boundary vertex on every level (DecimationSettings::keep_boundary). Absent: false,
  // since a sheet's boundary grows like sqrt(n) and would block a 4x ratio; without it only straight
  // boundary stretches coarsen, so corners and curved boundaries stay exact.
  std::optional<bool> keep_boundary;
  // Coarser levels as nested sub-grids (grid_level_vertices) instead of by quadric cost: key
  // `coarsening: "grid"`, only for `rectangle` and `box` meshes; the grid sets the vertex counts.
  bool grid_coarsening = false;
};

struct SceneObject {
  std::string name;
  TriMesh rest;                        // rest shape after the object's transform, m
  // The lattice of a generated `rectangle` or `box` mesh (for hierarchy.coarsening "grid"); absent
  // for other meshes.
  std::optional<GridLattice> grid;
  Positions initial;                   // initial positions (== rest.V unless posed), m
  Vec3 initial_velocity = Vec3::Zero();  // m/s, every vertex
  Material material;
  std::vector<PinGroup> pins;
  std::optional<Pressure> pressure;    // closed shells only
  bool wind = true;                    // whether the scene's wind acts on this object
  // Contact (only read when the scene has a "contact" section): whether the object's own surface
  // may touch itself (folds, drapes); other objects and the ground always collide with it.
  bool self_contact = false;
  bool ground_contact = true;          // collides with the scene's ground half-space, if any
  // An obstacle is a collider, not a simulated object: every vertex follows `motion` (or stays
  // put), it has no elastic energy and no mass, and `material` is unused.
  bool obstacle = false;
  std::optional<PinScript> motion;     // obstacles only: rigid (keyframes, velocity) or an animation
  std::optional<StrainLimit> strain_limit;
  ObjectHierarchyConfig hierarchy;     // coarser levels of this object (every object has them)
};

// Air moving at air_velocity * (1 + gust_amplitude * sin(2 pi gust_frequency t)), drag on each
// triangle proportional to the normal component of its velocity relative to the air.
struct Wind {
  Vec3 air_velocity = Vec3::Zero();  // m/s
  double air_density = 1.2;          // kg/m^3
  double drag_coefficient = 1.0;     // normal drag coefficient C_d, dimensionless
  double gust_amplitude = 0.0;       // fraction of air_velocity, >= 0
  double gust_frequency = 0.0;       // Hz
};

// How Newton's stopping test resolves friction (docs/scene-format.md, solver.friction_stopping).
enum class FrictionStopping {
  Contacts,  // each friction contact's tangential step below 0.1 eps_v, the rest at `tolerance`
  Uniform,   // every vertex's step below min(tolerance * bbox, 0.1 eps_v) (the rule before 2026-12-02)
};

struct SolverSettings {
  // Newton stops when ||p||_inf / h < tolerance * (bounding-box diagonal), p the Newton step.
  double tolerance = 1e-3;
  FrictionStopping friction_stopping = FrictionStopping::Contacts;
  int max_newton_iterations = 200;
  HessianProjection projection = HessianProjection::ExactFirst;  // docs/performance.md, "Which Hessian projection"
};

// The scene-wide level hierarchy (docs/scene-format.md, "hierarchy").
struct HierarchyConfig {
  int levels = 4;       // total number of levels INCLUDING the finest (1: no coarser level)
  double ratio = 4.0;   // vertex-count ratio between neighbouring levels (> 1) for objects without vertex_counts
};

struct Scene {
  std::string source_path;   // the file it was read from (for messages)
  std::string json_text;     // the scene file's text, stored in the frame file
  std::string name;
  double time_step = 0.0;    // h, s; one stored frame per step
  int frames = 0;            // N: frames 0..N are stored
  Vec3 gravity = Vec3(0, -9.81, 0);  // m/s^2
  std::optional<Wind> wind;
  std::optional<ContactConfig> contact;  // absent: objects pass through each other (no contact cost)
  std::optional<Ground> ground;          // requires contact
  SolverSettings solver;
  HierarchyConfig hierarchy;
  // How `pd simulate SCENE` runs the scene when no --mode is given (docs/scene-format.md, "mode"):
  // false = direct simulation of the meshes as given, true = progressive (preview, then refinement).
  bool progressive = false;
  std::vector<SceneObject> objects;
};

}  // namespace pd
