// Speed against consistency of Progressive Dynamics on scene files (issue 5's benchmark): for each
// scene, the progressive run (preview, then every refinement level, as `pd simulate --mode
// progressive`) and direct simulation of the coarsest and the finest level (`--mode direct
// --level`), all in this process, frames kept in memory.
//
// Per level: vertices, seconds per step, Newton iterations per step, and the max / mean
// centre-of-mass deviation from the finest level of the same kind of run (sum over simulated
// objects, as `pd compare`). Per scene: preview speed-up over direct finest (direct finest s/step
// over preview s/step; the paper reports 21x-75x on its scenes), preview overhead over direct
// coarsest (preview s/step over direct coarsest s/step; the paper: about 2x), and the coarsest-vs-
// finest deviation of both kinds of run with their ratio. Unless the preview's Hessian is already
// Galerkin's, the preview is also run with the exact Galerkin Hessian, for its cost and its deviation.
//
//   pd_bench_progressive                                   # the six progressive scenes of scenes/
//   pd_bench_progressive scenes/flag.json --frames 100     # given scenes, fewer frames
//   pd_bench_progressive bench/scenes/flag-large.json      # 16x finer variants (bench/scenes/)
//   --levels N      override every scene's hierarchy.levels
//   --hessian auto|galerkin|lagged|coarse|coarse-first
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "bench_main.h"
#include "progressive/consistency.h"
#include "progressive/level_task.h"
#include "scene/scene_file.h"
#include "store/frame_store.h"

using namespace pd;

namespace {

struct LevelRun {
  int level = 0;
  int vertices = 0;
  double seconds = 0.0;  // wall time of the level's task, s
  long newton = 0;       // Newton iterations over all steps
  int unconverged = 0;
  std::map<int, Eigen::VectorXd> x;
  std::map<int, ObjectPoints> com;
};

LevelRun solve(const Scene& scene, const SceneHierarchy& h, int level, const LevelRun* below, bool direct,
               const LevelTaskOptions& base) {
  LevelRun run;
  run.level = level;
  run.vertices = static_cast<int>(h.levels[static_cast<std::size_t>(level)].rest.V.rows());
  LevelTaskInputs in;
  if (below) in.below = [below](int t) { return below->x.at(t); };
  LevelTaskOptions opt = base;
  opt.system.direct = direct;
  const auto t0 = std::chrono::steady_clock::now();
  const LevelTaskReport r = solve_level_task(scene, h, {level, 0, scene.frames}, in, [&](const FrameRecord& f) {
    run.x[f.frame] = f.x;
    run.com[f.frame] = f.center_of_mass;
    run.newton += f.newton.iterations;
  }, opt);
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.unconverged = r.unconverged_steps;
  return run;
}

// max and mean over frames of the summed distance between simulated objects' centres of mass (m).
std::pair<double, double> deviation(const Scene& scene, const LevelRun& a, const LevelRun& b) {
  std::vector<char> obstacle;
  for (const SceneObject& o : scene.objects) obstacle.push_back(o.obstacle ? 1 : 0);
  double worst = 0.0, sum = 0.0;
  for (const auto& [t, com] : a.com) {
    const double d = com_distance(com, b.com.at(t), obstacle);
    worst = std::max(worst, d);
    sum += d;
  }
  return {worst, sum / static_cast<double>(a.com.size())};
}

int run(int argc, char** argv) {
  CLI::App app{"pd_bench_progressive: speed against consistency of Progressive Dynamics (see the source's header)"};
  std::vector<std::string> files = {"scenes/cube-trampoline.json", "scenes/flag.json",      "scenes/drape-gear.json",
                                    "scenes/basket.json",          "scenes/ball-drop.json", "scenes/spin-sphere.json"};
  int frames = -1, levels = -1;
  std::string hessian = "auto";
  app.add_option("scenes", files, "Scene files (default: the six progressive scenes of scenes/)");
  app.add_option("--frames", frames, "Frames to run (default: each scene's)")->check(CLI::Range(1, 1000000));
  app.add_option("--levels", levels, "Override every scene's hierarchy.levels")->check(CLI::Range(1, 32));
  app.add_option("--hessian", hessian, "The prolonged Hessian: auto, galerkin, lagged, coarse or coarse-first");
  CLI11_PARSE(app, argc, argv);
  LevelTaskOptions options;
  try {
    options.system.hessian = parse_level_hessian(hessian);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "pd_bench_progressive: --hessian: %s\n", e.what());
    return 2;
  }

