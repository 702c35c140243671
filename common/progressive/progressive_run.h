#pragma once
// A whole progressive run on one machine (PD Algorithm 1): build the scene's hierarchy, solve the
// preview (level 0, frames (0, N]), then every refinement level in turn, each as one level task
// (progressive/level_task.h), storing every frame of every level in the job's frame file as soon as
// it is solved. The farm runs the same tasks on many machines; this is the single-process path
// behind `pd simulate --mode progressive` and `pd simulate --mode direct --level L`.
//
// Frame file: /hierarchy (store/hierarchy_store.h) and /levels/<l> for every level of it (level 0 =
// coarsest, as the hierarchy numbers them), frames of the solved levels only.
#include <functional>
#include <string>
#include <vector>

#include "progressive/level_task.h"
#include "scene/scene.h"

namespace pd {

struct ProgressiveRunOptions {
  std::string out_path;   // HDF5 frame file, created (truncated)
  int frames = -1;        // override the scene's frame count when >= 1
  // Progressive: solve levels 0..last_level (-1: up to the finest). Direct (options.task.system.direct):
  // solve only `direct_level` (-1: the finest) on its own mesh.
  int last_level = -1;
  int direct_level = -1;
  LevelTaskOptions task;
  std::function<void(int level, int levels_to_solve)> on_level;  // before each level is solved
  std::function<void(int level, const FrameRecord&)> on_frame;   // after each frame is stored
};

struct ProgressiveRunReport {
  std::vector<int> levels;              // the levels solved, in order
  std::vector<double> seconds;          // wall time per solved level (s), same order
  std::vector<int> unconverged_steps;   // per solved level
  double hierarchy_seconds = 0.0;       // building (and storing) the hierarchy
};

// Throws InputError for a scene whose start state is not admissible at some level (the message
// names the level), std::invalid_argument for levels outside the hierarchy.
ProgressiveRunReport run_progressive(const Scene& scene, const ProgressiveRunOptions& options);

}  // namespace pd
