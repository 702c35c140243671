#include "support/level_runs.h"

#include <vector>

#include "progressive/level_task.h"
#include "support/intersection_checker.h"

namespace pd::test {

LevelRun solve_level(const Scene& scene, const SceneHierarchy& h, int level, const LevelRun* below, bool direct) {
  LevelRun run;
  LevelTaskInputs in;
  if (below) in.below = [below](int t) { return below->x.at(t); };
  LevelTaskOptions opt;
  opt.system.direct = direct;
  const SceneLevel& lv = h.levels[static_cast<std::size_t>(level)];
  std::vector<char> obstacle;
  for (const SceneObject& o : scene.objects) obstacle.push_back(o.obstacle ? 1 : 0);
  const LevelTaskReport r = solve_level_task(scene, h, {level, 0, scene.frames}, in, [&](const FrameRecord& f) {
    run.x[f.frame] = f.x;
    if (intersections_outside_obstacles(as_rows(f.x), lv.rest.F, lv.face_offsets, obstacle) > 0) ++run.intersecting;
  }, opt);
  run.unconverged_steps = r.unconverged_steps;
  return run;
}

}  // namespace pd::test
