#pragma once
// A whole single-level ("direct") simulation of a scene: build the system, step every frame, store
// each frame and its statistics in the job's frame file as soon as it is solved.
#include <functional>
#include <string>

#include "progressive/level_stepper.h"
#include "scene/scene.h"

namespace pd {

struct DirectRunOptions {
  std::string out_path;                  // HDF5 frame file, created (truncated)
  int frames = -1;                       // override the scene's frame count when >= 1
  // Called after each frame is stored (frame 0 included), e.g. for progress display.
  std::function<void(const FrameRecord&)> on_frame;
};

// Returns the number of steps whose Newton solve did not converge (stored anyway, and flagged in
// the stats as newton_converged = 0).
int run_direct(const Scene& scene, const DirectRunOptions& options);

}  // namespace pd
