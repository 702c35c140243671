#include "scene/scene_animation.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <system_error>
#include <filesystem>

#include "geometry/obj_io.h"
#include "geometry/pc2_io.h"
#include "scene/scene_file.h"
#include "scene/scene_mesh.h"
#include "util/input_error.h"
#include "util/memory_budget.h"
#include "util/message_text.h"

namespace pd {
namespace {

using scene_json::JsonNode;
namespace limits = scene_json::limits;

constexpr long long kMaxCacheFrames = 100000;  // 1 h at 24 fps: far beyond a shot
constexpr scene_json::Range kFps{1e-3, 1e4, "frames/s"};
constexpr scene_json::Range kStart{-1e7, 1e7, "s"};

// A sequence pattern split around its frame number.
struct Pattern {
  std::string head, tail;
  int width = 0;  // zero-padded to this many digits (0: no padding)
};

Pattern parse_pattern(const JsonNode& node, const std::string& pattern) {
  const std::size_t hash = pattern.find('#'), percent = pattern.find('%');
  Pattern p;
  if (hash != std::string::npos) {
    std::size_t end = hash;
    while (end < pattern.size() && pattern[end] == '#') ++end;
    if (percent != std::string::npos || pattern.find('#', end) != std::string::npos)
      node.fail_got("must hold exactly one frame number: one run of '#' or one %d");
    p.head = pattern.substr(0, hash);
    p.tail = pattern.substr(end);
    p.width = static_cast<int>(end - hash);
  } else if (percent != std::string::npos) {
    std::size_t at = percent + 1;
    if (at < pattern.size() && pattern[at] == '0') ++at;
    const std::size_t digits = at;
    while (at < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[at]))) ++at;
    if (at >= pattern.size() || pattern[at] != 'd' || at - digits > 1 ||
        pattern.find('%', at) != std::string::npos)
      node.fail_got("must hold exactly one frame number: one run of '#' or one %d, %4d or %04d");
    p.head = pattern.substr(0, percent);
    p.tail = pattern.substr(at + 1);
    p.width = at > digits ? pattern[digits] - '0' : 0;
  } else {
    node.fail_got("has no frame number: write it as a run of '#' (body_####.obj) or %04d (body_%04d.obj)");
  }
  if (p.width > 9) node.fail_got("pads its frame number to more than 9 digits");
  return p;
}

std::string padded(long long frame, int width) {
  std::string digits = std::to_string(frame);
  if (static_cast<int>(digits.size()) < width) digits.insert(0, static_cast<std::size_t>(width) - digits.size(), '0');
  return digits;
}

// The line of the `index`-th (0-based) vertex line of an OBJ file, 0 if it cannot be found. Only
// called to name the line of an error, so it reads the file a second time.
long line_of_vertex(const std::string& path, Eigen::Index index) {
  std::ifstream in(path);
  std::string line;
  long number = 0;
  Eigen::Index seen = 0;
  while (std::getline(in, line)) {
    ++number;
    std::size_t i = 0;
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (line.compare(i, 2, "v ") == 0 || line.compare(i, 2, "v\t") == 0) {
      if (seen == index) return number;
      ++seen;
    }
  }
  return 0;
}

// The frames as read, with where each came from for messages.
struct CacheFrames {
  std::vector<Positions> frames;
  std::vector<std::string> files;  // per frame: the OBJ file, or the PC2 file for every sample
  bool pc2 = false;
  double sample_rate = 1.0;        // frames per sample (PC2), 1 for OBJ sequences
};

// "<file>:<line>: vertex i" for an OBJ frame, "<file>: sample k, point i" for a PC2 sample.
std::string vertex_where(const CacheFrames& c, std::size_t k, Eigen::Index v) {
  const std::string& file = c.files[k];
  if (c.pc2) return file + ": sample " + std::to_string(k) + ", point " + std::to_string(v);
  const long line = line_of_vertex(file, v);
  return file + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": vertex " + std::to_string(v + 1);
}

void check_memory(const JsonNode& node, long long frames, long long vertices) {
  const double bytes = 24.0 * static_cast<double>(frames) * static_cast<double>(vertices);
  const MemoryBudget budget = memory_budget();
  if (bytes > budget.bytes)
    node.fail("needs " + gib_text(bytes) + " for " + std::to_string(frames) + " frames x " + std::to_string(vertices) +
              " vertices, more than the " + gib_text(budget.bytes) + " this process may take (" + budget.limited_by + ")");
}

