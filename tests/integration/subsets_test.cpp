// Time subsets on the farm: real pd-scheduler and pd-worker processes (tests/support/farm.h), jobs
// cut into K >= 2 subsets per refinement level. Checked: K = 2 keeps every frame intersection-free
// and equal to K = 1 up to the seam placed from the preview; one worker and two give the same frames;
// a refused vertical start moves its seam (and at last continues horizontally) with the frames of the
// single run; a seam every 10th frame keeps the contact promise; pd refine --subsets waits for the
// preview; a seam's stitch takes away the pop an unstitched seam shows. Split from farm_test.cpp (the same FarmTest suite, so the CI's test patterns are unchanged).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "farm/task_graph.h"
#include "progressive/error_measures.h"
#include "store/frame_store.h"
#include "support/farm.h"

namespace pd {
namespace {

using nlohmann::json;
using test::expect_complete_and_intersection_free;
using test::expect_every_level_complete;
using test::expect_identical_frames;
using test::fetch;
using test::Farm;
using test::FarmTest;
using test::job_status;
using test::kLongJob;
using test::kShortJob;
using test::max_vertex_deviation;
using test::run_beside_reference;
using test::scene_path;
using test::submit;
using test::task_workers;
using test::wait_until_done;

// The first seam of each refinement level: the smallest task start > 0 (0 when the level has none).
int first_seam(const json& job, int level) {
  int seam = 0;
  for (const json& t : job.at("tasks"))
    if (t.at("kind") == "level" && t.at("level") == level && t.at("first") > 0)
      seam = seam == 0 ? t.at("first").get<int>() : std::min(seam, t.at("first").get<int>());
  return seam;
}

// Subsets on cube-trampoline: 110 frames (seam 55), not the scene's 200. With 200 the level-2
// subset (100, 200] cannot start: safe upsampling of level 1's frame 100 finds "no valid perturbation
// found for restored vertex 306" (a limit of the library, reproduced outside the farm with
// solve_level_task; in contact it also fails for level 1 at frames 30, 40, 70, 80, 120, 180). Where it
// succeeds in contact it takes 6-28 s per vertical start (frames 45-65 but 55); at frame 55 (the cube
// in the air after its bounce) 0.3 s on level 1 and 1.7 s on level 2.
constexpr int kSubsetFrames = 110;

TEST_F(FarmTest, TwoSubsetsKeepEveryFrameIntersectionFreeAndEqualToOneSubsetBeforeTheSeam) {
  constexpr int kFrames = kSubsetFrames;
  Farm& farm = start_farm(2, "farm_k2");
  const std::string scene = scene_path("cube-trampoline.json");
  const std::string frames = std::to_string(kFrames);
  // Both jobs on one farm: the same CPU time as one job beside a reference pd simulate.
  const int64_t k1 = submit(farm, {scene, "--frames", frames, "--subsets", "1"});
  const int64_t k2 = submit(farm, {scene, "--frames", frames, "--subsets", "2"});
  wait_until_done(farm, k1, kLongJob);
  wait_until_done(farm, k2, kLongJob);
  fetch(farm, k1, farm.dir() + "/k1.h5");
  fetch(farm, k2, farm.dir() + "/k2.h5");

  const json status = job_status(farm, k2);
  expect_every_level_complete(status, kFrames);
  EXPECT_EQ(status.at("subsets"), 2);
  // K = 2's refinement levels were added once its preview was stored, cut at a seam placed from it
  // (farm/seam_placement.h: within a quarter subset of the even split 55, logged with the reason);
  // K = 1's were there from the start.
  const std::vector<json> placed = test::log_events(farm.scheduler_log(), "seams_placed");
  ASSERT_EQ(placed.size(), 1u);
  EXPECT_EQ(placed[0].at("job"), k2);
  EXPECT_EQ(test::log_events(farm.scheduler_log(), "job_refined").size(), 1u);
  const FrameReader one(farm.dir() + "/k1.h5"), two(farm.dir() + "/k2.h5");
  ASSERT_EQ(two.num_levels(), 3);
  ASSERT_EQ(two.num_levels(), one.num_levels());
  expect_complete_and_intersection_free(two);
  // The preview is a chain whatever K is: all of it equal.
  expect_identical_frames(two, one, 0, 0, kFrames);
  for (int l = 1; l < two.num_levels(); ++l) {
    const int seam = first_seam(status, l);
    EXPECT_NEAR(seam, 55, 110 / 8) << "level " << l;
    EXPECT_EQ(placed[0].at("message").get<std::string>().rfind("frame " + std::to_string(seam) + ",", 0), 0u)
        << placed[0].dump();
    if (seam <= 0) continue;
    expect_identical_frames(two, one, l, 0, seam);
    const double dev = max_vertex_deviation(two, one, l, seam + 1, kFrames);
    std::printf("K = 2 against K = 1, level %d: max vertex deviation after the seam (frames %d..%d) %.6g m\n", l,
                seam + 1, kFrames, dev);
    RecordProperty("max_deviation_after_seam_level_" + std::to_string(l) + "_m", std::to_string(dev));
  }
}

// The tasks of level l of a job's status, by first frame.
// The level's subsets and bridges (stitch = false) or its seams' stitch tasks (stitch = true), by first frame.
std::vector<json> level_tasks(const json& status, int level, bool stitch = false) {
  std::vector<json> out;
  for (const json& t : status.at("tasks"))
    if (t.at("kind") == "level" && t.at("level") == level && t.at("stitch").get<bool>() == stitch) out.push_back(t);
  std::sort(out.begin(), out.end(), [](const json& x, const json& y) { return x.at("first") < y.at("first"); });
  return out;
}

// A subset whose vertical start is refused moves its seam 3 frames later, twice, each time with a
// bridge task continuing the level horizontally over the frames left; refused a third time, it
// continues horizontally from the bridges' frames, so the job ends done instead of failing. The flag
// at 20 frames, K = 2, on workers that refuse every vertical start (pd-worker
// --refuse-vertical-starts: since safe upsampling projects strain limits none of the flag's starts is
// refused, LevelTask.AVerticalStartWhoseProlongationIsBeyondTheStrainLimitStartsBelowIt). Every task
// after the seam s then continues horizontally: (s, s+3], (s+3, s+6], (s+6, 20], and every level has
// the single run's frames bit for bit.
TEST_F(FarmTest, ASubsetWhoseVerticalStartIsRefusedContinuesHorizontallyAndTheJobEndsDone) {
  constexpr int kFrames = 20;
  test::FarmOptions options;
  options.worker_args = {"--refuse-vertical-starts"};
  Farm& farm = start_farm(options, "farm_refused_start");
  const std::string ref_path = farm.dir() + "/ref.h5";
  const int64_t job = run_beside_reference(farm, scene_path("flag.json"), kFrames, 2);

  const json status = job_status(farm, job);
  expect_every_level_complete(status, kFrames);
  for (int l = 1; l <= 2; ++l) {
    const std::vector<json> tasks = level_tasks(status, l);
    ASSERT_EQ(tasks.size(), 4u) << status.dump();
    const int seam = tasks[1].at("first").get<int>();
    EXPECT_NEAR(seam, kFrames / 2, kFrames / 8) << "the placed seam";
    for (int k = 1; k <= 3; ++k) {
      EXPECT_TRUE(tasks[k].at("horizontal").get<bool>()) << tasks[k].dump();
      EXPECT_EQ(tasks[k].at("first"), seam + 3 * (k - 1)) << tasks[k].dump();
    }
    EXPECT_EQ(tasks[3].at("attempts"), 4) << tasks[3].dump();  // three refused starts, then horizontal
  }
  EXPECT_EQ(test::log_events(farm.scheduler_log(), "seam_moved").size(), 4u);
  EXPECT_EQ(test::log_events(farm.scheduler_log(), "task_continues_horizontally").size(), 2u);
  const FrameReader got(farm.dir() + "/job.h5"), want(ref_path);
  ASSERT_EQ(got.num_levels(), 3);
  expect_complete_and_intersection_free(got);
  for (int l = 0; l < got.num_levels(); ++l) expect_identical_frames(got, want, l, 0, kFrames);
}

// A refused vertical start whose moved seam can be made: workers that refuse vertical starts before
// frame 13 (pd-worker --refuse-vertical-starts-before 13), the flag at 20 frames, K = 2, the seam
// placed near 10. Each level's later subset moves 3 frames at a time until it starts at 13 or later,
// vertically; bridges continue the level over the frames between, horizontally. No subset gives up
// its vertical start; the job ends done, intersection-free, each level the single run's frames up to
// its moved seam bit for bit (the bridges continue the single run).
TEST_F(FarmTest, ARefusedVerticalStartMovesItsSeamToAFrameWhereItCanBeMade) {
  constexpr int kFrames = 20;
  test::FarmOptions options;
  options.worker_args = {"--refuse-vertical-starts-before", "13"};
  Farm& farm = start_farm(options, "farm_moved_seam");
  const std::string ref_path = farm.dir() + "/ref.h5";
  const int64_t job = run_beside_reference(farm, scene_path("flag.json"), kFrames, 2);

  const json status = job_status(farm, job);
  expect_every_level_complete(status, kFrames);
  EXPECT_TRUE(test::log_events(farm.scheduler_log(), "task_continues_horizontally").empty());
  EXPECT_GE(test::log_events(farm.scheduler_log(), "seam_moved").size(), 2u);
  const FrameReader got(farm.dir() + "/job.h5"), want(ref_path);
  expect_complete_and_intersection_free(got);
  for (int l = 1; l <= 2; ++l) {
    const std::vector<json> tasks = level_tasks(status, l);
    ASSERT_GE(tasks.size(), 3u) << status.dump();
    const json& last = tasks.back();
    EXPECT_GE(last.at("first").get<int>(), 13) << last.dump();
    EXPECT_LE(last.at("first").get<int>(), 18) << last.dump();
    EXPECT_FALSE(last.at("horizontal").get<bool>()) << last.dump();  // it started vertically
    for (std::size_t k = 1; k + 1 < tasks.size(); ++k) EXPECT_TRUE(tasks[k].at("horizontal").get<bool>()) << tasks[k].dump();
    // The seam's stitch moved with it: one stitch task, from the moved seam to the level's end at most.
    const std::vector<json> stitches = level_tasks(status, l, true);
    ASSERT_EQ(stitches.size(), 1u) << status.dump();
    EXPECT_EQ(stitches[0].at("first"), last.at("first"));
    EXPECT_LT(stitches[0].at("last").get<int>(), kFrames);
    expect_identical_frames(got, want, l, 0, last.at("first").get<int>());
  }
}

// The contact promise with a seam every 10th frame: drape-sphere (cloth falling onto a sphere, self-
// contact, friction), 100 frames, K = 10, two workers. Its level-2 vertical start at frame 40
// upsampled to a state with 3 crossing face pairs (safe upsampling's own bug, not found yet), and
// frames 41-50 were stored crossing; such a start is now refused (the seam moves). Every frame of
// every level must be stored and intersection-free (the CGAL check); how many starts were refused for
// crossing is printed (1 when this was written).
TEST_F(FarmTest, ASeamEveryTenthFrameOfAClothOnASphereKeepsEveryFrameIntersectionFree) {
  constexpr int kFrames = 100;
  Farm& farm = start_farm(2, "farm_drape_seams");
  const int64_t job =
      submit(farm, {scene_path("drape-sphere.json"), "--frames", std::to_string(kFrames), "--subsets", "10"});
  wait_until_done(farm, job, kLongJob);
  fetch(farm, job, farm.dir() + "/job.h5");
  expect_every_level_complete(job_status(farm, job), kFrames);
  expect_complete_and_intersection_free(FrameReader(farm.dir() + "/job.h5"));
  int crossing = 0;
  for (const json& e : test::log_events(farm.scheduler_log(), "seam_moved"))
    crossing += e.at("message").get<std::string>().find("intersects itself") != std::string::npos;
  std::printf("vertical starts refused for a crossing upsampled state: %d\n", crossing);
}

TEST_F(FarmTest, OneWorkerAndTwoWorkersGiveIdenticalFramesWithTwoSubsets) {
  constexpr int kFrames = kSubsetFrames;
  const std::string scene = scene_path("cube-trampoline.json"), frames = std::to_string(kFrames);
  Farm& single = start_farm(1, "farm_one");
  Farm& pair = start_farm(2, "farm_two");
  const int64_t a = submit(single, {scene, "--frames", frames, "--subsets", "2"});
  const int64_t b = submit(pair, {scene, "--frames", frames, "--subsets", "2"});
  wait_until_done(single, a, kShortJob);
  wait_until_done(pair, b, kShortJob);
  fetch(single, a, single.dir() + "/job.h5");
  fetch(pair, b, pair.dir() + "/job.h5");
  const json status = job_status(pair, b);
  expect_every_level_complete(status, kFrames);
  const std::set<std::string> workers = task_workers(status);
  EXPECT_TRUE(workers.count("w1") && workers.count("w2")) << "tasks ran on: " << status.at("tasks").dump();

  const FrameReader x(single.dir() + "/job.h5"), y(pair.dir() + "/job.h5");
  ASSERT_EQ(x.num_levels(), y.num_levels());
  ASSERT_EQ(x.num_frames(), kFrames + 1);
  ASSERT_EQ(x.num_frames(), y.num_frames());
  for (int l = 0; l < x.num_levels(); ++l) expect_identical_frames(x, y, l, 0, kFrames);
}


// pd refine --subsets 3 of a preview-only job: while its preview runs the refinement is pending (no
// task above level 0, the job still running); once the preview is stored the levels are added, cut
// at seams placed from it (logged with the reasons, each within a quarter subset of its even split;
// pd status shows them), each seam with its stitch task, and the job ends done with every level complete and intersection-free.
TEST_F(FarmTest, RefiningWithSubsetsWaitsForThePreviewAndCutsTheLevelsAtSeamsPlacedFromIt) {
  constexpr int kFrames = 60;
  Farm& farm = start_farm(1, "farm_refine_seams");
  const int64_t job =
      submit(farm, {scene_path("cube-trampoline.json"), "--frames", std::to_string(kFrames), "--preview-only"});
  const test::RunResult refine = farm.pd({"refine", std::to_string(job), "--subsets", "3", "--json"});
  ASSERT_EQ(refine.exit_code, 0) << refine.describe();
  wait_until_done(farm, job, kShortJob);
  fetch(farm, job, farm.dir() + "/job.h5");
  const json status = job_status(farm, job);
  expect_every_level_complete(status, kFrames);
  const std::vector<json> placed = test::log_events(farm.scheduler_log(), "seams_placed");
  ASSERT_EQ(placed.size(), 1u);
  const std::string why = placed[0].at("message").get<std::string>();
  for (int l = 1; l <= 2; ++l) {
    std::vector<int> firsts;
    for (const json& t : level_tasks(status, l)) firsts.push_back(t.at("first").get<int>());
    ASSERT_EQ(firsts.size(), 3u) << status.dump();
    const std::vector<json> stitches = level_tasks(status, l, true);  // one per seam, pd's default width
    ASSERT_EQ(stitches.size(), 2u) << status.dump();
    EXPECT_EQ(firsts[0], 0);
    for (int k = 1; k <= 2; ++k) {
      EXPECT_NEAR(firsts[k], 20 * k, kFrames / 12) << "level " << l;
      EXPECT_NE(why.find("frame " + std::to_string(firsts[k]) + ","), std::string::npos) << why;
      EXPECT_EQ(stitches[static_cast<std::size_t>(k - 1)].at("first"), firsts[k]);
      EXPECT_EQ(stitches[static_cast<std::size_t>(k - 1)].at("last"), firsts[k] + farm::kDefaultStitchFrames - 1);
    }
  }
  // pd status shows the seams and why each was placed there (the log's reasons), and the stitch.
  ASSERT_EQ(status.at("seams").size(), 2u) << status.dump();
  for (const json& reason : status.at("seams")) EXPECT_NE(why.find(reason.get<std::string>()), std::string::npos) << why;
  const test::RunResult text = farm.pd({"status", std::to_string(job)});
  ASSERT_EQ(text.exit_code, 0) << text.describe();
  EXPECT_NE(text.out.find("  seams (K = 3, each stitched over " + std::to_string(farm::kDefaultStitchFrames) +
                          " frames):\n    frame "),
            std::string::npos)
      << text.out;
  // The refinement was added when the preview's last frame was stored, not before.
  double last_preview = 0.0;
  for (const json& e : test::log_events(farm.scheduler_log(), "frame_stored"))
    if (e.at("message") == "level 0 frame " + std::to_string(kFrames)) last_preview = e.at("time").get<double>();
  EXPECT_GE(test::log_events(farm.scheduler_log(), "job_refined").at(0).at("time").get<double>(), last_preview);
  expect_complete_and_intersection_free(FrameReader(farm.dir() + "/job.h5"));
}

// The pop of seams of one level of a job file (progressive/error_measures.h seam_pops), every vertex
// counted (the flag has no obstacle).
std::vector<SeamPop> level_pops(const FrameReader& r, int level, const std::vector<int>& seams) {
  const int n = r.num_frames() - 1;
  std::vector<double> m(static_cast<std::size_t>(n + 1), std::nan(""));
  const std::vector<char> all(static_cast<std::size_t>(r.num_vertices(level)), 1);
  for (int t = 1; t < n; ++t)
    m[static_cast<std::size_t>(t)] = max_second_difference(r.frame(level, t - 1), r.frame(level, t), r.frame(level, t + 1), all);
  return seam_pops(m, seams);
}

// The flag, 60 frames, two workers: K = 1, K = 2 without a stitch (--stitch 0) and K = 2 with pd's
// default stitch (16 frames). On the finest level the unstitched seam pops harder than the K = 1 run
// at the same frame (0.97 against 0.63 when this was written: visible by the rule of pd compare
// --seams, above 0.5 and 1.5x K = 1); stitched, neither the seam s nor the junction s + 15 where the
// later subset takes over is visible, and the seam's pop is below the unstitched one. The stitch
// changes only frames s + 1 .. s + 15: level 1 (fed by the same preview) is the unstitched job's bit
// for bit before and after them, and every frame is intersection-free.
TEST_F(FarmTest, AStitchedSeamDoesNotPopWhereTheUnstitchedSeamDoes) {
  constexpr int kFrames = 60;
  Farm& farm = start_farm(2, "farm_stitch");
  const std::string scene = scene_path("flag.json"), frames = std::to_string(kFrames);
  const int64_t single = submit(farm, {scene, "--frames", frames});
  const int64_t plain = submit(farm, {scene, "--frames", frames, "--subsets", "2", "--stitch", "0"});
  const int64_t stitched = submit(farm, {scene, "--frames", frames, "--subsets", "2"});
  std::vector<std::string> paths;
  for (const int64_t job : {single, plain, stitched}) {
    wait_until_done(farm, job, kLongJob);
    paths.push_back(farm.dir() + "/job" + std::to_string(job) + ".h5");
    fetch(farm, job, paths.back());
  }
  const json status = job_status(farm, stitched);
  expect_every_level_complete(status, kFrames);
  const FrameReader k1(paths[0]), k2(paths[1]), st(paths[2]);
  expect_complete_and_intersection_free(st);
  const int finest = st.num_levels() - 1;
  ASSERT_GE(finest, 2);
  const std::vector<json> stitches = level_tasks(status, finest, true);
  ASSERT_EQ(stitches.size(), 1u) << status.dump();
  const int s = stitches[0].at("first").get<int>(), junction = stitches[0].at("last").get<int>();
  ASSERT_EQ(junction, s + farm::kDefaultStitchFrames - 1);
  ASSERT_EQ(first_seam(job_status(farm, plain), finest), s) << "both jobs place their seam from the same preview";

  const std::vector<SeamPop> base = level_pops(k1, finest, {s, junction});
  const std::vector<SeamPop> unstitched = level_pops(k2, finest, {s});
  const std::vector<SeamPop> got = level_pops(st, finest, {s, junction});
  ASSERT_EQ(got.size(), 2u);
  std::printf("level %d seam %d: pop %.3g unstitched, %.3g stitched, %.3g K = 1; junction %d: %.3g (K = 1 %.3g)\n",
              finest, s, unstitched[0].pop, got[0].pop, base[0].pop, junction, got[1].pop, base[1].pop);
  for (std::size_t i = 0; i < 2; ++i)
    EXPECT_FALSE(got[i].pop > 0.5 && got[i].pop > 1.5 * base[i].pop) << "visible at frame " << got[i].seam;
  EXPECT_LT(got[0].pop, unstitched[0].pop);

  expect_identical_frames(st, k2, 1, 0, s);
  expect_identical_frames(st, k2, 1, junction + 1, kFrames);
  EXPECT_GT(max_vertex_deviation(st, k2, finest, s + 1, s + 1), 0.0) << "the stitch changed nothing";
}

}  // namespace
}  // namespace pd
