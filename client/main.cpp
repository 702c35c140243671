// pd: the command-line client. Local commands (simulate, export, hierarchy, compare) run in this process; the farm
// commands (submit, status, ...) come with the scheduler.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "util/input_error.h"
#include "util/process_setup.h"

int main(int argc, char** argv) {
  pd::limit_openmp_threads(argv);
  CLI::App app{"pd: progressive cloth and shell animation"};
  app.require_subcommand(1);

  pd::cli::SimulateArgs sim;
  auto* simulate = app.add_subcommand("simulate", "Simulate a scene on this machine into an HDF5 frame file");
  simulate->add_option("scene", sim.scene, "Scene file (JSON, see docs/scene-format.md)")->required();
  simulate->add_option("--out,-o", sim.out, "Frame file to create (HDF5, see docs/frame-format.md)")->required();
  simulate->add_option("--frames", sim.frames, "Simulate this many frames instead of the scene's count")
      ->check(CLI::PositiveNumber);
  simulate->add_flag("--quiet,-q", sim.quiet, "No progress output");
  simulate->add_option("--mode", sim.mode,
                       "direct (plain implicit Euler) or progressive (preview, then refinement); default: the scene's \"mode\"")
      ->check(CLI::IsMember({"direct", "progressive"}));
  simulate->add_option("--level", sim.level, "direct: simulate this hierarchy level's mesh (0 = coarsest)")
      ->check(CLI::NonNegativeNumber);
  simulate->add_option("--levels", sim.levels, "Use this many hierarchy levels instead of the scene's")
      ->check(CLI::PositiveNumber);
  simulate->add_flag("--preview-only", sim.preview_only, "progressive: stop after the preview (level 0)");
  simulate->add_option("--hessian", sim.hessian, "progressive: Hessian of the prolonged elasticity")
      ->check(CLI::IsMember({"galerkin", "lagged", "coarse"}));

  pd::cli::ExportArgs exp;
  auto* export_cmd = app.add_subcommand("export", "Write the frames of a frame file for other tools");
  export_cmd->add_option("file", exp.file, "Frame file (HDF5)")->required();
  export_cmd->add_option("--level", exp.level, "Resolution level (0 = coarsest)")->check(CLI::NonNegativeNumber);
  export_cmd->add_option("--format", exp.format, "Output format")->check(CLI::IsMember({"obj"}));
  export_cmd->add_option("--out,-o", exp.out_dir, "Output folder (created if missing)")->required();
  export_cmd->add_flag("--rest", exp.rest, "Write every level's rest mesh as level_<l>.obj (no frames)");
  export_cmd->add_flag("--prolong", exp.prolong,
                       "Write the frames of --level prolonged to the finest mesh (needs a stored hierarchy, "
                       "see pd hierarchy)");

  pd::cli::HierarchyArgs hier;
  auto* hierarchy = app.add_subcommand("hierarchy", "Build (or reuse) a scene's level hierarchy into a frame file");
  hierarchy->add_option("scene", hier.scene, "Scene file (JSON, see docs/scene-format.md)")->required();
  hierarchy->add_option("--out,-o", hier.out, "Frame file to create, or to reuse when its hierarchy matches")
      ->required();
  hierarchy->add_flag("--json", hier.json, "Print one JSON object instead of text lines");

  pd::cli::CompareArgs cmp;
  auto* compare = app.add_subcommand(
      "compare", "Centre-of-mass consistency between the levels of one or two frame files (prints, writes CSV)");
  compare->add_option("file", cmp.file, "Frame file; its finest level with frames is the reference")->required();
  compare->add_option("other", cmp.other, "A second frame file of the same scene (e.g. a direct run)");
  compare->add_option("--csv", cmp.csv, "CSV file to write (default FILE.compare.csv)");

  if (argc < 2) {  // bare `pd`: show what it can do, and fail (nothing was done)
    std::fputs(app.help().c_str(), stderr);
    return 2;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    // A bad command line is bad input like any other: same message prefix and exit code.
    std::fprintf(stderr, "pd: error: %s\nRun with --help for more information.\n", e.what());
    return 2;
  }

  try {
    if (*simulate) return pd::cli::simulate(sim);
    if (*export_cmd) return pd::cli::export_frames(exp);
    if (*hierarchy) return pd::cli::hierarchy(hier);
    if (*compare) return pd::cli::compare(cmp);
  } catch (const pd::InputError& e) {
    std::fprintf(stderr, "pd: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd: internal error: %s\n", e.what());
    return 1;
  }
  return 1;
}
