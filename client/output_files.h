#pragma once
// The files the pd client reads and writes, checked before anything is opened, and outputs written
// under a temporary name that is renamed on success (README.md, "Output files"):
//  - inputs must be regular files: a FIFO, device or folder is refused after stat(), never opened
//    (opening a FIFO blocks until a writer comes);
//  - an output must not be a FIFO, device or (for a file output) a folder, and must not be one of the
//    command's inputs: the same file by st_dev/st_ino when it exists, else the same canonical path;
//  - an existing output that is not of the kind the command writes (a frame file for simulate and
//    hierarchy, a pd compare CSV for compare) is refused unless --force;
//  - an output is written to "<out>.partial" and renamed to <out> at the end; on failure the
//    temporary is removed (no debris), except where a command keeps what it stored (pd simulate).
// Every refusal is an InputError "<path>: <option>: <problem>" (paths echoed with cli_text's echo rules
// for control characters; paths are not cut).
#include <string>
#include <vector>

namespace pd::cli {

// Suffix of the temporary name an output is written to (same folder, so the rename is atomic).
inline constexpr const char* kPartialSuffix = ".partial";

// `path` with control characters escaped (one line), not cut: for messages naming a file.
std::string shown_path(const std::string& path);

// Throws unless `path` exists and is a regular file (after following symlinks). `what` names it in
// the message, e.g. "scene" or "frame file".
void check_input_file(const std::string& path, const std::string& what);

// Throws when `out` (given as `option`, e.g. "--out") is a FIFO, device or socket, is a folder, is one
// of `inputs` (same file, see above), or its folder does not exist.
void check_output_file(const std::string& out, const std::string& option, const std::vector<std::string>& inputs);

// The same for an output folder (pd export --out): it may exist only as a folder.
void check_output_folder(const std::string& out, const std::string& option, const std::vector<std::string>& inputs);

// Whether `a` and `b` name the same file: same st_dev/st_ino when both exist, else equal canonical
// paths (weakly_canonical: the missing tail as written).
bool same_file(const std::string& a, const std::string& b);

// Whether the regular file `path` exists (stat, no open).
bool regular_file_exists(const std::string& path);

// Whether the regular file `path` is a frame file: starts with the HDF5 signature and opens as one
// (FrameReader). False for anything else, without throwing.
bool is_frame_file(const std::string& path);

// Whether the regular file `path` starts with `prefix` (e.g. the compare CSV header).
bool file_starts_with(const std::string& path, const std::string& prefix);

// Throws unless `out` is absent, or `force`, or `is_kind(out)`: "<out>: <option>: exists and is not
// <kind>; give --force to replace it".
void check_replaceable(const std::string& out, const std::string& option, bool force, bool is_kind,
                       const std::string& kind);

// The OBJ files a scene's JSON text names (objects[i].mesh.path of "type": "obj" and
// objects[i].initial_positions.obj), resolved against the scene file's folder; none when the text
// does not parse (load_scene reports that).
std::vector<std::string> scene_obj_paths(const std::string& scene_path, const std::string& json_text);

// check_input_file for a scene file, then the same for every OBJ file its text names that exists
// (stat only, before load_scene opens them): "<scene>: objects[i].mesh.path: <path> is a FIFO ...".
void check_scene_files(const std::string& scene_path);

// A file output written under "<final>.partial": the constructor removes a leftover temporary
// (refusing one that is not a regular file); commit() renames it onto `final`; the destructor removes
// it when it was not committed.
class PartialOutput {
 public:
  PartialOutput(std::string final_path, std::string option);
  PartialOutput(const PartialOutput&) = delete;
  PartialOutput& operator=(const PartialOutput&) = delete;
  ~PartialOutput();
  const std::string& path() const { return partial_; }
  const std::string& final_path() const { return final_; }
  void commit();   // throws InputError when the rename fails (the temporary is then removed)
  void discard();  // removes the temporary now
 private:
  std::string final_, option_, partial_;
  bool done_ = false;
};

// A folder output (pd export): files go to a temporary folder, then are moved into `final`.
// When `final` does not exist the temporary is "<final>.partial" and is renamed to `final` whole;
// else it is "<final>/.pd-export.partial" and each file is renamed into `final`. Not committed: the
// temporary folder and what it holds are removed.
class PartialFolder {
 public:
  PartialFolder(std::string final_path, std::string option);
  PartialFolder(const PartialFolder&) = delete;
  PartialFolder& operator=(const PartialFolder&) = delete;
  ~PartialFolder();
  const std::string& path() const { return partial_; }
  void commit();
 private:
  std::string final_, option_, partial_;
  bool merge_ = false;  // final exists: move the files one by one
  bool done_ = false;
};

}  // namespace pd::cli
