// pd simulate: run a scene on one machine, in one process, into an HDF5 frame file.
#include <cstdio>

#include "commands.h"
#include "progress.h"
#include <memory>

#include "progressive/direct_run.h"
#include "progressive/progressive_run.h"
#include "util/input_error.h"
#include "scene/scene_file.h"

namespace pd::cli {

namespace {

// pd simulate --mode progressive, or --mode direct --level L: one progress bar per level.
int simulate_levels(const SimulateArgs& args, Scene scene) {
  if (args.levels >= 1) scene.hierarchy.levels = args.levels;
  if (args.level >= scene.hierarchy.levels)
    throw InputError("simulate: --level " + std::to_string(args.level) + ": " + args.scene + " has hierarchy levels 0.." +
                     std::to_string(scene.hierarchy.levels - 1) + " (hierarchy.levels = " +
                     std::to_string(scene.hierarchy.levels) + ")");
  if (args.mode == "direct" && args.preview_only) throw InputError("simulate: --preview-only needs --mode progressive");
  ProgressiveRunOptions opt;
  opt.out_path = args.out;
  opt.frames = args.frames;
  opt.task.system.direct = args.mode == "direct";
  opt.task.system.hessian = parse_prolonged_hessian(args.hessian);
  opt.direct_level = args.level;
  if (args.preview_only) opt.last_level = 0;
  const int frames = args.frames >= 1 ? args.frames : scene.frames;
  std::unique_ptr<Progress> progress;
  int iterations = 0;
  opt.on_level = [&](int level, int count) {
    if (progress && !args.quiet) progress->finish(std::to_string(iterations) + " Newton iterations");
    iterations = 0;
    progress = std::make_unique<Progress>(scene.name + (opt.task.system.direct ? " direct" : " progressive") +
                                              ", level " + std::to_string(level) + " (" + std::to_string(count) +
                                              (count == 1 ? " level)" : " levels)"),
                                          frames);
  };
  opt.on_frame = [&](int, const FrameRecord& r) {
    iterations += r.newton.iterations;
    if (!args.quiet && r.frame > 0)
      progress->update(r.frame, std::to_string(r.newton.iterations) + " Newton its" +
                                    (r.newton.converged ? "" : " (" + r.newton.stop_reason + ")"));
  };
  const ProgressiveRunReport report = run_progressive(scene, opt);
  if (progress && !args.quiet) progress->finish(std::to_string(iterations) + " Newton iterations");
  int not_converged = 0;
  for (std::size_t k = 0; k < report.levels.size(); ++k) {
    if (!args.quiet)
      std::fprintf(stderr, "level %d: %s, %d steps not converged\n", report.levels[k],
                   format_duration(report.seconds[k]).c_str(), report.unconverged_steps[k]);
    not_converged += report.unconverged_steps[k];
  }
  if (not_converged)
    std::fprintf(stderr, "pd simulate: warning: %d steps stopped before convergence (see stats/newton_converged)\n",
                 not_converged);
  return 0;
}

}  // namespace

int simulate(const SimulateArgs& given) {
  const Scene scene = load_scene(given.scene);
  SimulateArgs args = given;
  if (args.mode.empty()) args.mode = scene.progressive ? "progressive" : "direct";
  if (args.mode == "progressive" || args.level >= 0 || args.levels >= 1) return simulate_levels(args, scene);
  if (args.preview_only) throw InputError("simulate: --preview-only needs --mode progressive");
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
