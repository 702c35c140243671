#pragma once
// The level hierarchy in a job's HDF5 frame file (group /hierarchy; layout in docs/frame-format.md,
// "Hierarchy"), so that a job builds its hierarchy once and every later stage (workers, pd export,
// h5py readers) uses exactly the same levels and operators.
//
// Exactness: reading gives a SceneHierarchy equal to the stored one bit for bit: meshes, maps,
// collapse records and batches are stored as they are; each ShellProlongation is rebuilt from the
// stored rest meshes and locations (the only constructor it has) and its U, normal and tangent
// offsets are then compared with the stored arrays with ==. A difference means the file was damaged
// or written by code that builds operators differently: InputError
//   "<path>: /hierarchy/<l>/to_next: stored operator differs from the rebuilt one (file corrupt or
//    written by another version): <array> differs at entry <i>"
// The stored U / offsets are also there for readers outside C++ (h5py), who cannot rebuild.
//
// Flow for a job file: FrameWriter::create -> write_hierarchy -> FrameWriter::add_level for every
// level (which then checks the level against the stored one instead of writing it) -> write_frame.
// write_hierarchy opens the file by path; it may be called while that process's FrameWriter has the
// file open (HDF5 shares one open file within a process).
//
// Errors: InputError whose what() starts with the path and names the HDF5 object. Not thread-safe.
#include <optional>
#include <string>
#include <vector>

#include "hierarchy/scene_hierarchy.h"

namespace pd {

// Bumped when the /hierarchy layout changes; read_hierarchy rejects other versions.
constexpr int kHierarchyFormatVersion = 1;

// Writes `h` into the existing frame file `path` (made by FrameWriter::create) as /hierarchy,
// replacing any /hierarchy the file has (call it before add_level: levels added before refer to the
// replaced group). object_names: one per object, scene order (SceneHierarchy does not carry them;
// they go to /hierarchy/<l>/object_names as add_level writes them, and to each object's group).
// Flushes and fsyncs before returning.
void write_hierarchy(const std::string& path, const SceneHierarchy& h, const std::vector<std::string>& object_names);

// The hash stored in /hierarchy@hash, or nullopt when the file has none (missing file, plain frame
// file from FrameWriter alone, not HDF5). Cheap: reads one attribute.
std::optional<std::string> stored_hierarchy_hash(const std::string& path);

// Reads /hierarchy of `path`; nullopt when the file has no /hierarchy@hash. Throws InputError for a
// missing or non-HDF5 file, a missing or misshapen dataset, another hierarchy_format_version, or an
// operator that does not rebuild to the stored arrays.
std::optional<SceneHierarchy> read_hierarchy(const std::string& path);

// The hierarchy of `scene` for the job file `path`: when `path` holds a hierarchy whose hash equals
// hierarchy_hash(scene) it is read and returned (*reused = true, `report` left empty). Otherwise it is
// built (report filled as build_scene_hierarchy does) and `path` is (re)created as a frame file with
// it: FrameWriter::create(path, scene.json_text, scene.frames), write_hierarchy, add_level for every
// level, no frames stored. Recreating drops the file's old frames, which belong to the old hierarchy.
SceneHierarchy load_or_build_hierarchy(const Scene& scene, const std::string& path, bool* reused = nullptr,
                                       std::vector<HierarchyLevelReport>* report = nullptr);

// The scene's object names in scene order (what write_hierarchy and add_level take).
std::vector<std::string> scene_object_names(const Scene& scene);

// Adds every level of `h` to `writer` (which must have none yet): add_level(l, rest, faces, vertex
// offsets, object_names). After write_hierarchy this only checks the stored levels and creates
// /levels/<l>.
class FrameWriter;
void add_hierarchy_levels(FrameWriter& writer, const SceneHierarchy& h, const std::vector<std::string>& object_names);

}  // namespace pd
