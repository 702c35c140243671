// pd simulate: run a scene on one machine, in one process, into an HDF5 frame file.
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.h"
#include "output_files.h"
#include "progress.h"
#include "stop_signals.h"

#include "progressive/direct_run.h"
#include "progressive/level_stepper.h"
#include "progressive/progressive_run.h"
#include "store/frame_store.h"
#include "scene/scene_file.h"
#include "util/input_error.h"
#include "util/memory_budget.h"
#include "util/parallel.h"

namespace pd::cli {

namespace {

// SIGINT / SIGTERM during a run stop it after the frame being solved, as after an error, so that
// the frames stored so far are kept in OUT instead of a stray OUT.partial.
// Called after every stored frame.
void stop_if_signalled(int frame) {
  if (const int sig = StopSignals::received(); sig != 0)
    throw InputError(std::string("interrupted by ") + (sig == SIGINT ? "SIGINT" : "SIGTERM") +
                     " after frame " + std::to_string(frame));
}

// Steps whose Newton solve stopped before its tolerance (at the iteration cap, or the line search
// stalled) are counted in the frame file (stats/newton_converged). The run keeps every frame either
// way, but by default such a run is a failure (exit 3): a script or a farm must be able to tell a
// shot beyond what the solver can do from a good one without reading the file. `steps`: the
// number of steps of the run, or -1 when not one number (progressive: several levels).
int unconverged_exit_code(const SimulateArgs& args, int not_converged, int steps) {
  if (not_converged == 0) return 0;
  const std::string count =
      std::to_string(not_converged) + (steps >= 0 ? " of " + std::to_string(steps) : "") + " steps";
  if (args.allow_unconverged) {
    std::fprintf(stderr, "pd simulate: warning: %s stopped before convergence (see stats/newton_converged)\n",
                 count.c_str());
    return 0;
  }
  std::fprintf(stderr,
               "pd: error: %s: %s stopped before convergence (see stats/newton_converged); the frames are stored "
               "in %s; --allow-unconverged accepts them with exit code 0\n",
               shown_path(args.scene).c_str(), count.c_str(), shown_path(args.out).c_str());
  return 3;
}

// pd simulate --mode progressive, or --mode direct --level L: one progress bar per level.
int simulate_levels(const SimulateArgs& args, Scene scene, const std::string& out_path, int& stored) {
  if (args.levels >= 1) scene.hierarchy.levels = args.levels;
  if (args.level >= scene.hierarchy.levels)
    throw InputError("--level: level " + std::to_string(args.level) + " is not in the hierarchy of " +
                     shown_path(args.scene) + " (hierarchy.levels = " + std::to_string(scene.hierarchy.levels) +
                     "); allowed: 0.." + std::to_string(scene.hierarchy.levels - 1));
  ProgressiveRunOptions opt;
  opt.out_path = out_path;
  opt.frames = args.frames;
  opt.task.system.direct = args.mode == "direct";
  opt.task.system.hessian = parse_level_hessian(args.hessian.empty() ? "auto" : args.hessian);
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
    stored += r.frame > 0;
    stop_if_signalled(r.frame);
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
  return unconverged_exit_code(args, not_converged, -1);
}

// pd simulate in direct mode on the scene's meshes as given (one level, no hierarchy).
int simulate_direct(const SimulateArgs& args, const Scene& scene, const std::string& out_path, int& stored) {
  const int frames = args.frames >= 1 ? args.frames : scene.frames;
  Progress progress("simulate " + scene.name, frames);
  int total_iterations = 0;
  double total_seconds = 0;

  DirectRunOptions opt;
  opt.out_path = out_path;
  opt.frames = args.frames;
  opt.on_frame = [&](const FrameRecord& r) {
    stored += r.frame > 0;
    stop_if_signalled(r.frame);
    total_iterations += r.newton.iterations;
    total_seconds += r.seconds;
    if (!args.quiet && r.frame > 0)
      progress.update(r.frame, std::to_string(r.newton.iterations) + " Newton its" +
                                   (r.newton.converged ? "" : " (" + r.newton.stop_reason + ")"));
  };
  const int not_converged = run_direct(scene, opt);

  char summary[256];
  std::snprintf(summary, sizeof summary, "%d frames -> %s: %d Newton iterations, %s solving%s", frames,
                shown_path(args.out).c_str(), total_iterations, format_duration(total_seconds).c_str(),
                not_converged ? ", some steps did not converge (see stats/newton_converged)" : "");
  if (!args.quiet) progress.finish(summary);
  return unconverged_exit_code(args, not_converged, frames);
}

// Options that apply to one mode only, against the mode of this run (--mode, else the scene's).
void check_mode_options(const SimulateArgs& args, bool mode_given) {
  const std::string mode = "--mode " + args.mode + (mode_given ? "" : " (the scene's \"mode\")");
  if (args.mode == "direct" && args.preview_only)
    throw InputError("--preview-only: does not apply to " + mode + "; allowed: with --mode progressive");
  if (args.mode == "direct" && !args.hessian.empty())
    throw InputError("--hessian: does not apply to " + mode + "; allowed: with --mode progressive");
  if (args.mode == "progressive" && args.level >= 0)
    throw InputError("--level: does not apply to " + mode + " (it runs every level); allowed: with --mode direct");
}

// Why the frame file `path` cannot be kept: empty when it opens and every frame marked done reads
// back. A failed write (disk full, file size limit) can leave HDF5's index pointing past the end of
// the file, so that frames stored before the failure no longer read back.
std::string unreadable_frames(const std::string& path) {
  try {
    const FrameReader reader(path);
    for (int l = 0; l < reader.num_levels(); ++l) {
      const std::vector<uint8_t> done = reader.done(l);
      for (int t = 0; t < static_cast<int>(done.size()); ++t)
        if (done[static_cast<std::size_t>(t)] == 1) reader.frame(l, t);
    }
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

// After a failed run: the frames stored before the error are kept (the temporary renamed onto the
// output, its done flags saying which frames exist) when at least one frame t >= 1 was stored and
// every stored frame reads back; else the temporary is removed (no damaged file replaces OUT).
// Returns what to add to the error message.
std::string keep_stored(PartialOutput& out, int stored) {
  if (stored < 1) {
    out.discard();
    return "";
  }
  const std::string damaged = unreadable_frames(out.path());
  if (!damaged.empty()) {
    out.discard();
    return " (the frames stored before the error were not kept: the failed write damaged the file: " + damaged + ")";
  }
  try {
    out.commit();
  } catch (const std::exception& e) {
    return std::string(" (and the frames stored before it are lost: ") + e.what() + ")";
  }
  return " (the " + std::to_string(stored) + " frame" + (stored == 1 ? "" : "s") + " stored before the error are in " +
         shown_path(out.final_path()) + ")";
}

}  // namespace

// Refuses a scene this process cannot hold before any of it is built (util/memory_budget.h): a
// 2 M-vertex sheet under a 2 GiB limit used to end in "internal error: std::bad_alloc".
void check_memory(const std::string& scene_path, const Scene& scene) {
  long long vertices = 0;
  for (const SceneObject& o : scene.objects) vertices += o.rest.num_vertices();
  const double needed = simulation_bytes(vertices);
  const MemoryBudget budget = memory_budget();
  if (needed > budget.bytes)
    throw InputError(shown_path(scene_path) + ": " + std::to_string(vertices) + " vertices would need about " +
                     gib_text(needed) + " to simulate (about " + std::to_string(int(kSimulationBytesPerVertex / 1024)) +
                     " KiB a vertex); " + gib_text(budget.bytes) + " is left to this process by " + budget.limited_by);
}

int simulate(const SimulateArgs& given) {
  check_scene_files(given.scene);
  const Scene scene = load_scene(given.scene);
  SimulateArgs args = given;
  const bool mode_given = !args.mode.empty();
  if (!mode_given) args.mode = scene.progressive ? "progressive" : "direct";
  check_mode_options(args, mode_given);
  check_memory(args.scene, scene);
  set_element_threads(args.threads);
  std::vector<std::string> inputs = scene_obj_paths(args.scene, scene.json_text);
  inputs.push_back(args.scene);
  check_output_file(args.out, "--out", inputs);
  check_replaceable(args.out, "--out", args.force, is_frame_file(args.out), "a frame file");

  PartialOutput out(args.out, "--out");
  const StopSignals signals(SA_RESTART | SA_RESETHAND);
  int stored = 0;  // frames t >= 1 written to out.path()
  int code = 0;
  try {
    const bool levels = args.mode == "progressive" || args.level >= 0 || args.levels >= 1;
    code = levels ? simulate_levels(args, scene, out.path(), stored) : simulate_direct(args, scene, out.path(), stored);
  } catch (const InputError& e) {
    throw InputError(e.what() + keep_stored(out, stored));
  } catch (const StateDiverged& e) {
    throw StateDiverged(shown_path(args.scene) + ": " + e.what() + keep_stored(out, stored));
  } catch (const std::bad_alloc&) {
    throw OutOfMemory(shown_path(args.scene) + ": out of memory (an allocation failed)" + keep_stored(out, stored));
  } catch (const std::exception& e) {
    throw std::runtime_error(e.what() + keep_stored(out, stored));
  }
  out.commit();
  return code;
}

}  // namespace pd::cli