std::string face_text(const Faces& F, Eigen::Index f) {
  return std::to_string(F(f, 0) + 1) + " " + std::to_string(F(f, 1) + 1) + " " + std::to_string(F(f, 2) + 1);
}

CacheFrames read_sequence(const JsonNode& node, const std::string& base_dir, const TriMesh& mesh) {
  const JsonNode pattern_node = node.required("obj_sequence");
  const std::string pattern = pattern_node.string(scene_json::kMaxPathBytes);
  parse_pattern(pattern_node, pattern);
  const std::vector<JsonNode> range = node.required("frames").elements(2);
  const long long first = range[0].integer(0, 10000000), last = range[1].integer(0, 10000000);
  if (last < first) node.required("frames").fail_got("must be [first, last] with first <= last");
  if (last - first + 1 > kMaxCacheFrames)
    node.required("frames").fail_got("lists more than " + std::to_string(kMaxCacheFrames) + " frames");
  check_memory(node, last - first + 1, mesh.num_vertices());
  ObjLimits obj_limits;
  obj_limits.max_vertices = kMaxSceneMeshVertices;
  obj_limits.max_faces = kMaxSceneMeshFaces;
  CacheFrames c;
  for (long long frame = first; frame <= last; ++frame) {
    const std::string file = resolve_scene_path(base_dir, sequence_file(pattern_node, pattern, frame));
    TriMesh m;
    try {
      m = read_obj(file, obj_limits);
    } catch (const InputError& e) {
      pattern_node.fail("frame " + std::to_string(frame) + ": " + e.what());
    }
    if (m.num_vertices() != mesh.num_vertices())
      pattern_node.fail(file + ": has " + std::to_string(m.num_vertices()) + " vertices, the obstacle's mesh has " +
                        std::to_string(mesh.num_vertices()));
    if (m.num_faces() != mesh.num_faces())
      pattern_node.fail(file + ": has " + std::to_string(m.num_faces()) + " faces, the obstacle's mesh has " +
                        std::to_string(mesh.num_faces()));
    for (Eigen::Index f = 0; f < m.F.rows(); ++f)
      if (m.F.row(f) != mesh.F.row(f))
        pattern_node.fail(file + ": face " + std::to_string(f + 1) + " is " + face_text(m.F, f) +
                          ", the obstacle mesh's face " + std::to_string(f + 1) + " is " + face_text(mesh.F, f) +
                          " (every frame needs the mesh's face list)");
    c.frames.push_back(std::move(m.V));
    c.files.push_back(file);
  }
  return c;
}

CacheFrames read_cache(const JsonNode& node, const std::string& base_dir, const TriMesh& mesh) {
  const JsonNode path_node = node.required("pc2");
  const std::string file = path_node.string(scene_json::kMaxPathBytes);
  if (file.empty()) path_node.fail_got("must be a path to a PC2 file");
  const std::string path = resolve_scene_path(base_dir, file);
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (!ec) check_memory(node, static_cast<long long>(size / 12), 1);  // float32 -> double: 24 bytes a point
  Pc2Cache cache;
  try {
    cache = read_pc2(path);
  } catch (const InputError& e) {
    path_node.fail(e.what());
  }
  const Eigen::Index points = cache.samples.front().rows();
  if (points != mesh.num_vertices())
    path_node.fail(path + ": has " + std::to_string(points) + " points, the obstacle's mesh has " +
                   std::to_string(mesh.num_vertices()) + " vertices");
  if (static_cast<long long>(cache.samples.size()) > kMaxCacheFrames)
    path_node.fail(path + ": has " + std::to_string(cache.samples.size()) + " samples, more than the limit of " +
                   std::to_string(kMaxCacheFrames));
  CacheFrames c;
  c.pc2 = true;
  c.sample_rate = cache.sample_rate;
  c.files.assign(cache.samples.size(), path);
  c.frames = std::move(cache.samples);
  return c;
}

