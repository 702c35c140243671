// pd plan: replays a job's task graph on W workers with the step costs measured in a finished
// progressive run (plan_command.h; the model is farm/makespan.h).
#include "plan_command.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_text.h"
#include "farm/makespan.h"
#include "farm/seam_placement.h"
#include "frame_file_guard.h"
#include "output_files.h"
#include "farm/task_graph.h"
#include "store/frame_store.h"
#include "util/input_error.h"

namespace pd::cli {
namespace {

constexpr const char* kStepStat = "solve_seconds";

// "1,2,8" -> {1, 2, 8}; every entry a positive decimal integer.
std::vector<int> parse_workers(const std::string& list) {
  std::vector<int> out;
  std::stringstream in(list);
  std::string item;
  while (std::getline(in, item, ',')) {
    const auto begin = item.find_first_not_of(" \t"), end = item.find_last_not_of(" \t");
    const std::string s = begin == std::string::npos ? "" : item.substr(begin, end - begin + 1);
    errno = 0;
    char* stop = nullptr;
    const long v = s.empty() ? 0 : std::strtol(s.c_str(), &stop, 10);
    if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos || errno == ERANGE ||
        v > std::numeric_limits<int>::max())
      throw InputError("plan: --workers: '" + echo(s) + "' is not a positive integer (in '" + echo(list) + "')");
    if (v < 1) throw InputError("plan: --workers: must be >= 1, got " + echo(s));
    out.push_back(static_cast<int>(v));
  }
  if (out.empty() || (!list.empty() && list.back() == ','))
    throw InputError("plan: --workers: expected a comma-separated list of worker counts, got '" + echo(list) + "'");
  return out;
}

void require_seconds(const char* option, double value) {
  if (std::isfinite(value) && value >= 0.0) return;
  std::ostringstream msg;
  msg << "plan: " << option << ": must be a finite number >= 0, got " << value;
  throw InputError(msg.str());
}

void validate(const PlanArgs& a) {
  if (a.subsets < 1) throw InputError("plan: --subsets: must be >= 1, got " + std::to_string(a.subsets));
  if (a.preview_chunk < 0)
    throw InputError("plan: --preview-chunk: must be >= 0 (0: the default), got " + std::to_string(a.preview_chunk));
  if (a.vertical_start_seconds) require_seconds("--vertical-start-seconds", *a.vertical_start_seconds);
  require_seconds("--hierarchy-seconds", a.hierarchy_seconds);
  require_seconds("--dispatch-seconds", a.dispatch_seconds);
}

struct Measured {
  int frames = 0;                  // N
  std::vector<double> step;        // per level with frames: mean solve_seconds
  std::vector<int> frames_used;    // per level: frames t > 0 the mean is over
  // Per level and frame t = 0..N: that frame's solve_seconds (the level's mean where it has none).
  std::vector<std::vector<double>> frame_steps;
  // With K >= 2 and level 0 stored whole: the seams the scheduler would place from it.
  std::vector<farm::PlacedSeam> seams;
};

// The seams a farm job with K subsets gets from this preview (scheduler/seams.cpp does the same from
// its job file): empty when K < 2 or level 0 lacks a frame.
std::vector<farm::PlacedSeam> placed_seams(const FrameReader& reader, int subsets) {
  const std::vector<uint8_t> done = reader.done(0);
  if (subsets < 2 || std::find(done.begin(), done.end(), uint8_t{0}) != done.end()) return {};
  const std::vector<std::string> names = reader.stat_names(0);
  const bool has_pairs = std::find(names.begin(), names.end(), "contact_active_pairs") != names.end();
  const std::vector<double> pairs =
      has_pairs ? reader.stat(0, "contact_active_pairs") : std::vector<double>(done.size(), NAN);
  const farm::PreviewProfile p = farm::preview_profile(
      reader.num_frames() - 1, [&](int t) { return reader.frame(0, t); },
      [&](int t) { return pairs[static_cast<std::size_t>(t)]; });
  return farm::place_seams(p, subsets);
}

// The per-level step costs of a finished run: levels 0..L that hold solved frames, L + 1 >= 1.
Measured measure(const std::string& path, int subsets) {
  const FrameReader reader(path);
  Measured m;
  m.frames = reader.num_frames() - 1;
  if (m.frames < 1) throw InputError(path + ": plan: the file has no frame beyond frame 0 to measure");
  int first_empty = -1;
  for (int l = 0; l < reader.num_levels(); ++l) {
    const std::vector<uint8_t> done = reader.done(l);
    int solved = 0;
    for (int t = 1; t <= m.frames; ++t) solved += done[static_cast<std::size_t>(t)] ? 1 : 0;
    if (solved == 0) {
      if (first_empty < 0) first_empty = l;
      continue;
    }
    if (first_empty >= 0)
      throw InputError(path + ": plan: level " + std::to_string(l) + " has solved frames but level " +
                       std::to_string(first_empty) + " has none (not a progressive run)");
    const std::vector<std::string> names = reader.stat_names(l);
    if (std::find(names.begin(), names.end(), kStepStat) == names.end())
      throw InputError(path + ": plan: level " + std::to_string(l) + " has no " + kStepStat + " stat");
    const std::vector<double> seconds = reader.stat(l, kStepStat);
    double sum = 0.0;
    int used = 0;
    for (int t = 1; t <= m.frames; ++t) {
      const double s = seconds[static_cast<std::size_t>(t)];
      if (done[static_cast<std::size_t>(t)] && std::isfinite(s)) sum += s, ++used;
    }
    if (used == 0)
      throw InputError(path + ": plan: level " + std::to_string(l) + ": no solved frame has a " + kStepStat + " value");
    m.step.push_back(sum / used);
    m.frames_used.push_back(used);
    std::vector<double> per_frame(static_cast<std::size_t>(m.frames + 1), sum / used);
    for (int t = 1; t <= m.frames; ++t) {
      const double s = seconds[static_cast<std::size_t>(t)];
      if (done[static_cast<std::size_t>(t)] && std::isfinite(s)) per_frame[static_cast<std::size_t>(t)] = s;
    }
    m.frame_steps.push_back(std::move(per_frame));
  }
  if (m.step.empty()) throw InputError(path + ": plan: no level has a solved frame (t > 0) to measure");
  if (m.step.size() >= 2) m.seams = placed_seams(reader, subsets);
  return m;
}

struct Row {
  int workers = 0;
  farm::Plan plan;
  double speedup = 0.0;
};

void print_table(std::ostream& out, const PlanArgs& a, const Measured& m, const farm::GraphOptions& g,
                 const farm::Costs& c, const std::vector<Row>& rows) {
  const int k = std::min(g.subsets, g.frames);
  const int chunk = std::min(g.preview_chunk == 0 ? farm::default_preview_chunk(g.frames) : g.preview_chunk, g.frames);
  char line[256];
  out << "plan: " << a.file << ": N = " << g.frames << " frames, " << g.levels << " level(s), K = " << k
      << " subset(s) per refinement level, preview chunks of " << chunk << " frames"
      << (k >= 2 ? ", seams stitched over " + std::to_string(g.stitch) + " frames" : std::string()) << "\n";
  out << "step cost per level (measured: mean " << kStepStat << " over the level's solved frames):\n";
  for (int l = 0; l < g.levels; ++l) {
    std::snprintf(line, sizeof line, "  level %d: %.6g s (%d frames)\n", l, c.step_seconds[static_cast<std::size_t>(l)],
                  m.frames_used[static_cast<std::size_t>(l)]);
    out << line;
  }
  if (a.vertical_start_seconds) {
    out << "vertical start: " << *a.vertical_start_seconds << " s per subset k >= 2 (--vertical-start-seconds)\n";
  } else {
    out << "vertical start: ASSUMED 2 x the level's step cost per subset k >= 2 (set --vertical-start-seconds)\n";
  }
  if (!m.seams.empty()) {
    out << "seams (placed from the file's level 0 as the scheduler places them from the stored preview):\n";
    for (const farm::PlacedSeam& s : m.seams) out << "  " << s.reason << "\n";
  } else if (k >= 2) {
    out << "seams: the even split (the file's level 0 is not stored whole, or --frames plans another length)\n";
  }
  out << "hierarchy task: " << c.hierarchy_seconds << " s, dispatch: " << c.dispatch_seconds
      << " s per task (assumed; --hierarchy-seconds, --dispatch-seconds)\n";
  std::snprintf(line, sizeof line, "%8s %14s %9s %17s %6s\n", "workers", "makespan s", "speed-up", "preview done s",
                "busy");
  out << line;
  for (const Row& r : rows) {
    std::snprintf(line, sizeof line, "%8d %14.4f %9.2f %17.4f %5.1f%%\n", r.workers, r.plan.makespan, r.speedup,
                  r.plan.preview_seconds, 100.0 * r.plan.busy_fraction);
    out << line;
  }
}

void print_json(std::ostream& out, const PlanArgs& a, const Measured& m, const farm::GraphOptions& g,
                const farm::Costs& c, const std::vector<Row>& rows) {
  nlohmann::json j;
  j["file"] = a.file;
  j["frames"] = g.frames;
  j["levels"] = g.levels;
  j["subsets"] = std::min(g.subsets, g.frames);
  j["stitch"] = g.stitch;
  j["preview_chunk"] =
      std::min(g.preview_chunk == 0 ? farm::default_preview_chunk(g.frames) : g.preview_chunk, g.frames);
  j["step_seconds"] = c.step_seconds;
  j["measured_frames"] = m.frames_used;
  j["vertical_start_seconds"] = c.vertical_start_seconds;
  j["vertical_start_assumed"] = !a.vertical_start_seconds.has_value();
  j["hierarchy_seconds"] = c.hierarchy_seconds;
  j["dispatch_seconds"] = c.dispatch_seconds;
  j["seams"] = nlohmann::json::array();
  for (const farm::PlacedSeam& s : m.seams)
    j["seams"].push_back({{"frame", s.frame}, {"even", s.even}, {"reason", s.reason}});
  j["plans"] = nlohmann::json::array();
  for (const Row& r : rows) {
    j["plans"].push_back({{"workers", r.workers},
                          {"makespan_seconds", r.plan.makespan},
                          {"speedup", r.speedup},
                          {"preview_seconds", r.plan.preview_seconds},
                          {"first_preview_frame_seconds", r.plan.first_preview_frame_seconds},
                          {"level_finish_seconds", r.plan.level_finish},
                          {"busy_fraction", r.plan.busy_fraction}});
  }
  out << j.dump(2) << "\n";
}

}  // namespace

