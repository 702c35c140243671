#pragma once
// Readers for the hierarchy sections of a scene file (internal to common/scene): the top-level
// "hierarchy" and each object's "hierarchy". docs/scene-format.md lists the keys; every reader throws
// InputError naming the file and key path. The settings are used by hierarchy/scene_hierarchy.h.
#include <vector>

#include "scene/scene.h"
#include "scene/scene_json.h"

namespace pd::scene_json {

// Top-level "hierarchy": {levels, ratio}.
HierarchyConfig read_hierarchy(const JsonNode& node);

// An object's "hierarchy": {vertex_counts, keep_boundary}. vertex_counts is checked against the
// scene's level count and the object's finest vertex count (`object` has its mesh already).
ObjectHierarchyConfig read_object_hierarchy(const JsonNode& node, const HierarchyConfig& scene_config,
                                            const SceneObject& object);

// Reads the top-level "hierarchy" of `root` (if any) into scene.hierarchy, then every object's
// "hierarchy" (objects[i] is the JSON of scene.objects[i]). Called after the objects are read.
void read_hierarchy_sections(const JsonNode& root, const std::vector<JsonNode>& objects, Scene& scene);

}  // namespace pd::scene_json
