#include "progressive/progressive_run.h"

#include <chrono>
#include <map>
#include <stdexcept>
#include <utility>

#include "progressive/contact_control.h"
#include "progressive/frame_stats.h"
#include "scene/scene_animation.h"
#include "store/frame_store.h"
#include "store/hierarchy_store.h"
#include "util/input_error.h"

namespace pd {

namespace {

double since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace

ProgressiveRunReport run_progressive(const Scene& input_scene, const ProgressiveRunOptions& options) {
  Scene scene = input_scene;
  if (options.frames >= 1) scene.frames = options.frames;
  check_animations_cover(scene, scene.frames);
  ProgressiveRunReport report;
  const auto t_hierarchy = std::chrono::steady_clock::now();
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const int L = h.finest();
  const bool direct = options.task.system.direct;
  std::vector<int> levels;
  if (direct) {
    const int l = options.direct_level < 0 ? L : options.direct_level;
    if (l > L) throw std::invalid_argument("direct level " + std::to_string(l) + " is not in [0, " + std::to_string(L) + "]");
    levels = {l};
  } else {
    const int last = options.last_level < 0 ? L : options.last_level;
    if (last > L) throw std::invalid_argument("last level " + std::to_string(last) + " is not in [0, " + std::to_string(L) + "]");
    for (int l = 0; l <= last; ++l) levels.push_back(l);
  }
  // Every level to be solved must start admissibly (a coarse level can overlap where the finest
  // does not): checked before anything is written.
  for (int l : levels) {
    const Scene at_level = scene_at_level(scene, h, l);
    try {
      check_start_state(at_level, build_level_system(scene, h, l, options.task.system));
    } catch (const InputError& e) {
      throw InputError(std::string(e.what()) + " (at hierarchy level " + std::to_string(l) + " of " +
                       std::to_string(L + 1) + ", 0 = coarsest)");
    }
  }

  FrameWriter writer = FrameWriter::create(options.out_path, scene.json_text, scene.frames);
  const std::vector<std::string> names = scene_object_names(scene);
  write_hierarchy(options.out_path, h, names);
  add_hierarchy_levels(writer, h, names);
  report.hierarchy_seconds = since(t_hierarchy);

  std::map<int, Eigen::VectorXd> below, current;  // frames of the level below and of this level
  for (int l : levels) {
    if (options.on_level) options.on_level(l, static_cast<int>(levels.size()));
    const auto t_level = std::chrono::steady_clock::now();
    LevelTaskInputs inputs;
    if (l >= 1 && !direct) inputs.below = [&below](int t) { return below.at(t); };
    current.clear();
    const LevelTaskReport r = solve_level_task(scene, h, {l, 0, scene.frames}, inputs,
                                               [&](const FrameRecord& f) {
                                                 writer.write_frame(l, f.frame, as_rows(f.x), frame_stats(f));
                                                 current[f.frame] = f.x;
                                                 if (options.on_frame) options.on_frame(l, f);
                                               },
                                               options.task);
    report.levels.push_back(l);
    report.seconds.push_back(since(t_level));
    report.unconverged_steps.push_back(r.unconverged_steps);
    std::swap(below, current);
  }
  writer.close();
  return report;
}

}  // namespace pd
