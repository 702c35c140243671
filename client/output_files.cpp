#include "output_files.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>
#include <utility>

#include <nlohmann/json.hpp>

#include "cli_text.h"
#include "store/frame_store.h"
#include "util/input_error.h"

namespace pd::cli {
namespace fs = std::filesystem;
namespace {

// What kind of special file st describes, or "" for a regular file or folder.
const char* special_kind(const struct stat& st) {
  if (S_ISFIFO(st.st_mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(st.st_mode)) return "a character device";
  if (S_ISBLK(st.st_mode)) return "a block device";
  if (S_ISSOCK(st.st_mode)) return "a socket";
  return "";
}

std::string folder_of(const std::string& path) {
  const fs::path folder = fs::path(path).parent_path();
  return folder.empty() ? "." : folder.string();
}

// The checks both output kinds share: not special, not an input, folder exists.
void check_output_common(const std::string& out, const std::string& option, const std::vector<std::string>& inputs,
                         const struct stat* st) {
  if (st && *special_kind(*st))
    throw InputError(shown_path(out) + ": " + option + ": is " + special_kind(*st) + ", not a file pd may write");
  for (const std::string& in : inputs)
    if (!in.empty() && same_file(out, in))
      throw InputError(shown_path(out) + ": " + option + ": is the input " + shown_path(in) +
                       "; writing it would destroy it (choose another output path)");
  struct stat dir {};
  const std::string folder = folder_of(out);
  if (::stat(folder.c_str(), &dir) != 0 || !S_ISDIR(dir.st_mode))
    throw InputError(shown_path(out) + ": " + option + ": folder " + shown_path(folder) + " does not exist");
}

// Removes a leftover temporary `partial` (regular file or, when `folder`, a folder pd made).
void remove_leftover(const std::string& partial, const std::string& option, bool folder) {
  struct stat st {};
  if (::lstat(partial.c_str(), &st) != 0) return;
  const bool ok = folder ? S_ISDIR(st.st_mode) : S_ISREG(st.st_mode);
  if (!ok)
    throw InputError(shown_path(partial) + ": " + option + ": this temporary name exists and is not a " +
                     (folder ? "folder" : "regular file") + "; remove it");
  std::error_code ec;
  fs::remove_all(partial, ec);
  if (ec) throw InputError(shown_path(partial) + ": " + option + ": cannot remove this old temporary: " + ec.message());
}

}  // namespace

std::string shown_path(const std::string& path) { return one_line(path, 4096); }

bool regular_file_exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

void check_input_file(const std::string& path, const std::string& what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw InputError(shown_path(path) + ": cannot read the " + what + ": " + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) throw InputError(shown_path(path) + ": is a folder, not a " + what);
  if (!S_ISREG(st.st_mode))
    throw InputError(shown_path(path) + ": is " + special_kind(st) + ", not a " + what +
                     " (only regular files are read)");
}

bool same_file(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  const bool ea = ::stat(a.c_str(), &sa) == 0, eb = ::stat(b.c_str(), &sb) == 0;
  if (ea && eb) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
  if (ea != eb) return false;
  std::error_code e1, e2;
  const fs::path ca = fs::weakly_canonical(a, e1), cb = fs::weakly_canonical(b, e2);
  return !e1 && !e2 && ca == cb;
}

void check_output_file(const std::string& out, const std::string& option, const std::vector<std::string>& inputs) {
  if (out.empty()) throw InputError(option + ": must name a file");
  struct stat st {};
  const bool exists = ::stat(out.c_str(), &st) == 0;
  if (exists && S_ISDIR(st.st_mode)) throw InputError(shown_path(out) + ": " + option + ": is a folder, not a file");
  check_output_common(out, option, inputs, exists ? &st : nullptr);
}

void check_output_folder(const std::string& out, const std::string& option, const std::vector<std::string>& inputs) {
  if (out.empty()) throw InputError(option + ": must name a folder");
  struct stat st {};
  const bool exists = ::stat(out.c_str(), &st) == 0;
  if (exists && S_ISREG(st.st_mode))
    throw InputError(shown_path(out) + ": " + option + ": is a file, not a folder (pd export writes a folder)");
  if (exists && !S_ISDIR(st.st_mode))
    throw InputError(shown_path(out) + ": " + option + ": is " + special_kind(st) + ", not a folder");
  if (exists) {
    for (const std::string& in : inputs)
      if (!in.empty() && same_file(out, in)) throw InputError(shown_path(out) + ": " + option + ": is the input");
    return;
  }
  // A missing folder is created by pd export, but only inside an existing one: a mistyped parent
  // would otherwise be made too, and be left behind after an error.
  check_output_common(out, option, inputs, nullptr);
}

bool is_frame_file(const std::string& path) {
  if (!regular_file_exists(path)) return false;
  static const char kSignature[8] = {'\x89', 'H', 'D', 'F', '\r', '\n', '\x1a', '\n'};
  char head[8] = {};
  {
    std::ifstream in(path, std::ios::binary);
    if (!in.read(head, sizeof head)) return false;
  }
  if (std::memcmp(head, kSignature, sizeof head) != 0) return false;
  try {
    const FrameReader reader(path);
    return reader.num_levels() >= 0;
  } catch (const std::exception&) {
    return false;
  }
}

bool file_starts_with(const std::string& path, const std::string& prefix) {
  if (!regular_file_exists(path)) return false;
  std::ifstream in(path, std::ios::binary);
  std::string head(prefix.size(), '\0');
  if (!in.read(head.data(), static_cast<std::streamsize>(head.size()))) return false;
  return head == prefix;
}

void check_replaceable(const std::string& out, const std::string& option, bool force, bool is_kind,
                       const std::string& kind) {
  if (force || is_kind || !regular_file_exists(out)) return;
  throw InputError(shown_path(out) + ": " + option + ": exists and is not " + kind + "; give --force to replace it");
}

namespace {

// (key, resolved path) of every OBJ file the scene text names.
std::vector<std::pair<std::string, std::string>> scene_obj_refs(const std::string& scene_path,
                                                                const std::string& json_text) {
  std::vector<std::pair<std::string, std::string>> out;
  const nlohmann::json j = nlohmann::json::parse(json_text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object() || !j.contains("objects") || !j["objects"].is_array()) return out;
  const fs::path folder = fs::path(scene_path).parent_path();
  const auto add = [&](const std::string& key, const nlohmann::json& p) {
    if (!p.is_string()) return;
    const fs::path given = p.get<std::string>();
    out.emplace_back(key, (given.is_absolute() ? given : folder / given).string());
  };
  for (std::size_t i = 0; i < j["objects"].size(); ++i) {
    const nlohmann::json& o = j["objects"][i];
    if (!o.is_object()) continue;
    const std::string at = "objects[" + std::to_string(i) + "]";
    if (o.contains("mesh") && o["mesh"].is_object() && o["mesh"].contains("path"))
      add(at + ".mesh.path", o["mesh"]["path"]);
    if (o.contains("initial_positions") && o["initial_positions"].is_object() && o["initial_positions"].contains("obj"))
      add(at + ".initial_positions.obj", o["initial_positions"]["obj"]);
  }
  return out;
}

}  // namespace

std::vector<std::string> scene_obj_paths(const std::string& scene_path, const std::string& json_text) {
  std::vector<std::string> out;
  for (const auto& [key, path] : scene_obj_refs(scene_path, json_text)) out.push_back(path);
  return out;
}

void check_scene_files(const std::string& scene_path) {
  check_input_file(scene_path, "scene file");
  std::ifstream in(scene_path, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const auto& [key, path] : scene_obj_refs(scene_path, text)) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) continue;  // missing: load_scene names it
    if (S_ISREG(st.st_mode)) continue;
    throw InputError(shown_path(scene_path) + ": " + key + ": " + shown_path(path) + " is " +
                     (S_ISDIR(st.st_mode) ? "a folder" : special_kind(st)) +
                     ", not an OBJ file (only regular files are read)");
  }
}