CLI::App* add_plan_subcommand(CLI::App& app, PlanArgs& args) {
  CLI::App* cmd = app.add_subcommand(
      "plan", "Predict a farm job's wall time on W workers from the step times of a finished progressive run");
  cmd->add_option("file", args.file, "Frame file of a finished progressive run (pd simulate --mode progressive)")
      ->required();
  cmd->add_option("--workers", args.workers, "Comma-separated worker counts to predict (default 1,2,8,32,128)");
  const CLI::Validator seconds = decimal_real(0.0, false, 1e9, "seconds, >= 0 and <= 1e9");
  cmd->add_option("--subsets", args.subsets, "Time subsets K per refinement level (default 1)")
      ->transform(decimal_integer(1, 2147483647));
  cmd->add_option("--stitch", args.stitch,
                  "Frames each seam is stitched over, as pd submit --stitch (default " +
                      std::to_string(farm::kDefaultStitchFrames) + ")")
      ->transform(decimal_integer(0, farm::kMaxStitchFrames));
  cmd->add_option("--frames", args.frames,
                  "Frames N to plan (default 0: the file's); a longer shot is planned with the file's step costs")
      ->transform(decimal_integer(0, kMaxFrames));
  cmd->add_option("--preview-chunk", args.preview_chunk, "Frames per preview task (default 0: min(50, N))")
      ->transform(decimal_integer(0, kMaxFrames));
  cmd->add_option_function<double>(
      "--vertical-start-seconds", [&args](const double& s) { args.vertical_start_seconds = s; },
      "Seconds of one vertical start (safe upsampling) of a subset k >= 2, every level; frame files do not "
      "measure it: without this option it is ASSUMED to be 2 x the level's step cost")
      ->transform(seconds);
  cmd->add_option("--hierarchy-seconds", args.hierarchy_seconds,
                  "Seconds of the hierarchy task (not in frame files; pd hierarchy prints it; default 0)")
      ->transform(seconds);
  cmd->add_option("--dispatch-seconds", args.dispatch_seconds, "Overhead of every task in seconds (default 0)")
      ->transform(seconds);
  cmd->add_flag("--json", args.json, "Print one JSON object instead of the table");
  return cmd;
}