  std::vector<std::string> level_rows, scene_rows;
  for (const std::string& file : files) {
    Scene scene = load_scene(file);
    if (frames >= 1) scene.frames = frames;
    if (levels >= 1) scene.hierarchy.levels = levels;
    const auto t0 = std::chrono::steady_clock::now();
    const SceneHierarchy h = build_scene_hierarchy(scene);
    const double build = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const int L = h.finest();
    std::printf("%s: %d levels, %d frames, hierarchy %.2f s\n", scene.name.c_str(), L + 1, scene.frames, build);
    std::fflush(stdout);
    const std::size_t rows_before = level_rows.size();
    std::vector<LevelRun> progressive;
    for (int l = 0; l <= L; ++l) {
      progressive.push_back(solve(scene, h, l, l > 0 ? &progressive.back() : nullptr, false, options));
      const LevelRun& r = progressive.back();
      std::printf("  progressive level %d: %d vertices, %.3f s/step, %.1f Newton its/step, %d unconverged\n", l,
                  r.vertices, r.seconds / scene.frames, double(r.newton) / scene.frames, r.unconverged);
      std::fflush(stdout);
    }
    // The same preview with the exact Galerkin Hessian at every iterate, to measure what the run's
    // cheaper preview Hessian saves and changes (only when the run above used another one).
    LevelRun galerkin_preview;
    const bool compare_hessians =
        options.system.hessian.value_or(auto_prolonged_hessian(0)) != ProlongedHessian::Galerkin;
    if (compare_hessians) {
      LevelTaskOptions exact = options;
      exact.system.hessian = ProlongedHessian::Galerkin;
      galerkin_preview = solve(scene, h, 0, nullptr, false, exact);
      std::printf("  preview with the Galerkin Hessian: %.3f s/step, %.1f Newton its/step, %d unconverged\n",
                  galerkin_preview.seconds / scene.frames, double(galerkin_preview.newton) / scene.frames,
                  galerkin_preview.unconverged);
    }
    const LevelRun d0 = solve(scene, h, 0, nullptr, true, options);
    const LevelRun dL = solve(scene, h, L, nullptr, true, options);
    for (const LevelRun* r : {&d0, &dL})
      std::printf("  direct level %d: %d vertices, %.3f s/step, %.1f Newton its/step, %d unconverged\n", r->level,
                  r->vertices, r->seconds / scene.frames, double(r->newton) / scene.frames, r->unconverged);
    const auto row = [&](const char* kind, const LevelRun& r, const LevelRun& finest) {
      const auto [worst, mean] = deviation(scene, r, finest);
      char buf[512];
      std::snprintf(buf, sizeof buf, "| %s | %s | %d | %d | %.4f | %.1f | %d | %.4g / %.4g |", scene.name.c_str(), kind,
                    r.level, r.vertices, r.seconds / scene.frames, double(r.newton) / scene.frames, r.unconverged,
                    1e3 * worst, 1e3 * mean);
      level_rows.push_back(buf);
    };
    for (const LevelRun& r : progressive) row("progressive", r, progressive.back());
    if (compare_hessians) row("preview, Galerkin Hessian", galerkin_preview, progressive.back());
    row("direct", d0, dL);
    row("direct", dL, dL);
    const double preview = progressive.front().seconds;
    const double prog_dev = deviation(scene, progressive.front(), progressive.back()).first;
    const double direct_dev = deviation(scene, d0, dL).first;
    const double prog_dev_finest_direct = deviation(scene, progressive.back(), dL).first;
    char buf[512];
    char lag[64] = "-";
    if (compare_hessians) std::snprintf(lag, sizeof lag, "%.2fx", galerkin_preview.seconds / preview);
    std::snprintf(buf, sizeof buf, "| %s | %d | %.2f | %.1fx | %.2fx | %s | %.4g | %.4g | %.1fx | %.4g |",
                  scene.name.c_str(), scene.frames, build, dL.seconds / preview, preview / d0.seconds, lag,
                  1e3 * prog_dev, 1e3 * direct_dev, direct_dev / prog_dev, 1e3 * prog_dev_finest_direct);
    scene_rows.push_back(buf);
    // This scene's rows now as well, so a run stopped in a later scene keeps them.
    for (std::size_t k = rows_before; k < level_rows.size(); ++k) std::printf("%s\n", level_rows[k].c_str());
    std::printf("%s\n", buf);
    std::fflush(stdout);
  }
  std::printf("\n| scene | run | level | vertices | s/step | Newton its/step | unconverged steps | centre-of-mass "
              "deviation from the same run's finest level, max / mean (mm) |\n| --- | --- | ---: | ---: | ---: | ---: "
              "| ---: | --- |\n");
  for (const std::string& r : level_rows) std::printf("%s\n", r.c_str());
  std::printf("\n| scene | frames | hierarchy s | preview speed-up over direct finest | preview / direct coarsest | "
              "Galerkin preview / lagged preview | coarsest-vs-finest deviation, progressive (mm) | the same, direct (mm) | direct / progressive | "
              "progressive finest vs direct finest (mm) |\n| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
  for (const std::string& r : scene_rows) std::printf("%s\n", r.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pd::bench::run_benchmark("pd_bench_progressive", run, argc, argv);
}
