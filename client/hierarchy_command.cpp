// pd hierarchy: build (or reuse) a scene's level hierarchy and store it in a frame file, so that a
// job builds it once and its levels can be inspected (pd export --rest) before simulating.
#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "hierarchy/scene_hierarchy.h"
#include "output_files.h"
#include "scene/scene_file.h"
#include "store/hierarchy_store.h"

namespace pd::cli {
namespace {

// JSON string literal (the file name is the only free text printed).
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

// The report of a reused hierarchy: counts and rest prolongation error from the loaded operators;
// build_seconds = 0 since nothing was built.
std::vector<HierarchyLevelReport> report_of(const SceneHierarchy& h) {
  std::vector<HierarchyLevelReport> report(static_cast<size_t>(h.num_levels()));
  const Positions& finest = h.levels.back().rest.V;
  for (int l = 0; l < h.num_levels(); ++l) {
    const SceneLevel& s = h.levels[static_cast<size_t>(l)];
    HierarchyLevelReport& r = report[static_cast<size_t>(l)];
    r.vertices = static_cast<int>(s.rest.V.rows());
    r.triangles = static_cast<int>(s.rest.F.rows());
    if (s.to_finest_prolongation && finest.rows() > 0)
      r.rest_prolongation_error = (s.to_finest_prolongation->apply(s.rest.V) - finest).rowwise().norm().maxCoeff();
  }
  return report;
}

}  // namespace

int hierarchy(const HierarchyArgs& args) {
  check_scene_files(args.scene);
  const Scene scene = load_scene(args.scene);
  std::vector<std::string> inputs = scene_obj_paths(args.scene, scene.json_text);
  inputs.push_back(args.scene);
  check_output_file(args.out, "--out", inputs);
  const bool frame_file = is_frame_file(args.out);
  check_replaceable(args.out, "--out", args.force, frame_file, "a frame file");
  const auto t0 = std::chrono::steady_clock::now();
  bool reused = false;
  std::vector<HierarchyLevelReport> report;
  std::optional<SceneHierarchy> stored;
  // A matching stored hierarchy is read in place (nothing written); else the file is built under
  // OUT.partial and renamed onto OUT, so a failed build leaves OUT as it was.
  if (frame_file && stored_hierarchy_hash(args.out) == hierarchy_hash(scene)) stored = read_hierarchy(args.out);
  if (stored) {
    reused = true;
    report = report_of(*stored);
  } else {
    PartialOutput out(args.out, "--out");
    stored = load_or_build_hierarchy(scene, out.path(), nullptr, &report);
    out.commit();
  }
  const SceneHierarchy& h = *stored;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  if (args.json) {
    std::printf("{\"file\": %s, \"hash\": %s, \"reused\": %s, \"seconds\": %.6g, \"levels\": [", quoted(args.out).c_str(),
                quoted(h.hash).c_str(), reused ? "true" : "false", seconds);
    for (size_t l = 0; l < report.size(); ++l) {
      const HierarchyLevelReport& r = report[l];
      std::printf("%s\n  {\"level\": %zu, \"vertices\": %d, \"triangles\": %d, \"build_seconds\": %.6g, "
                  "\"rest_prolongation_error\": %.6g}",
                  l ? "," : "", l, r.vertices, r.triangles, r.build_seconds, r.rest_prolongation_error);
    }
    std::printf("]}\n");
    return 0;
  }
  std::printf("%s hierarchy of %s (%d levels, hash %s) %s %s in %.2f s\n", reused ? "reused" : "built",
              scene.name.empty() ? args.scene.c_str() : scene.name.c_str(), h.num_levels(), h.hash.c_str(),
              reused ? "from" : "->", args.out.c_str(), seconds);
  for (size_t l = 0; l < report.size(); ++l) {
    const HierarchyLevelReport& r = report[l];
    // A reused hierarchy was not built here: no build time to show.
    char built[32] = "cached";
    if (!reused) std::snprintf(built, sizeof built, "%.3f s", r.build_seconds);
    std::printf("level %zu: %d vertices, %d triangles, %s, rest prolongation error %.3g m\n", l, r.vertices,
                r.triangles, built, r.rest_prolongation_error);
  }
  return 0;
}

}  // namespace pd::cli
