#pragma once
// The `animation` key of an obstacle (docs/scene-format.md, "Animated obstacles"): an OBJ sequence or
// a PC2 point cache that its vertices follow. Used by scene_file.cpp; errors are InputError naming the
// scene file and key path and, for a bad cache, the cache file and its line, sample or vertex.
#include <functional>
#include <memory>
#include <string>

#include "geometry/mesh.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "scene/vertex_animation.h"

namespace pd {

// Reads the animation at `node` for an obstacle whose rest mesh (before its transform) is `mesh`:
// every cache frame must have the mesh's vertex count and, for OBJ files, its face list. `place`
// applies the object's transform to a frame (the same as to the rest mesh, so a body exported in
// centimetres is scaled like its rest OBJ). Checks every placed coordinate against the scene's
// position limits, every vertex's speed between cache frames against limits::kMaxSpeed, and that
// the cache lasts until `shot_end` (s, frames x time_step) or later. The cache's memory (frames x
// vertices x 24 bytes) is checked against memory_budget() before it is read.
std::shared_ptr<const VertexAnimation> read_animation(const scene_json::JsonNode& node, const std::string& base_dir,
                                                      const TriMesh& mesh,
                                                      const std::function<void(Positions&)>& place, double shot_end);

// Throws InputError "<scene file>: objects[k].animation: covers t = a to b s, but the job runs to T s
// (F frames x h)" for the first animated obstacle whose cache ends before frames x time_step: a job
// run longer than its scene (pd simulate --frames, pd submit --frames) must not hold a body still
// without saying so.
void check_animations_cover(const Scene& scene, int frames);

// The files an obstacle's animation (the JSON value of its "animation" key) names, as the scene
// writes them (relative to the scene file's folder): the OBJ sequence's files in frame order, or the
// PC2 file. For the farm, which ships them with the scene (farm/scene_source.h). The value must have
// passed read_animation (a scene load_scene accepted).
std::vector<std::string> animation_files(const nlohmann::json& animation);

// The file name of frame `frame` of an OBJ sequence pattern: one run of '#' (zero-padded to its
// length) or one printf conversion %d, %Nd or %0Nd. Throws InputError at `node` (the pattern's key)
// for a pattern without exactly one frame number in it.
std::string sequence_file(const scene_json::JsonNode& node, const std::string& pattern, long long frame);

}  // namespace pd
