#pragma once
// The meshes of a scene file's objects (docs/scene-format.md, "Meshes"): the generated shapes and OBJ
// files of `objects[i].mesh`, checked against the per-object and scene-wide vertex and face limits
// (scene_file.h) before anything is allocated. Used by scene_file.cpp; errors are InputError naming
// the key path.
#include <optional>
#include <string>

#include "geometry/mesh.h"
#include "geometry/shapes.h"
#include "hierarchy/grid_coarsening.h"
#include "scene/scene_json.h"

namespace pd {

// The vertices of the objects read before the current one (for the scene-wide limit).
struct MeshBudget {
  long long vertices_before = 0;
};

// A file the scene names: relative paths are relative to the scene file's folder (base_dir).
std::string resolve_scene_path(const std::string& base_dir, const std::string& file);

// The OBJ file a path node names (relative to base_dir), within the per-object limits.
TriMesh read_obj_at(const scene_json::JsonNode& path_node, const std::string& base_dir);

// The lattice of a generated rectangle or box (read_mesh has checked its keys), from its vertices
// before the object's transform; nothing for other mesh types.
std::optional<GridLattice> generated_lattice(const scene_json::JsonNode& mesh_node, const TriMesh& mesh);

// The mesh an object's `mesh` node describes, before its transform.
TriMesh read_mesh(const scene_json::JsonNode& mesh, const std::string& base_dir, const MeshBudget& budget);

}  // namespace pd
