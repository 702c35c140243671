// pd simulate: run a scene on one machine, in one process, into an HDF5 frame file.
#include <cstdio>

#include "commands.h"
#include "progress.h"
#include "progressive/direct_run.h"
#include "scene/scene_file.h"

namespace pd::cli {

int simulate(const SimulateArgs& args) {
  const Scene scene = load_scene(args.scene);
  const int frames = args.frames >= 1 ? args.frames : scene.frames;
  Progress progress("simulate " + scene.name, frames);
  int total_iterations = 0;
  double total_seconds = 0;

  DirectRunOptions opt;
  opt.out_path = args.out;
  opt.frames = args.frames;
  opt.on_frame = [&](const FrameRecord& r) {
    total_iterations += r.newton.iterations;
    total_seconds += r.seconds;
    if (!args.quiet && r.frame > 0)
      progress.update(r.frame, std::to_string(r.newton.iterations) + " Newton its" +
                                   (r.newton.converged ? "" : " (" + r.newton.stop_reason + ")"));
  };
  const int not_converged = run_direct(scene, opt);

  char summary[256];
  std::snprintf(summary, sizeof summary, "%d frames -> %s: %d Newton iterations, %s solving%s", frames,
                args.out.c_str(), total_iterations, format_duration(total_seconds).c_str(),
                not_converged ? ", some steps did not converge (see stats/newton_converged)" : "");
  if (!args.quiet) progress.finish(summary);
  if (not_converged)
    std::fprintf(stderr, "pd simulate: warning: %d of %d steps stopped before convergence\n", not_converged, frames);
  return 0;
}

}  // namespace pd::cli
