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
  // "direct": plain implicit Euler; without `level` on the finest mesh as given, stored as level 0
  // with no hierarchy; with `level` on that hierarchy level's mesh, stored with the hierarchy.
  // "progressive": PD's preview then every refinement level. Empty: the scene's "mode" key.
  std::string mode;
  int level = -1;           // direct: the hierarchy level to simulate (0 = coarsest)
  int levels = -1;          // override of the scene's hierarchy.levels
  bool preview_only = false;  // progressive: stop after level 0
  std::string hessian = "lagged";  // progressive: "galerkin", "lagged" or "coarse" (progressive/prolonged_term.h)
};
int simulate(const SimulateArgs& args);

struct ExportArgs {
  std::string file;
  int level = 0;
  std::string format = "obj";
  std::string out_dir;
  bool rest = false;     // write every level's rest mesh as level_<l>.obj (instead of frames)
  bool prolong = false;  // write the frames of `level` prolonged to the finest mesh (P^level)
};
int export_frames(const ExportArgs& args);

struct HierarchyArgs {
  std::string scene;
  std::string out;    // frame file that receives the hierarchy (reused when its hash matches)
  bool json = false;  // print one JSON object instead of text lines
};
int hierarchy(const HierarchyArgs& args);

struct CompareArgs {
  std::string file;   // the reference is this file's finest level that holds frames
  std::string other;  // optional second file (e.g. a direct run of the same scene)
  std::string csv;    // CSV output; empty: FILE.compare.csv
};
int compare(const CompareArgs& args);

}  // namespace pd::cli