// Placed coordinates within the scene's position limits, and vertex speeds between cache frames.
void check_frames(const JsonNode& node, const CacheFrames& c, double step) {
  for (std::size_t k = 0; k < c.frames.size(); ++k) {
    const Positions& x = c.frames[k];
    for (Eigen::Index v = 0; v < x.rows(); ++v)
      for (int a = 0; a < 3; ++a)
        if (!(std::abs(x(v, a)) <= limits::kPosition.upper))
          node.fail(vertex_where(c, k, v) + ": coordinate " + number_for_message(x(v, a)) +
                    " m (after the object's transform) is outside +-" + number_for_message(limits::kPosition.upper) +
                    " m");
    if (k == 0) continue;
    const Eigen::VectorXd speed = (x - c.frames[k - 1]).rowwise().norm() / step;
    Eigen::Index v = 0;
    if (speed.maxCoeff(&v) > limits::kMaxSpeed)
      node.fail(vertex_where(c, k, v) + ": moves at " + number_for_message(speed[v]) + " m/s from the frame before, " +
                "more than the limit of " + number_for_message(limits::kMaxSpeed) + " m/s (is \"fps\" right?)");
  }
}

}  // namespace

std::string sequence_file(const JsonNode& node, const std::string& pattern, long long frame) {
  const Pattern p = parse_pattern(node, pattern);
  return p.head + padded(frame, p.width) + p.tail;
}

std::shared_ptr<const VertexAnimation> read_animation(const JsonNode& node, const std::string& base_dir,
                                                      const TriMesh& mesh,
                                                      const std::function<void(Positions&)>& place, double shot_end) {
  node.expect_keys({"obj_sequence", "frames", "pc2", "fps", "start", "interpolation"});
  const bool sequence = node.has("obj_sequence"), pc2 = node.has("pc2");
  if (sequence == pc2) node.fail("needs exactly one of \"obj_sequence\" (with \"frames\") and \"pc2\"");
  if (pc2 && node.has("frames"))
    node.required("frames").fail("applies to \"obj_sequence\" only (a PC2 file holds its own sample count)");
  const double fps = node.required("fps").in_range(kFps);
  double start = 0.0;
  if (auto s = node.optional("start")) start = s->in_range(kStart);
  AnimationInterpolation interpolation = AnimationInterpolation::Linear;
  if (auto i = node.optional("interpolation"))
    interpolation = i->choice({"linear", "smooth"}, "interpolation") == "smooth" ? AnimationInterpolation::Smooth
                                                                               : AnimationInterpolation::Linear;
  CacheFrames c = sequence ? read_sequence(node, base_dir, mesh) : read_cache(node, base_dir, mesh);
  for (Positions& x : c.frames) place(x);
  const double step = c.sample_rate / fps;
  check_frames(node, c, step);
  const double end = start + step * static_cast<double>(c.frames.size() - 1);
  if (end < shot_end * (1.0 - 1e-12))
    node.fail("covers t = " + number_for_message(start) + " to " + number_for_message(end) + " s (" +
              std::to_string(c.frames.size()) + " frames at " + number_for_message(fps / c.sample_rate) +
              " frames/s), but the shot runs to " + number_for_message(shot_end) +
              " s (frames x time_step): give more cache frames or fewer shot frames, or check \"fps\" and \"start\"");
  return std::make_shared<const VertexAnimation>(std::move(c.frames), start, step, interpolation);
}

void check_animations_cover(const Scene& scene, int frames) {
  const double end = frames * scene.time_step;
  for (std::size_t k = 0; k < scene.objects.size(); ++k) {
    const SceneObject& o = scene.objects[k];
    if (!o.motion || !o.motion->animation) continue;
    const VertexAnimation& a = *o.motion->animation;
    if (a.end() < end * (1.0 - 1e-12))
      throw InputError(scene.source_path + ": objects[" + std::to_string(k) + "].animation: covers t = " +
                       number_for_message(a.start()) + " to " + number_for_message(a.end()) + " s, but the job runs to " +
                       number_for_message(end) + " s (" + std::to_string(frames) + " frames x " +
                       number_for_message(scene.time_step) + " s)");
  }
}

std::vector<std::string> animation_files(const nlohmann::json& animation) {
  const JsonNode node(animation, "animation", "(scene)");
  if (auto p = node.optional("pc2")) return {p->string(scene_json::kMaxPathBytes)};
  const JsonNode pattern_node = node.required("obj_sequence");
  const std::string pattern = pattern_node.string(scene_json::kMaxPathBytes);
  const std::vector<JsonNode> range = node.required("frames").elements(2);
  std::vector<std::string> files;
  for (long long f = range[0].integer(0, 10000000); f <= range[1].integer(0, 10000000); ++f)
    files.push_back(sequence_file(pattern_node, pattern, f));
  return files;
}

}  // namespace pd
