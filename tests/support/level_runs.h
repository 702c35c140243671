#pragma once
// Solving one level of a scene over all its frames in the test process (progressive/level_task.h, as
// `pd simulate` does), keeping every frame and counting the frames that break the contact promise
// (the independent CGAL checker; an obstacle's own crossings do not count).
#include <map>

#include <Eigen/Core>

#include "hierarchy/scene_hierarchy.h"
#include "scene/scene.h"

namespace pd::test {

struct LevelRun {
  std::map<int, Eigen::VectorXd> x;  // stacked positions per frame, m
  int intersecting = 0;              // frames with a pair the checker rejects
  int unconverged_steps = 0;
};

// Level `level` of `scene`, frames 0..N: progressive from `below` (the level under it), a preview when
// below is null, or a direct simulation of the level's own meshes when `direct`.
LevelRun solve_level(const Scene& scene, const SceneHierarchy& h, int level, const LevelRun* below, bool direct);

}  // namespace pd::test
