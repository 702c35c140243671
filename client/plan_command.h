#pragma once
// pd plan FILE.h5: predicts the wall time of a farm job on W workers (farm/makespan.h) from the step
// times measured in a finished progressive run of the same scene (pd simulate --mode progressive).
//
// Per level, the step cost is each frame's "solve_seconds" stat (the mean over the level's done frames
// t > 0 where a frame has none, and for every frame with --frames, below);
// N = the file's frame count - 1; the job's levels are the levels 0..L that hold solved frames. What
// the file does not measure is assumed and printed as such: a vertical start costs 2 x the level's
// step cost unless --vertical-start-seconds is given, the hierarchy task --hierarchy-seconds (0) and
// each task's dispatch --dispatch-seconds (0). With --subsets K >= 2 and level 0 stored whole, the
// refinement levels are cut at the seams the scheduler would place from that preview
// (farm/seam_placement.h), printed with the reason for each; otherwise at the even split. --frames N
// plans a job of N frames with the file's step costs (a shot longer than the run measured; its seams
// are then the even split).
//
// Bad input (missing or unreadable file, no solved frame, a level with frames above one without,
// --subsets < 1, a bad --workers list, a negative time) throws InputError naming the option or the
// file, e.g. "plan: --subsets: must be >= 1, got 0".
#include <iosfwd>
#include <optional>
#include <string>

#include "farm/task_graph.h"

namespace CLI {
class App;
}

namespace pd::cli {

struct PlanArgs {
  std::string file;
  std::string workers = "1,2,8,32,128";  // comma-separated worker counts, each >= 1
  int subsets = 1;                       // K per refinement level (clamped to N as the farm does)
  int stitch = farm::kDefaultStitchFrames;  // W frames per seam stitch, as pd submit's --stitch
  int frames = 0;                        // N to plan; 0: the file's (a longer shot with the file's step costs)
  int preview_chunk = 0;                 // frames per preview task; 0: the farm's default
  std::optional<double> vertical_start_seconds;  // one vertical start, every level; unset: 2 x step cost
  double hierarchy_seconds = 0.0;        // the hierarchy task (not stored in frame files)
  double dispatch_seconds = 0.0;         // overhead of every task
  bool json = false;                     // one JSON object instead of the table
  // Where the table or JSON goes; nullptr: std::cout. (Tests point it at a std::ostringstream.)
  std::ostream* out = nullptr;
};

// Adds the `plan` subcommand, its options bound to `args`, to `app`; returns it (main checks `*cmd`
// after parsing and calls plan(args)).
CLI::App* add_plan_subcommand(CLI::App& app, PlanArgs& args);

// Runs pd plan; returns the exit code (0), throws InputError for bad input.
int plan(const PlanArgs& args);

}  // namespace pd::cli
