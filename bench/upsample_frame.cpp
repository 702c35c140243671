// Safe upsampling of stored frames (hierarchy/safe_upsampling.h): what a farm subset's vertical start
// does before its first step (progressive/level_task.cpp), taken out of the farm to be timed and
// profiled. For each frame T given, level L's frame T of a frame file (a pd simulate --mode
// progressive file or a farm job file, which hold the hierarchy) is upsampled to level L + 1 with the
// scene's settings (upsampling_level), and the report printed: counts, gaps, the time per phase, and
// then the result's self-intersections (the contact promise the level task checks) or the refusal.
//
//   pd_bench_upsample_frame SCENE.json FILE.h5 --level L --frames T1,T2,...
//
// The scene must be the one the file was made from (its hierarchy is read from the file, and the
// scene's level count is set to the file's).
#include <chrono>
#include <cstdio>
#include <exception>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "hierarchy/safe_upsampling.h"
#include "hierarchy/self_intersection_cgal.h"
#include "scene/scene_file.h"
#include "store/frame_store.h"
#include "store/hierarchy_store.h"
#include "upsampling_report.h"
#include "util/process_setup.h"

int main(int argc, char** argv) {
  pd::configure_numerical_libraries(argv);
  CLI::App app{"Safe upsampling of stored frames, level L -> L + 1, timed per phase"};
  std::string scene_path, file;
  int level = 0;
  std::string frames;
  app.add_option("scene", scene_path, "The scene file the frame file was made from")->required()->check(CLI::ExistingFile);
  app.add_option("file", file, "Frame file with the hierarchy and level L's frames")->required()->check(CLI::ExistingFile);
  app.add_option("--level", level, "The coarse level L (0 = coarsest)")->required()->check(CLI::Range(0, 18));
  app.add_option("--frames", frames, "Comma-separated frames T of level L")->required();
  CLI11_PARSE(app, argc, argv);
  try {
    pd::Scene scene = pd::load_scene(scene_path);
    std::optional<pd::SceneHierarchy> h = pd::read_hierarchy(file);
    if (!h) throw std::runtime_error(file + ": no hierarchy in the file");
    if (level + 1 >= h->num_levels())
      throw std::runtime_error("--level " + std::to_string(level) + ": the hierarchy has " +
                               std::to_string(h->num_levels()) + " levels, so L must be at most " +
                               std::to_string(h->num_levels() - 2));
    scene.hierarchy.levels = h->num_levels();
    const pd::UpsamplingLevel up = pd::upsampling_level(scene, *h, level);
    const pd::FrameReader reader(file);
    const pd::Faces& fine_faces = h->levels[static_cast<std::size_t>(level + 1)].rest.F;
    std::stringstream list(frames);
    for (std::string item; std::getline(list, item, ',');) {
      const int t = std::stoi(item);
      const pd::Positions coarse = reader.frame(level, t);
      const pd::Positions target = h->levels[static_cast<std::size_t>(level)].to_next->apply(coarse);
      pd::UpsamplingReport report;
      const auto t0 = std::chrono::steady_clock::now();
      try {
        const pd::Positions x = pd::safe_upsample(up, coarse, target, {}, &report);
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("level %d frame %d -> level %d (%d -> %d vertices): wall %.3f s; %s; %d self-intersecting face pairs\n",
                    level, t, level + 1, static_cast<int>(coarse.rows()), static_cast<int>(x.rows()), wall,
                    pd::bench::describe_upsampling(report).c_str(),
                    up.contact ? pd::count_self_intersections(x, fine_faces) : 0);
      } catch (const std::exception& e) {
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("level %d frame %d -> level %d: REFUSED after %.3f s: %s; %s\n", level, t, level + 1, wall, e.what(),
                    pd::bench::describe_upsampling(report).c_str());
      }
      std::fflush(stdout);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd_bench_upsample_frame: %s\n", e.what());
    return 1;
  }
  return 0;
}
