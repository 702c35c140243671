// pd_bench_seam_overlap: does starting a time subset a few frames early, and discarding the overlap,
// reduce the jitter at its seam? (issue "speed against error": the seam jitter of K time subsets.)
//
// For one scene, the single run (K = 1) of every level, then the finest level's subset (a, N] solved
// again as a farm task would: started vertically at a - m (safe upsampling of level L-1's frame
// a - m) for each overlap m, its frames (a - m, a] discarded, frames a + 1.. kept. The level below
// is the single run's, so only the finest level's seam is measured. Seam jitter as pd compare
// --seams gives it (progressive/error_measures.h: d(t) = max over vertices of the acceleration
// difference to the single run, m per frame^2; ratio = max(d(a), d(a+1)) / median of d after them).
// Also the largest position difference from the single run after the seam, and each task's time.
//
//   pd_bench_seam_overlap SCENE --frames N --seam A [--overlaps 0,2,4,8]
// prints one line per overlap and a JSON object per overlap on the last lines.
#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench_main.h"
#include "level_runs.h"
#include "hierarchy/scene_hierarchy.h"
#include "progressive/error_measures.h"
#include "progressive/level_task.h"
#include "scene/scene_file.h"

namespace {

using pd::bench::Frames;

double max_distance(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  double d = 0.0;
  for (Eigen::Index v = 0; v < a.size() / 3; ++v) d = std::max(d, (a.segment<3>(3 * v) - b.segment<3>(3 * v)).norm());
  return d;
}

int run(int argc, char** argv) {
  CLI::App app{"pd_bench_seam_overlap: seam jitter of a vertical start with an overlap"};
  std::string scene_path;
  std::vector<int> overlaps{0, 2, 4, 8};
  int frames = 0, seam = 0, level = -1;
  app.add_option("scene", scene_path, "Scene file")->required();
  app.add_option("--frames", frames, "Frames N")->required()->check(CLI::Range(1, 1000000));
  app.add_option("--seam", seam, "Seam frame a (the subset (a, N] starts there)")->required()->check(CLI::Range(1, 1000000));
  app.add_option("--overlaps", overlaps, "Overlaps m to try, frames, comma-separated (default: 0,2,4,8)")
      ->delimiter(',')
      ->check(CLI::Range(0, 1000000));
  app.add_option("--level", level, "The level whose subset is measured (default: the finest; >= 1)");
  CLI11_PARSE(app, argc, argv);
  if (seam + 2 > frames) {
    std::fprintf(stderr, "--seam: needs seam + 2 <= frames\n");
    return 2;
  }

  pd::Scene scene = pd::load_scene(scene_path);
  scene.frames = frames;
  const pd::SceneHierarchy h = pd::build_scene_hierarchy(scene);
  const int L = level >= 1 ? std::min(level, h.num_levels() - 1) : h.num_levels() - 1;
  double total = 0.0;
  const std::vector<Frames> single = pd::bench::single_run(scene, h, L, frames, nullptr, &total);
  const Frames& ref = single[static_cast<std::size_t>(L)];
  const Frames& below = single[static_cast<std::size_t>(L - 1)];
  std::vector<nlohmann::json> results;
  for (const int m : overlaps) {
    nlohmann::json r = {{"scene", scene_path}, {"frames", frames}, {"seam", seam}, {"overlap", m}, {"level", L}};
    const int start = seam - m;
    if (start < 1) {
      r["error"] = "the overlap reaches frame 0";
      results.push_back(r);
      continue;
    }
    double s = 0.0;
    Frames subset;
    try {
      subset = pd::bench::solve_frames(scene, h, {L, start, frames}, pd::bench::fed_by(&below), s);
    } catch (const std::exception& e) {
      r["error"] = e.what();
      std::printf("overlap %d: failed: %s\n", m, e.what());
      results.push_back(r);
      continue;
    }
    // The K = 2 run: the first subset's frames (the single run's, up to a), then this subset's.
    Frames run;
    for (const auto& [t, x] : ref)
      if (t <= seam) run[t] = x;
    for (const auto& [t, x] : subset)
      if (t > seam) run[t] = x;
    // d(t) and the seam jitter as pd compare --seams computes them (progressive/error_measures.h).
    const std::vector<char> every(static_cast<std::size_t>(ref.at(0).size() / 3), 1);
    std::vector<double> d(static_cast<std::size_t>(frames + 1), std::numeric_limits<double>::quiet_NaN());
    for (int t = 1; t < frames; ++t)
      d[static_cast<std::size_t>(t)] = pd::acceleration_difference(
          pd::as_rows(run.at(t - 1)), pd::as_rows(run.at(t)), pd::as_rows(run.at(t + 1)), pd::as_rows(ref.at(t - 1)),
          pd::as_rows(ref.at(t)), pd::as_rows(ref.at(t + 1)), every);
    const pd::SeamJitter j = pd::seam_jitter(d, {seam});
    const double at_seam = j.max_seam_d, med = j.median_other;
    double after = 0.0;
    for (int t = seam + 1; t <= frames; ++t) after = std::max(after, max_distance(run.at(t), ref.at(t)));
    r["seconds"] = s;
    r["seam_d_m"] = at_seam;
    r["median_other_d_m"] = med;
    r["ratio"] = std::isfinite(j.ratio) ? nlohmann::json(j.ratio) : nlohmann::json(nullptr);
    r["max_distance_after_seam_m"] = after;
    std::printf("overlap %d: seam d %.3e m, median other %.3e m, ratio %s, max distance after the seam %.3e m, "
                "%.2f s (%d extra steps)\n",
                m, at_seam, med, std::isfinite(j.ratio) ? std::to_string(j.ratio).c_str() : "n/a", after, s, m);
    results.push_back(r);
  }
  std::printf("single run total %.2f s\n", total);
  for (const nlohmann::json& r : results) std::printf("%s\n", r.dump().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pd::bench::run_benchmark("pd_bench_seam_overlap", run, argc, argv);
}
