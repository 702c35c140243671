// pd_bench_seam_stitch: does a stitch remove the pop of a time subset's seam? (issue 44, item 4.)
//
// For one scene, the single run (K = 1) of levels 0..L, then level L's later subset (S, N] started
// vertically at the seam S (safe upsampling of level L-1's frame S, as a farm task starts it), and,
// for each width W, a stitch: level L continued horizontally from the single run's frames S-1 and S
// over (S, S+W], guided toward the later subset's frames (LevelTaskInputs::stitch_target,
// physics/guide.h). The trajectory a user would get:
//   W = 0: the single run up to S, the later subset after it (a plain seam);
//   W > 0: the single run up to S, the stitch over S+1..S+W-1, the later subset from S+W on.
// Per W: the seam pops (progressive/error_measures.h, seam_pops: peak second difference at s and
// s + 1 over the 95th percentile of the 40 frames around) at S and at the junction S + W - 1, with
// the single run's pops at the same frames as the baseline (visible: pop > 0.5 and > 1.5x baseline,
// as pd compare judges); how far the stitch's frame S + W lands from the later subset's; the
// stitch's time against the later subset's per-step time.
//
//   pd_bench_seam_stitch SCENE --frames N --seam S [--widths 0,4,8,16] [--level L]
// prints one line per width and a JSON object per width on the last lines.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
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
using pd::bench::fed_by;
using pd::bench::solve_frames;

// m(t) of a trajectory (every vertex), NaN where t-1, t, t+1 are not all there.
std::vector<double> second_differences(const Frames& run, int frames) {
  std::vector<double> m(static_cast<std::size_t>(frames + 1), std::numeric_limits<double>::quiet_NaN());
  const std::vector<char> every(static_cast<std::size_t>(run.begin()->second.size() / 3), 1);
  for (int t = 1; t < frames; ++t)
    if (run.count(t - 1) && run.count(t) && run.count(t + 1))
      m[static_cast<std::size_t>(t)] = pd::max_second_difference(pd::as_rows(run.at(t - 1)), pd::as_rows(run.at(t)),
                                                                  pd::as_rows(run.at(t + 1)), every);
  return m;
}

nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

int run(int argc, char** argv) {
  CLI::App app{"pd_bench_seam_stitch: the pop of a seam with and without a stitch"};
  std::string scene_path;
  std::vector<int> widths{0, 4, 8, 16};
  int frames = 0, seam = 0, level = -1;
  app.add_option("scene", scene_path, "Scene file")->required();
  app.add_option("--frames", frames, "Frames N")->required()->check(CLI::Range(1, 1000000));
  app.add_option("--seam", seam, "Seam frame S (the later subset (S, N] starts there)")->required()->check(CLI::Range(1, 1000000));
  app.add_option("--widths", widths, "Stitch widths W to try, frames (0: no stitch; default 0,4,8,16)")
      ->delimiter(',')
      ->check(CLI::Range(0, 1000000));
  app.add_option("--level", level, "The level whose seam is measured (default: the finest; >= 1)");
  CLI11_PARSE(app, argc, argv);
  const int widest = *std::max_element(widths.begin(), widths.end());
  if (seam + widest + 25 > frames || seam < 21) {
    std::fprintf(stderr, "--seam: needs 21 <= seam and seam + the widest stitch + 25 <= frames (pop windows)\n");
    return 2;
  }

  pd::Scene scene = pd::load_scene(scene_path);
  scene.frames = frames;
  const pd::SceneHierarchy h = pd::build_scene_hierarchy(scene);
  const int L = level >= 1 ? std::min(level, h.num_levels() - 1) : h.num_levels() - 1;
  std::map<int, double> kappa;
  const std::vector<Frames> single = pd::bench::single_run(scene, h, L, frames, &kappa);
  const Frames& one = single[static_cast<std::size_t>(L)];
  const Frames& below = single[static_cast<std::size_t>(L - 1)];
  double later_seconds = 0.0;
  const Frames later = solve_frames(scene, h, {L, seam, frames}, fed_by(&below), later_seconds);
  const double step_seconds = later_seconds / (frames - seam);
  std::printf("later subset (%d, %d] from a vertical start: %.2f s (%.4f s per step)\n", seam, frames, later_seconds,
              step_seconds);
  const std::vector<double> m_one = second_differences(one, frames);

  std::vector<nlohmann::json> results;
  for (const int w : widths) {
    Frames run;
    for (const auto& [t, x] : one)
      if (t <= seam) run[t] = x;
    for (const auto& [t, x] : later)
      if (t >= seam + std::max(w, 1)) run[t] = x;
    double stitch_seconds = 0.0, landing = 0.0;
    if (w > 0) {
      pd::LevelTaskInputs in = fed_by(&below);
      in.own_before = one.at(seam - 1);
      in.own_start = one.at(seam);
      if (kappa.count(seam)) in.own_kappa = kappa.at(seam);
      in.stitch_target = [&later](int f) { return later.at(f); };
      in.stitch_frames = w;
      const Frames stitch = solve_frames(scene, h, {L, seam, seam + w}, in, stitch_seconds);
      for (int t = seam + 1; t < seam + w; ++t) run[t] = stitch.at(t);
      landing = (stitch.at(seam + w) - later.at(seam + w)).cwiseAbs().maxCoeff();
    }
    const std::vector<int> seams = w > 1 ? std::vector<int>{seam, seam + w - 1} : std::vector<int>{seam};
    const std::vector<pd::SeamPop> pops = pd::seam_pops(second_differences(run, frames), seams);
    const std::vector<pd::SeamPop> base = pd::seam_pops(m_one, seams);
    nlohmann::json r = {{"scene", scene_path}, {"frames", frames}, {"seam", seam}, {"level", L}, {"width", w},
                        {"stitch_seconds", stitch_seconds}, {"stitch_steps_equivalent", stitch_seconds / step_seconds},
                        {"landing_max_m", landing}, {"pops", nlohmann::json::array()}};
    std::string line;
    for (std::size_t k = 0; k < pops.size(); ++k) {
      const bool visible = pops[k].pop > 0.5 && pops[k].pop > 1.5 * base[k].pop;
      r["pops"].push_back({{"frame", pops[k].seam}, {"pop", num(pops[k].pop)}, {"baseline_pop", num(base[k].pop)},
                           {"peak_m", num(pops[k].peak)}, {"visible", visible}});
      char text[160];
      std::snprintf(text, sizeof text, "%s frame %d pop %.2f (K=1 %.2f)%s", line.empty() ? "" : ",", pops[k].seam,
                    pops[k].pop, base[k].pop, visible ? " VISIBLE" : "");
      line += text;
    }
    std::printf("width %d: %s; stitch %.2f s (%.1f later steps), lands %.2e m from the later subset\n", w, line.c_str(),
                stitch_seconds, stitch_seconds / step_seconds, landing);
    results.push_back(r);
  }
  for (const nlohmann::json& r : results) std::printf("%s\n", r.dump().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pd::bench::run_benchmark("pd_bench_seam_stitch", run, argc, argv);
}
