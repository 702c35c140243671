#include "fuzz_entries.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "scene/scene_file.h"
#include "store/frame_store.h"
#include "store/hierarchy_store.h"
#include "util/input_error.h"

namespace pd {
namespace {

// Deepest bracket nesting of JSON text, strings skipped (a cheap pre-scan; no parser recursion).
int nesting_depth(const std::string& text) {
  int depth = 0, deepest = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

bool mentions_obj(const nlohmann::json& j) {
  if (j.is_string()) return j.get_ref<const std::string&>() == "obj";
  if (j.is_array())
    for (const nlohmann::json& e : j)
      if (mentions_obj(e)) return true;
  if (j.is_object())
    for (auto it = j.begin(); it != j.end(); ++it)
      if (it.key() == "obj" || mentions_obj(it.value())) return true;
  return false;
}

// Whether the scene text may name an OBJ file (mesh type "obj", initial_positions.obj): such inputs
// are skipped, so that the fuzzer never opens a file of the machine by a path it made up.
bool may_read_files(const std::string& text) {
  if (text.find("obj") == std::string::npos && text.find("\\u") == std::string::npos) return false;
  if (nesting_depth(text) > 256) return true;  // not pre-parsed: skipped rather than risked
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  return j.is_discarded() || mentions_obj(j);
}

std::string scratch_path() {
  std::error_code ec;
  const std::filesystem::path dir =
      std::filesystem::is_directory("/dev/shm", ec) ? std::filesystem::path("/dev/shm") : std::filesystem::temp_directory_path();
  return (dir / ("pd_fuzz_frame_file_" + std::to_string(getpid()) + ".h5")).string();
}

// Reads everything FrameReader offers, as pd export and pd compare do.
void read_everything(const std::string& path) {
  {
    const FrameReader r(path);
    r.scene_json();
    for (int l = 0; l < r.num_levels(); ++l) {
      r.rest_positions(l);
      r.faces(l);
      r.object_offsets(l);
      r.object_names(l);
      const std::vector<uint8_t> done = r.done(l);
      for (int t = 0; t < static_cast<int>(done.size()); ++t) {
        if (done[static_cast<size_t>(t)] != 1) continue;
        r.frame(l, t);
        r.center_of_mass(l, t);
      }
      for (const std::string& name : r.stat_names(l)) r.stat(l, name);
    }
  }
  read_hierarchy(path);
}

}  // namespace

int pd_fuzz_scene(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (may_read_files(text)) return 0;
  try {
    parse_scene(text, "fuzz.json", "");
  } catch (const InputError&) {
  }
  return 0;
}

int pd_fuzz_frame_file(const uint8_t* data, size_t size) {
  static const std::string path = scratch_path();
  {
    std::FILE* out = std::fopen(path.c_str(), "wb");
    if (!out) return 0;
    const bool ok = std::fwrite(data, 1, size, out) == size;
    if (std::fclose(out) != 0 || !ok) return 0;
  }
  try {
    read_everything(path);
  } catch (const InputError&) {
  }
  std::remove(path.c_str());
  return 0;
}

}  // namespace pd
