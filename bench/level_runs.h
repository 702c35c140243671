#pragma once
// Level tasks run in one process for the seam benchmarks (seam_overlap.cpp, seam_stitch.cpp): a task's
// frames collected in memory, and the single run (K = 1) of levels 0..L, each level fed the one
// below, as `pd simulate --mode progressive` runs them.
#include <chrono>
#include <cstdio>
#include <map>
#include <vector>

#include <Eigen/Core>

#include "hierarchy/scene_hierarchy.h"
#include "progressive/level_task.h"

namespace pd::bench {

using Frames = std::map<int, Eigen::VectorXd>;  // stacked positions (m) by frame

// Inputs whose level below is `below`'s frames (nothing when null).
inline LevelTaskInputs fed_by(const Frames* below) {
  LevelTaskInputs in;
  if (below) in.below = [below](int t) { return below->at(t); };
  return in;
}

// Solves `task` with `in` and returns its frames; seconds: its wall time; kappa (optional): each
// frame's barrier stiffness statistic (J/m^4), where the scene has contact.
inline Frames solve_frames(const Scene& scene, const SceneHierarchy& h, const LevelTask& task,
                           const LevelTaskInputs& in, double& seconds, std::map<int, double>* kappa = nullptr) {
  Frames out;
  const auto start = std::chrono::steady_clock::now();
  solve_level_task(scene, h, task, in, [&](const FrameRecord& r) {
    out[r.frame] = r.x;
    if (kappa)
      for (const auto& [name, value] : r.contact)
        if (name == "barrier_stiffness") (*kappa)[r.frame] = value;
  });
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

// Levels 0..L over (0, frames], one after the other, each line of time printed; kappa (optional): level
// L's barrier stiffness per frame. Returns the levels' frames and adds their time to *total.
inline std::vector<Frames> single_run(const Scene& scene, const SceneHierarchy& h, int L, int frames,
                                      std::map<int, double>* kappa = nullptr, double* total = nullptr) {
  std::vector<Frames> single(static_cast<std::size_t>(L + 1));
  for (int l = 0; l <= L; ++l) {
    double s = 0.0;
    single[static_cast<std::size_t>(l)] = solve_frames(
        scene, h, {l, 0, frames}, fed_by(l > 0 ? &single[static_cast<std::size_t>(l - 1)] : nullptr), s,
        l == L ? kappa : nullptr);
    if (total) *total += s;
    std::printf("single run: level %d (0, %d] in %.2f s\n", l, frames, s);
  }
  return single;
}

}  // namespace pd::bench
