#include "farm/scene_source.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "scene/scene_animation.h"
#include "scene/scene_file.h"
#include "util/fnv1a.h"
#include "util/input_error.h"

namespace pd::farm {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// Why `path` cannot be placed under a scratch folder, or "" when it can. Absolute paths and ".."
// components would resolve outside the folder (and let a job write anywhere a worker can).
std::string relative_path_problem(const std::string& path) {
  if (path.empty()) return "is empty";
  const fs::path p(path);
  if (p.has_root_directory() || p.has_root_name() || p.is_absolute()) return "\"" + path + "\" is absolute";
  for (const fs::path& part : p) {
    if (part == "..") return "\"" + path + "\" has a \"..\" component";
  }
  if (p.lexically_normal() == "." || !p.has_filename()) return "\"" + path + "\" names a folder, not a file";
  return "";
}

std::string read_bytes(const fs::path& file, const std::string& what) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(what + ": cannot open " + file.string());
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (in.bad()) throw InputError(what + ": cannot read " + file.string());
  return bytes.str();
}

// Collects the OBJ files of one scene: each once (by normalised relative path), in scene order.
class FileCollector {
 public:
  FileCollector(std::string scene_path, fs::path base_dir)
      : scene_path_(std::move(scene_path)), base_dir_(std::move(base_dir)) {}

  void add(const std::string& written, const std::string& key_path) {
    const std::string what = scene_path_ + ": " + key_path;
    const std::string problem = relative_path_problem(written);
    if (!problem.empty()) {
      throw InputError(what + ": " + problem +
                       "; a farm job needs file paths relative to the scene file's folder (without \"..\")");
    }
    if (!seen_.insert(fs::path(written).lexically_normal().string()).second) return;
    files_.push_back({written, read_bytes(base_dir_ / written, what)});
  }

  std::vector<protocol::SceneFile> take() { return std::move(files_); }

 private:
  std::string scene_path_;
  fs::path base_dir_;
  std::set<std::string> seen_;
  std::vector<protocol::SceneFile> files_;
};

}  // namespace

protocol::SceneSource read_scene_source(const std::string& path, Scene* loaded) {
  // Validation first: every problem of the scene is reported exactly as `pd simulate` reports it.
  Scene scene = load_scene(path);

  protocol::SceneSource source;
  source.name = path;
  source.text = scene.json_text;

  // The text passed load_scene, so it is valid JSON with the keys and types the format requires.
  Json doc;
  try {
    doc = Json::parse(source.text);
  } catch (const Json::exception& e) {
    throw InputError(path + ": cannot re-read the scene's JSON: " + e.what());
  }
  FileCollector files(path, fs::path(path).parent_path());
  const Json& objects = doc.at("objects");
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const Json& object = objects[i];
    const std::string at = "objects[" + std::to_string(i) + "]";
    const Json& mesh = object.at("mesh");
    if (mesh.at("type") == "obj") files.add(mesh.at("path").get<std::string>(), at + ".mesh.path");
    const auto posed = object.find("initial_positions");
    if (posed != object.end()) files.add(posed->at("obj").get<std::string>(), at + ".initial_positions.obj");
    const auto animation = object.find("animation");
    if (animation != object.end())
      for (const std::string& file : animation_files(*animation)) files.add(file, at + ".animation");
  }
  source.files = files.take();
  if (loaded != nullptr) *loaded = std::move(scene);
  return source;
}

std::string scene_source_hash(const protocol::SceneSource& source) {
  Fnv1a h;
  h.str("pd-scene-source-1");
  h.str(source.name);
  h.str(source.text);
  h.i64(static_cast<long long>(source.files.size()));
  for (const protocol::SceneFile& f : source.files) {
    h.str(f.path);
    h.str(f.content);
  }
  return h.hex();
}

Scene scene_from_source(const protocol::SceneSource& source, const std::string& scratch_dir) {
  // Every path is checked before the first file is written, so a refused source leaves nothing behind.
  std::set<std::string> seen;
  for (std::size_t k = 0; k < source.files.size(); ++k) {
    const std::string& path = source.files[k].path;
    const std::string what = source.name + ": files[" + std::to_string(k) + "].path: ";
    const std::string problem = relative_path_problem(path);
    if (!problem.empty()) throw InputError(what + problem);
    if (!seen.insert(fs::path(path).lexically_normal().string()).second)
      throw InputError(what + "\"" + path + "\" names the same file as an earlier entry");
  }

  for (std::size_t k = 0; k < source.files.size(); ++k) {
    const protocol::SceneFile& file = source.files[k];
    const std::string what = source.name + ": files[" + std::to_string(k) + "].path: ";
    const fs::path target = fs::path(scratch_dir) / fs::path(file.path).lexically_normal();
    std::error_code ec;
    fs::create_directories(target.parent_path(), ec);
    if (ec) throw InputError(what + "cannot create folder " + target.parent_path().string() + ": " + ec.message());
    std::ofstream out(target, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(what + "cannot create " + target.string() + ": " + std::strerror(errno));
    out.write(file.content.data(), static_cast<std::streamsize>(file.content.size()));
    out.close();
    if (!out) throw InputError(what + "cannot write " + target.string());
  }
  return parse_scene(source.text, source.name, scratch_dir);
}

}  // namespace pd::farm
