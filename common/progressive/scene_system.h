#pragma once
// The discrete system of a scene at one resolution: all objects' vertices concatenated into one
// stacked vector, their lumped masses, pins, and the incremental potential built from exactly the
// terms the scene declares (a scene without wind has no wind term, and so on).
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"
#include "progressive/contact_control.h"
#include "scene/scene.h"
#include "solver/incremental_potential.h"

namespace pd {

class InertiaTerm;
class PinTargetTerm;
class ProlongationState;

struct PinnedVertex {
  int vertex = 0;        // global vertex index
  Vec3 start;            // position at t = 0, m
  int script = -1;       // index into SceneSystem::scripts, -1 = fixed in place
  int source = -1;       // the vertex of the script's animation it follows (animated obstacles only)
};

struct SceneSystem {
  TriMesh rest;                          // all objects, global vertex indices, rest positions
  std::vector<int> object_offsets;       // object k owns vertices [off[k], off[k+1])
  std::vector<int> object_face_offsets;  // object k owns faces [off[k], off[k+1]) of rest.F
  std::vector<std::string> object_names;
  Eigen::VectorXd masses;                // lumped, per dof (3 per vertex), kg
  Eigen::VectorXd x0, v0;                // initial stacked positions (m) and velocities (m/s)
  std::vector<PinnedVertex> pins;
  std::vector<PinScript> scripts;
  double bbox_diagonal = 0.0;            // of the initial positions, m (scales the Newton tolerance)
  IncrementalPotential ip;               // inertia first, then the scene's terms
  InertiaTerm* inertia = nullptr;        // ip's first term
  ContactControl contact;                // the contact and strain-limit terms in ip, if any
  PinTargetTerm* pin_target = nullptr;   // in ip when some pin has a script (see level_stepper.cpp)
  double average_free_mass = 0.0;        // mean lumped mass of the vertices with mass, kg
  // A coarse level of a progressive run (progressive/level_system.h): the prolongation its
  // elasticity is evaluated through (frozen offsets, if chosen, are refreshed by the stepper at
  // every Newton iterate). Null otherwise.
  std::shared_ptr<ProlongationState> prolongation;
};

// Builds the system of the scene's meshes as given. Obstacles get every vertex pinned to their
// motion script, no mass and no elastic terms. own_shell_forces = false leaves out every object's
// membrane, bending and pressure (a coarse level of a progressive run adds the finest level's
// instead).
SceneSystem build_scene_system(const Scene& scene, bool own_shell_forces = true);

// An object's shell forces appended to `terms`: Neo-Hookean membrane, bending if it has interior
// edges (its material's bending_model: midedge fit or hinge), pressure if it has one. faces = its faces in global ids, offset = its first global
// vertex, rest = the global rest positions the terms read, initial = the stacked initial positions
// (the pressure's V0).
void add_shell_forces(const SceneObject& obj, const Faces& faces, int offset, const Positions& rest,
                      const Eigen::VectorXd& initial, std::vector<std::unique_ptr<EnergyTerm>>& terms);

// Where a pinned vertex is at time t (s).
Vec3 pin_position(const SceneSystem& sys, const PinnedVertex& pin, double t);

// Centre of mass of each object (rows), m; the plain vertex average for massless obstacles.
Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> centers_of_mass(const SceneSystem& sys,
                                                                          const Eigen::VectorXd& x);

}  // namespace pd