PartialOutput::PartialOutput(std::string final_path, std::string option)
    : final_(std::move(final_path)), option_(std::move(option)), partial_(final_ + kPartialSuffix) {
  remove_leftover(partial_, option_, /*folder=*/false);
}

PartialOutput::~PartialOutput() {
  if (!done_) discard();
}

void PartialOutput::discard() {
  std::error_code ec;
  fs::remove(partial_, ec);  // nothing to report: the command is failing already
  done_ = true;
}

void PartialOutput::commit() {
  std::error_code ec;
  fs::rename(partial_, final_, ec);
  if (ec) {
    const std::string why = ec.message();
    discard();
    throw InputError(shown_path(final_) + ": " + option_ + ": cannot rename " + shown_path(partial_) +
                     " to it: " + why);
  }
  done_ = true;
}

PartialFolder::PartialFolder(std::string final_path, std::string option)
    : final_(std::move(final_path)), option_(std::move(option)) {
  std::error_code ec;
  merge_ = fs::is_directory(final_, ec);
  partial_ = merge_ ? (fs::path(final_) / ".pd-export.partial").string() : final_ + kPartialSuffix;
  remove_leftover(partial_, option_, /*folder=*/true);
}

PartialFolder::~PartialFolder() {
  if (done_) return;
  std::error_code ec;
  fs::remove_all(partial_, ec);
}

void PartialFolder::commit() {
  std::error_code ec;
  if (!merge_) {
    fs::rename(partial_, final_, ec);
    if (ec) throw InputError(shown_path(final_) + ": " + option_ + ": cannot rename " + shown_path(partial_) +
                             " to it: " + ec.message());
    done_ = true;
    return;
  }
  // Refuse before moving anything when a file of the same name is a folder or special file there.
  for (const fs::directory_entry& e : fs::directory_iterator(partial_)) {
    const fs::path target = fs::path(final_) / e.path().filename();
    struct stat st {};
    if (::lstat(target.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
      throw InputError(shown_path(target.string()) + ": " + option_ + ": exists and is not a regular file");
  }
  for (const fs::directory_entry& e : fs::directory_iterator(partial_)) {
    fs::rename(e.path(), fs::path(final_) / e.path().filename(), ec);
    if (ec) throw InputError(shown_path(final_) + ": " + option_ + ": cannot move " + shown_path(e.path().string()) +
                             " into it: " + ec.message());
  }
  fs::remove(partial_, ec);
  done_ = true;
}

}  // namespace pd::cli
