// A job's scene travels to each worker once (issue 46 item 2): the first task a worker runs carries
// the scene's text and files (meshes, an animated obstacle's PC2 cache, sent as base64), every later
// task names it by hash. Real pd-scheduler and pd-worker processes; the job's frames are those of
// `pd simulate` bit for bit, and no stored frame intersects.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "geometry/obj_io.h"
#include "geometry/shapes.h"
#include "store/frame_store.h"
#include "support/farm.h"
#include "support/pc2_bytes.h"

namespace pd {
namespace {

using nlohmann::json;
using test::Farm;
using test::FarmTest;

// A cotton sheet falling onto a box body that rises and widens, the body a PC2 cache at 50 fps;
// two levels, 30 frames of 1/100 s. Written under dir; returns the scene file's path.
std::string write_body_scene(const std::string& dir) {
  const TriMesh box = make_box(Vec3(0.3, 0.3, 0.3), 2);
  std::filesystem::create_directories(dir + "/body");
  write_obj(dir + "/body/rest.obj", box.V, box.F);
  std::vector<Positions> samples;
  for (int k = 0; k <= 15; ++k) {
    Positions x = box.V;
    x.col(0) *= 1.0 + 0.01 * k;
    x.col(1).array() += 0.004 * k;
    samples.push_back(x);
  }
  std::ofstream(dir + "/body/motion.pc2", std::ios::binary) << test::pc2_bytes(samples);
  const json scene = {
      {"format_version", 1}, {"name", "sheet-on-body"}, {"time_step", 0.01}, {"frames", 30},
      {"contact", {{"dhat", 1e-3}, {"friction", 0.3}}},
      {"hierarchy", {{"levels", 2}}},
      {"objects",
       {{{"name", "sheet"},
         {"mesh", {{"type", "rectangle"}, {"size", {0.5, 0.5}}, {"cells", {10, 10}}}},
         {"transform", {{"rotation", {{"axis", {1, 0, 0}}, {"angle_deg", -90}}}, {"translation", {0, 0.17, 0}}}},
         {"material", {{"preset", "cotton"}}}},
        {{"name", "body"},
         {"obstacle", true},
         {"mesh", {{"type", "obj"}, {"path", "body/rest.obj"}}},
         {"animation", {{"pc2", "body/motion.pc2"}, {"fps", 50}}}}}}};
  const std::string path = dir + "/sheet-on-body.json";
  std::ofstream(path) << scene.dump(2);
  return path;
}

TEST_F(FarmTest, AnAnimatedObstaclesCacheGoesToEachWorkerOnceAndTheFramesAreThoseOfPdSimulate) {
  Farm& farm = start_farm(2, "shipping");
  const std::string scene = write_body_scene(farm.dir() + "/shot");
  const int frames = 30;
  const std::string ref_path = farm.dir() + "/ref.h5";
  // Preview chunks of 10 frames: five tasks (hierarchy, three preview chunks, level 1) on two workers.
  const int64_t job = test::submit(farm, {scene, "--frames", std::to_string(frames), "--preview-chunk", "10"});
  test::Process ref = test::start_reference(scene, ref_path, frames);
  test::wait_until_done(farm, job, test::kLongJob);
  test::fetch(farm, job, farm.dir() + "/job.h5");
  test::finish_reference(ref, ref_path, test::kLongJob);

  std::map<std::string, int> assigned, with_scene;  // per worker
  for (const json& e : test::log_events(farm.scheduler_log(), "task_assigned")) {
    const std::string detail = e.at("message").get<std::string>();
    const std::string worker = detail.substr(detail.find(" to ") + 4, 2);
    ++assigned[worker];
    if (detail.find("with the scene (") != std::string::npos) ++with_scene[worker];
  }
  int total = 0;
  for (const auto& [worker, n] : assigned) {
    total += n;
    EXPECT_EQ(with_scene[worker], 1) << worker << " ran " << n << " tasks";
  }
  EXPECT_GT(total, static_cast<int>(assigned.size())) << "some worker must have run two tasks";

  const FrameReader got(farm.dir() + "/job.h5"), want(ref_path);
  ASSERT_EQ(got.num_levels(), 2);
  for (int l = 0; l < got.num_levels(); ++l) test::expect_identical_frames(got, want, l, 0, frames);
  test::expect_complete_and_intersection_free(got);
}

}  // namespace
}  // namespace pd