int plan(const PlanArgs& args) {
  validate(args);
  check_input_file(args.file, "frame file");
  check_frame_file_in_child(args.file);
  const std::vector<int> workers = parse_workers(args.workers);
  Measured m = measure(args.file, args.subsets);
  if (args.frames > 0 && args.frames != m.frames) m.seams.clear();  // the file's preview is another length
  std::vector<int> seams;
  for (const farm::PlacedSeam& s : m.seams) seams.push_back(s.frame);

  farm::GraphOptions g;
  g.frames = args.frames > 0 ? args.frames : m.frames;
  g.levels = static_cast<int>(m.step.size());
  g.subsets = args.subsets;
  g.preview_chunk = args.preview_chunk;
  g.stitch = args.stitch;
  farm::Costs c;
  c.step_seconds = m.step;
  for (int l = 0; l < g.levels; ++l) {
    const double step = m.step[static_cast<std::size_t>(l)];
    c.vertical_start_seconds.push_back(l == 0 ? 0.0 : args.vertical_start_seconds.value_or(2.0 * step));
  }
  c.hierarchy_seconds = args.hierarchy_seconds;
  c.dispatch_seconds = args.dispatch_seconds;
  // The run's own length: each frame's measured step (unequal subsets planned as they run); a longer
  // shot: each level's mean.
  if (g.frames == m.frames) c.frame_step_seconds = m.frame_steps;

  const double one = farm::predict_plan(g, c, 1, seams).makespan;
  std::vector<Row> rows;
  for (int w : workers) {
    Row r;
    r.workers = w;
    r.plan = farm::predict_plan(g, c, w, seams);
    r.speedup = r.plan.makespan > 0.0 ? one / r.plan.makespan : 1.0;
    rows.push_back(r);
  }
  std::ostream& out = args.out ? *args.out : std::cout;
  if (args.json) {
    print_json(out, args, m, g, c, rows);
  } else {
    print_table(out, args, m, g, c, rows);
  }
  out.flush();
  return 0;
}

}  // namespace pd::cli
