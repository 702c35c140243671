#pragma once
// The level hierarchy of a whole scene: every object (cloth, shells and obstacles alike, PSQ 4.6)
// decimated to the same number of levels, and the scene-wide meshes and prolongation operators of
// each level with the objects stacked in scene order (the global vertex ids SceneSystem uses).
//
// Levels: 0 = coarsest ... L = finest (the scene's meshes as given). Level l of the scene is the
// union of level l of every object. An object may keep the same mesh on several levels (its
// per-object vertex_counts repeat a count): such a level has no collapses for that object and its
// prolongation rows are the identity.
//
// Pinned vertices of simulated objects are locked (never removed, never moved), so every level has
// them at their finest rest positions and scripts apply to them unchanged. Obstacles are not locked:
// they are decimated like any surface, and at every level each obstacle vertex follows the object's
// rigid motion applied to its own rest position.
//
// Errors: InputError "<scene file>: objects[<k>] (<name>): level <l> ...: <problem>" when an object
// cannot be decimated as asked (too few vertices, non-manifold, target unreachable) or its settings
// do not fit the scene's level count.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>
#include "hierarchy/decimation.h"
#include "hierarchy/shell_prolongation.h"
#include "scene/scene.h"

namespace pd {

// The hierarchy of one object.
struct ObjectHierarchy {
  // levels[0] coarsest ... levels[L] finest (build_levels' output; object-local ids). A level whose
  // count repeats the next finer level's is a copy of it: same vertices and positions, faces sorted as
  // Tri, identity coarse_to_fine / fine_to_coarse, no collapses (locate_finest_on_level and
  // split_batches work on it unchanged).
  std::vector<Level> levels;
  // batches[l] = split_batches(levels[l].collapses) for l < L: the vertex-split batches that take
  // level l to level l+1 (indices into levels[l].collapses). Empty vector at L.
  std::vector<std::vector<std::vector<int>>> batches;
};

// One level of the scene, objects stacked in scene order.
struct SceneLevel {
  TriMesh rest;                        // every object's level mesh, global ids, rest positions (m)
  std::vector<int> vertex_offsets;     // object k owns vertices [off[k], off[k+1]); size #objects + 1
  std::vector<int> face_offsets;       // object k owns faces [off[k], off[k+1]) of rest.F
  std::vector<int> to_finest;          // global level vertex id -> global finest vertex id
  // P_{l+1}^l: from this level to level l+1 (absent at the finest level). Fine rows = level l+1's
  // global vertices, coarse columns = this level's.
  std::optional<ShellProlongation> to_next;
  // P^l: from this level straight to the finest (at the finest level: every vertex at itself).
  std::optional<ShellProlongation> to_finest_prolongation;
};

struct SceneHierarchy {
  std::vector<ObjectHierarchy> objects;  // one per scene object, scene order
  std::vector<SceneLevel> levels;        // levels[0] coarsest ... levels[L] finest
  // Hex digest of everything the hierarchy depends on (meshes, pins, obstacle flags, hierarchy
  // settings, format version); equal hashes mean an identical build (see hierarchy_hash).
  std::string hash;

  int num_levels() const { return static_cast<int>(levels.size()); }
  int finest() const { return num_levels() - 1; }
};

// Build report per level (for `pd hierarchy`).
struct HierarchyLevelReport {
  int vertices = 0;
  int triangles = 0;
  // decimation + locations + operators for this level, s. Each object's decimation is one run for all
  // its levels; its time is shared out in proportion to each level's collapse count.
  double build_seconds = 0.0;
  // max over finest vertices of |P^l(rest_l) - rest_L|, m (round-off: PSQ's rest-shape recovery)
  double rest_prolongation_error = 0.0;
};

// Decimates every object of `scene` as its hierarchy settings say (Scene::hierarchy and
// SceneObject::hierarchy; docs/scene-format.md) and assembles the scene levels and operators.
// Deterministic: the same scene gives the same hierarchy bit for bit. `report`, if given, gets one
// entry per level (0 = coarsest).
SceneHierarchy build_scene_hierarchy(const Scene& scene,
                                     std::vector<HierarchyLevelReport>* report = nullptr);

// The digest build_scene_hierarchy stores in SceneHierarchy::hash, computable without building.
std::string hierarchy_hash(const Scene& scene);

// Level l's collapses (l < L) of all objects in level l+1's GLOBAL vertex ids, objects in scene
// order, and the scene-wide split batches (indices into that list; batch b of the scene is the union
// of batch b of every object, whose patches are disjoint across objects).
struct SceneCollapses {
  std::vector<Collapse> collapses;
  std::vector<std::vector<int>> batches;
  std::vector<int> coarse_to_fine;  // level l global id -> level l+1 global id
};
SceneCollapses scene_collapses(const SceneHierarchy& hierarchy, int level);

}  // namespace pd
