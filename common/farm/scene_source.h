#pragma once
// A scene as it travels to the farm (protocol::SceneSource): the scene file's text plus the OBJ files
// it refers to, so that a worker needs nothing but the scheduler's endpoint (no shared filesystem).
//
// The client reads a scene with read_scene_source; a worker rebuilds it with scene_from_source in a
// scratch folder of its own. Both sides see the same Scene: the OBJ files are written under the
// scratch folder at the paths the scene gives (relative to the scene file's folder), and parse_scene
// resolves them there.
#include <string>

#include "protocol/protocol.h"
#include "scene/scene.h"

namespace pd::farm {

// Reads the scene file at `path` for sending. First validates it with load_scene (scene/scene_file.h),
// so a bad scene throws exactly the InputError `pd simulate` gives; then collects every OBJ file the
// scene refers to (objects[i].mesh.path of "type": "obj", objects[i].initial_positions.obj), once per
// file, with its bytes. SceneSource::name is `path` as given; SceneFile::path is the path as the scene
// writes it. An OBJ path that is absolute or contains a ".." component cannot be rebuilt under a
// worker's scratch folder and is refused with an InputError naming the key, e.g.
//   "shots/hat.json: objects[0].mesh.path: "/data/hat.obj" is absolute; a farm job needs OBJ paths
//    relative to the scene file's folder (without "..")"
// `loaded`, when given, receives the Scene load_scene read (so a caller need not read it twice).
protocol::SceneSource read_scene_source(const std::string& path, Scene* loaded = nullptr);

// A hex digest of everything in `source` (name, text, every file's path and bytes): the farm sends a
// job's scene to a worker once and names it by this hash after (protocol::AssignTask.scene_hash).
std::string scene_source_hash(const protocol::SceneSource& source);

// Writes every file of `source` under `scratch_dir` (creating folders as needed) and parses the
// scene text with OBJ paths resolved there: parse_scene(source.text, source.name, scratch_dir).
// A file path that is empty, absolute or has a ".." component, or that names the same file as an
// earlier one, is refused before anything is written, with InputError
// "<source.name>: files[k].path: <problem>". A file that cannot be written throws InputError too.
Scene scene_from_source(const protocol::SceneSource& source, const std::string& scratch_dir);

}  // namespace pd::farm
