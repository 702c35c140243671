// pd: the command-line client. Local commands (simulate, export) run in this process; the farm
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

  pd::cli::ExportArgs exp;
  auto* export_cmd = app.add_subcommand("export", "Write the frames of a frame file for other tools");
  export_cmd->add_option("file", exp.file, "Frame file (HDF5)")->required();
  export_cmd->add_option("--level", exp.level, "Resolution level (0 = coarsest)")->check(CLI::NonNegativeNumber);
  export_cmd->add_option("--format", exp.format, "Output format")->check(CLI::IsMember({"obj"}));
  export_cmd->add_option("--out,-o", exp.out_dir, "Output folder (created if missing)")->required();

  if (argc < 2) {  // bare `pd`: show what it can do, and fail (nothing was done)
    std::fputs(app.help().c_str(), stderr);
    return 2;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);  // prints usage errors to stderr with CLI11's exit code (non-zero)
  }

  try {
    if (*simulate) return pd::cli::simulate(sim);
    if (*export_cmd) return pd::cli::export_frames(exp);
  } catch (const pd::InputError& e) {
    std::fprintf(stderr, "pd: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd: internal error: %s\n", e.what());
    return 1;
  }
  return 1;
}
