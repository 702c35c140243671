#pragma once
// The pd subcommands. Each returns the process exit code; input errors are thrown as InputError
// and turned into a message and exit code 2 by main().
#include <string>

namespace pd::cli {

struct SimulateArgs {
  std::string scene;
  std::string out;
  int frames = -1;     // override of the scene's frame count
  bool quiet = false;
};
int simulate(const SimulateArgs& args);

struct ExportArgs {
  std::string file;
  int level = 0;
  std::string format = "obj";
  std::string out_dir;
};
int export_frames(const ExportArgs& args);

}  // namespace pd::cli
