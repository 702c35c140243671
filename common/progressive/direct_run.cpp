#include "progressive/direct_run.h"

#include "progressive/frame_stats.h"
#include "scene/scene_animation.h"
#include "store/frame_store.h"

namespace pd {

int run_direct(const Scene& scene, const DirectRunOptions& options) {
  const int frames = options.frames >= 1 ? options.frames : scene.frames;
  check_animations_cover(scene, frames);  // before the frame file is created
  SceneSystem sys = build_scene_system(scene);
  check_start_state(scene, sys);
  FrameWriter writer = FrameWriter::create(options.out_path, scene.json_text, frames);
  writer.add_level(0, sys.rest.V, sys.rest.F, sys.object_offsets, sys.object_names);

  LevelStepper stepper(sys, scene.solver, scene.time_step);
  FrameRecord r = stepper.initial_frame();
  writer.write_frame(0, 0, as_rows(r.x), frame_stats(r));
  if (options.on_frame) options.on_frame(r);

  Eigen::VectorXd x = sys.x0, v = sys.v0;
  int not_converged = 0;
  for (int t = 0; t < frames; ++t) {
    r = stepper.step(t, x, v);
    not_converged += !r.newton.converged;
    writer.write_frame(0, t + 1, as_rows(r.x), frame_stats(r));
    if (options.on_frame) options.on_frame(r);
  }
  return not_converged;
}

}  // namespace pd
