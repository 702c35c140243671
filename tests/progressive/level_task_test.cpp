// The unit of work of a progressive run (progressive/level_task.h): a preview and a refinement run
// end to end; one level is the same as direct simulation; cutting a level into subsets; bit-for-bit
// reproducibility; bad tasks refused.
#include "progressive/level_task.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>

#include "geometry/shapes.h"
#include "hierarchy/safe_upsampling.h"
#include "progressive/test_scenes.h"
#include "scene/scene_file.h"
#include "support/test_paths.h"
#include "support/intersection_checker.h"

namespace pd {
namespace {

using Frames = std::map<int, Eigen::VectorXd>;

// A 0.4 m cotton sheet (8 x 8 cells) falling 2 cm onto a fixed sphere of radius 0.1 m, self-contact
// on, no friction; two levels.
Scene sheet_on_sphere(int frames) {
  Scene s = test::make_scene(0.01, frames, Vec3(0, -9.81, 0));
  TriMesh sheet = make_rectangle(0.4, 0.4, 8, 8);
  for (int v = 0; v < sheet.num_vertices(); ++v) sheet.V.row(v) = Vec3(sheet.V(v, 0), 0.12, sheet.V(v, 1)).transpose();
  SceneObject cloth = test::make_object("cloth", sheet, test::cotton());
  cloth.self_contact = true;
  s.objects.push_back(cloth);
  SceneObject ball = test::make_object("ball", make_icosphere(0.1, 1), test::cotton());
  ball.obstacle = true;
  s.objects.push_back(ball);
  ContactConfig c;
  c.dhat = 1e-3;
  c.offset = 5e-4;
  s.contact = c;
  s.hierarchy.levels = 2;
  return s;
}

// Runs a task, collecting its frames; `below` reads from `lower`.
LevelTaskReport run(const Scene& scene, const SceneHierarchy& h, const LevelTask& task, const Frames* lower,
                    Frames& out, LevelTaskInputs inputs = {}) {
  if (lower) inputs.below = [lower](int t) { return lower->at(t); };
  return solve_level_task(scene, h, task, inputs, [&](const FrameRecord& r) { out[r.frame] = r.x; });
}

double max_difference(const Frames& a, const Frames& b, int from) {
  double d = 0.0;
  for (const auto& [t, x] : a)
    if (t >= from) d = std::max(d, (x - b.at(t)).cwiseAbs().maxCoeff());
  return d;
}

TEST(LevelTask, PreviewAndRefinementRunEndToEndIntersectionFreeAndReproducibly) {
  const Scene scene = sheet_on_sphere(30);
  const SceneHierarchy h = build_scene_hierarchy(scene);
  Frames preview, fine;
  EXPECT_EQ(run(scene, h, {0, 0, 30}, nullptr, preview).unconverged_steps, 0);
  EXPECT_EQ(run(scene, h, {1, 0, 30}, &preview, fine).unconverged_steps, 0);
  ASSERT_EQ(preview.size(), 31u);
  ASSERT_EQ(fine.size(), 31u);
  for (const auto& [t, x] : fine) {
    EXPECT_TRUE(test::intersection_free(as_rows(x), h.levels[1].rest.F)) << "level 1 frame " << t;
    EXPECT_TRUE(test::intersection_free(as_rows(preview.at(t)), h.levels[0].rest.F)) << "level 0 frame " << t;
  }
  // The cloth has landed on the sphere and drapes: its centre vertex has come down from 0.12 m onto
  // the sphere's top, its edges hang below it.
  const int cloth_end = h.levels[1].vertex_offsets[1];
  const Positions cloth = as_rows(fine.at(30)).topRows(cloth_end);
  Eigen::Index centre = 0;
  (cloth.col(0).array().square() + cloth.col(2).array().square()).minCoeff(&centre);
  std::printf("[sheet on sphere] level 1, frame 30: centre vertex y = %.4f m, lowest cloth vertex y = %.4f m\n",
              cloth(centre, 1), cloth.col(1).minCoeff());
  const double ball_top = h.levels[1].rest.V.bottomRows(h.levels[1].rest.V.rows() - cloth_end).col(1).maxCoeff();
  EXPECT_LT(cloth(centre, 1), 0.12 - 5e-3);
  EXPECT_GT(cloth(centre, 1), ball_top - 0.02);  // on the top, not slid off
  EXPECT_LT(cloth.col(1).minCoeff(), 0.05);

  Frames again;
  run(scene, h, {1, 0, 30}, &preview, again);
  EXPECT_EQ(max_difference(fine, again, 0), 0.0);  // bit for bit
}

// With a single level (levels = 1) the preview IS direct simulation of the finest mesh.
TEST(LevelTask, SingleLevelPreviewIsDirectSimulationBitForBit) {
  Scene scene = sheet_on_sphere(15);
  scene.hierarchy.levels = 1;
  const SceneHierarchy h = build_scene_hierarchy(scene);
  Frames preview;
  run(scene, h, {0, 0, 15}, nullptr, preview);
  SceneSystem sys = build_scene_system(scene);
  LevelStepper stepper(sys, scene.solver, scene.time_step);
  Eigen::VectorXd x = sys.x0, v = sys.v0;
  for (int t = 0; t < 15; ++t) stepper.step(t, x, v);
  EXPECT_TRUE(preview.at(15) == x);
}

// Level 1 as one task, and as (0, 12] then (12, 24] started vertically from level 0's frame 12. No
// friction, wind or scripted pins, so only the start of the second subset differs (header), and the
// frames agree to the Newton tolerance from a few steps on.
TEST(LevelTask, SubsetStartedVerticallyFollowsTheSingleRun) {
  const Scene scene = sheet_on_sphere(24);
  const SceneHierarchy h = build_scene_hierarchy(scene);
  Frames preview, whole, first, second;
  run(scene, h, {0, 0, 24}, nullptr, preview);
  run(scene, h, {1, 0, 24}, &preview, whole);
  run(scene, h, {1, 0, 12}, &preview, first);
  const LevelTaskReport r = run(scene, h, {1, 12, 24}, &preview, second);
  EXPECT_TRUE(r.vertical_start);
  EXPECT_EQ(second.count(12), 0u);  // frame 12 belongs to the first subset
  EXPECT_EQ(max_difference(first, whole, 0), 0.0);
  const double d = max_difference(second, whole, 13);
  const auto frame_difference = [&](int t) { return (second.at(t) - whole.at(t)).cwiseAbs().maxCoeff(); };
  std::printf("[subsets] vertical start at 12: upsampled to %.3g m (max %.3g m) of the prolongation; frames 13-24 "
              "differ by at most %.3g m from the single run (frame 13: %.3g m, frame 24: %.3g m)\n",
              r.upsampling.rms_target_distance, r.upsampling.max_target_distance, d, frame_difference(13),
              frame_difference(24));
  // With contact the start matters (here the cloth rests on a 42-vertex sphere and the upsampled
  // start sits up to 5 mm from the prolongation, which dips into it): measured 4.9 mm at frame 13,
  // 5.7 mm at most. Bounded, and not growing over the subset.
  EXPECT_LT(d, 1e-2);
  EXPECT_LT(frame_difference(24), 1.5 * frame_difference(13));

  // A horizontal continuation from the level's own frames 11 and 12 is the single run bit for bit
  // when nothing adapts over the run (here: no contact section).
  Scene free_fall = scene;
  free_fall.contact.reset();
  free_fall.objects.pop_back();
  free_fall.objects[0].self_contact = false;
  const SceneHierarchy hf = build_scene_hierarchy(free_fall);
  Frames p, all, tail;
  run(free_fall, hf, {0, 0, 24}, nullptr, p);
  run(free_fall, hf, {1, 0, 24}, &p, all);
  LevelTaskInputs own;
  own.own_before = all.at(11);
  own.own_start = all.at(12);
  run(free_fall, hf, {1, 12, 24}, &p, tail, own);
  EXPECT_EQ(max_difference(tail, all, 13), 0.0);
  // Started vertically instead: without contact the minimiser does not depend on the start, and the
  // frames are the single run's to round-off (measured 2.8e-17 m).
  Frames vertical;
  run(free_fall, hf, {1, 12, 24}, &p, vertical);
  EXPECT_LT(max_difference(vertical, all, 13), 1e-12);
}

// With contact, a horizontal continuation that restores frame 12's barrier stiffness repeats the
// single run bit for bit.
TEST(LevelTask, HorizontalContinuationWithContactRepeatsTheSingleRunBitForBit) {
  const Scene scene = sheet_on_sphere(24);
  const SceneHierarchy h = build_scene_hierarchy(scene);
  Frames preview, whole, tail;
  run(scene, h, {0, 0, 24}, nullptr, preview);
  double kappa12 = 0.0;
  LevelTaskInputs in;
  in.below = [&](int t) { return preview.at(t); };
  solve_level_task(scene, h, {1, 0, 24}, in, [&](const FrameRecord& f) {
    whole[f.frame] = f.x;
    if (f.frame == 12)
      for (const auto& [name, value] : f.contact)
        if (name == "barrier_stiffness") kappa12 = value;
  });
  ASSERT_GT(kappa12, 0.0);
  LevelTaskInputs own;
  own.own_before = whole.at(11);
  own.own_start = whole.at(12);
  own.own_kappa = kappa12;
  run(scene, h, {1, 12, 24}, &preview, tail, own);
  EXPECT_EQ(max_difference(tail, whole, 13), 0.0);
  // The preview level continues the same way.
  Frames preview_tail;
  LevelTaskInputs own0;
  own0.own_before = preview.at(11);
  own0.own_start = preview.at(12);
  double kappa0 = 0.0;
  solve_level_task(scene, h, {0, 0, 12}, {}, [&](const FrameRecord& f) {
    if (f.frame == 12)
      for (const auto& [name, value] : f.contact)
        if (name == "barrier_stiffness") kappa0 = value;
  });
  own0.own_kappa = kappa0;
  run(scene, h, {0, 12, 24}, nullptr, preview_tail, own0);
  EXPECT_EQ(max_difference(preview_tail, preview, 13), 0.0);
}

TEST(LevelTask, BadTasksAreRefusedWithTheTaskInTheMessage) {
  const Scene scene = sheet_on_sphere(10);
  const SceneHierarchy h = build_scene_hierarchy(scene);
  Frames out, preview;
  EXPECT_THROW(run(scene, h, {2, 0, 5}, nullptr, out), std::invalid_argument);   // no such level
  EXPECT_THROW(run(scene, h, {0, 5, 5}, nullptr, out), std::invalid_argument);   // empty
  EXPECT_THROW(run(scene, h, {0, 0, 11}, nullptr, out), std::invalid_argument);  // past the scene
  EXPECT_THROW(run(scene, h, {0, 3, 6}, nullptr, out), std::invalid_argument);   // preview without own frames
  EXPECT_THROW(run(scene, h, {1, 0, 5}, nullptr, out), std::invalid_argument);   // no level below
  run(scene, h, {0, 0, 10}, nullptr, preview);
  Frames wrong = preview;
  wrong[3] = Eigen::VectorXd::Zero(6);
  try {
    run(scene, h, {1, 0, 5}, &wrong, out);
    ADD_FAILURE() << "a mis-sized frame below was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("frame 3 of level 0"), std::string::npos) << e.what();
  }
}

// The flag (scenes/flag.json: 5 % strain limit, pins, wind): the prolongation of level 0's frame 10
// has faces at 1.06 > 1.05, where the strain-limit energy is infinite. That vertical start was
// refused until safe upsampling learnt to project stretches (hierarchy/strain_projection.h) and
// to keep relaxing past a round without progress; now it starts, every face below the limit, and
// the subset solves its frames.
TEST(LevelTask, AVerticalStartWhoseProlongationIsBeyondTheStrainLimitStartsBelowIt) {
  Scene scene = load_scene(test::source_dir() + "/scenes/flag.json");
  scene.frames = 12;
  const SceneHierarchy h = build_scene_hierarchy(scene);
  Frames preview, subset;
  run(scene, h, {0, 0, 12}, nullptr, preview);
  const UpsamplingLevel up = upsampling_level(scene, h, 0);
  UpsamplingReport report;
  const Positions coarse = as_rows(preview.at(10));
  const Positions start = safe_upsample(up, coarse, h.levels[0].to_next->apply(coarse), {}, &report);
  EXPECT_GT(report.max_stretch_before, 1.05);
  EXPECT_LT(report.max_stretch_after, 1.05);
  EXPECT_GT(report.strain_projection_iterations, 0);
  run(scene, h, {1, 10, 12}, &preview, subset);
  ASSERT_EQ(subset.size(), 2u);  // frames 11 and 12
  EXPECT_TRUE(subset.count(11) && subset.count(12));
}

// A stitch (LevelTaskInputs::stitch_target): the flag's level 1, 40 frames, a later subset (20, 40]
// started vertically at 20. The stitch continues the single run from its frames 19 and 20 over
// (20, 28], guided toward the later subset's frames: it starts on the single run's branch (its frame
// 21 nearer the single run's than the later subset's is), ends on the later subset's (frame 28
// within 0.1 mm of it), and every stitched frame is intersection-free. A stitch without the own
// frames to continue from is refused.
TEST(LevelTask, AStitchCarriesTheSingleRunIntoTheLaterSubsetThroughTheLevelsOwnSteps) {
  Scene scene = load_scene(test::source_dir() + "/scenes/flag.json");
  scene.frames = 40;
  const SceneHierarchy h = build_scene_hierarchy(scene);
  Frames preview, single, later, stitch;
  run(scene, h, {0, 0, 40}, nullptr, preview);
  run(scene, h, {1, 0, 40}, &preview, single);
  run(scene, h, {1, 20, 40}, &preview, later);
  LevelTaskInputs in;
  in.own_before = single.at(19);
  in.own_start = single.at(20);
  in.stitch_target = [&later](int f) { return later.at(f); };
  in.stitch_frames = 8;
  run(scene, h, {1, 20, 28}, &preview, stitch, in);
  ASSERT_EQ(stitch.size(), 8u);
  const double apart = (later.at(21) - single.at(21)).cwiseAbs().maxCoeff();
  ASSERT_GT(apart, 1e-4) << "the later subset's frames must differ from the single run's for the test to mean anything";
  EXPECT_LT((stitch.at(21) - single.at(21)).cwiseAbs().maxCoeff(), 0.5 * apart);
  EXPECT_LT((stitch.at(28) - later.at(28)).cwiseAbs().maxCoeff(), 1e-4);
  for (const auto& [t, x] : stitch) EXPECT_TRUE(test::intersection_free(as_rows(x), h.levels[1].rest.F)) << t;
  // Resumed from its frames 23 and 24 (a farm stitch task whose worker was lost), the stitch keeps its
  // seam's ramp (stitch_seam) and repeats the uninterrupted frames bit for bit.
  LevelTaskInputs resumed = in;
  resumed.own_before = stitch.at(23);
  resumed.own_start = stitch.at(24);
  resumed.stitch_seam = 20;
  Frames rest;
  run(scene, h, {1, 24, 28}, &preview, rest, resumed);
  ASSERT_EQ(rest.size(), 4u);
  for (const auto& [t, x] : rest) EXPECT_EQ(x, stitch.at(t)) << t;
  resumed.stitch_seam = 25;  // a seam after the start
  Frames after;
  EXPECT_THROW(run(scene, h, {1, 24, 28}, &preview, after, resumed), std::invalid_argument);
  LevelTaskInputs bad;
  bad.stitch_target = in.stitch_target;
  bad.stitch_frames = 8;
  Frames none;
  EXPECT_THROW(run(scene, h, {1, 20, 28}, &preview, none, bad), std::invalid_argument);
}

// A 0.4 m cotton sheet (12 x 12 cells) released from a 90-degree twist about its x axis, no gravity,
// three levels: the coarse levels cannot represent the twist, so the prolongation of the level below's
// frame 0 is not the level's own frame 0 (its centre of mass is millimetres off).
Scene twisted_sheet(int frames) {
  Scene s = test::make_scene(0.01, frames, Vec3::Zero());
  const TriMesh sheet = make_rectangle(0.4, 0.4, 12, 12);
  SceneObject cloth = test::make_object("cloth", sheet, test::cotton());
  for (int v = 0; v < sheet.num_vertices(); ++v) {
    const double px = sheet.V(v, 0), py = sheet.V(v, 1), angle = 0.5 * M_PI * (px / 0.4);
    cloth.initial.row(v) << px, py * std::cos(angle), py * std::sin(angle);
  }
  s.objects.push_back(cloth);
  s.hierarchy.levels = 3;
  return s;
}

Vec3 centre_of_mass(const Eigen::VectorXd& x) { return as_rows(x).colwise().mean().transpose(); }

// kLevelStartFrames: a refinement level's first steps carry its start offset from the prolonged
// level below, so its first frame moves by its own momentum (here none: no force moves the centre of
// mass, as in a direct run) instead of jumping onto the prolonged trajectory; and a task resumed
// within those frames (a farm attempt continued from its stored frames) repeats them bit for bit.
TEST(LevelTask, ARefinementLevelStartsFromItsOwnStateAndFadesIntoTheLevelBelow) {
  const Scene scene = twisted_sheet(16);
  const SceneHierarchy h = build_scene_hierarchy(scene);
  Frames preview, middle, finest;
  run(scene, h, {0, 0, 16}, nullptr, preview);
  run(scene, h, {1, 0, 16}, &preview, middle);
  run(scene, h, {2, 0, 16}, &middle, finest);
  const Eigen::VectorXd offset =
      finest.at(0) - stacked(h.levels[1].to_next->apply(as_rows(middle.at(0))));
  const double offset_com = centre_of_mass(offset).norm(), offset_max = as_rows(offset).rowwise().norm().maxCoeff();
  const auto moved = [&](const Frames& f, int t) { return (centre_of_mass(f.at(t)) - centre_of_mass(f.at(0))).norm(); };
  // The finest level's centre of mass against the prolonged middle level's, frame t.
  const auto apart = [&](int t) {
    return (centre_of_mass(finest.at(t)) - centre_of_mass(stacked(h.levels[1].to_next->apply(as_rows(middle.at(t))))))
        .norm();
  };
  std::printf("[level start] finest start offset: centre of mass %.3g m, largest %.3g m; finest centre of mass "
              "moved %.3g / %.3g m at frames 1 / 15 (middle level %.3g at frame 1), off the prolonged middle level "
              "by %.3g / %.3g / %.3g m at frames 0 / 5 / 15\n",
              offset_com, offset_max, moved(finest, 1), moved(finest, 15), moved(middle, 1), apart(0), apart(5),
              apart(15));
  ASSERT_GT(offset_com, 1e-3);  // the case is not trivial
  EXPECT_LT(moved(finest, 1), 0.05 * offset_com);
  EXPECT_LT(moved(middle, 1), 1e-3);
  // After the start frames the level follows the level below: its offset is gone.
  EXPECT_LT(apart(15), 0.1 * offset_com);

  LevelTaskInputs resumed;
  resumed.own_before = finest.at(3);
  resumed.own_start = finest.at(4);
  Frames rest;
  run(scene, h, {2, 4, 16}, &middle, rest, resumed);
  for (const auto& [t, x] : rest) EXPECT_EQ(x, finest.at(t)) << t;
}

// cube-impact-sheet (scenes/stress) through its impact, level 0 -> 1 at frames 26-32: safe
// upsampling refused frames 26-29 (no valid perturbation) and at frame 30 reached a state with a
// touching pair, which relax_gaps refused with std::invalid_argument; as an invalid_argument that
// failed the job on every worker. Since the gap relaxation keeps the start shape of the faces it does
// not reshape (GapRelaxationSettings::keep_start_shape_within) only frame 28 is refused. Every vertical
// start here must either give intersection-free frames or fail as UpsamplingFailed (the farm's
// refusal: it then continues the subset horizontally) with no frame given; any other exception
// fails the test.
TEST(LevelTask, VerticalStartsThroughAnImpactStartOrAreRefusedNeverFailTheTask) {
  Scene scene = load_scene(test::source_dir() + "/scenes/stress/cube-impact-sheet.json");
  scene.frames = 34;
  const SceneHierarchy h = build_scene_hierarchy(scene);
  Frames preview;
  run(scene, h, {0, 0, 34}, nullptr, preview);
  int started = 0, refused = 0;
  for (int a = 26; a <= 32; ++a) {
    Frames subset;
    try {
      run(scene, h, {1, a, a + 1}, &preview, subset);
      ++started;
      ASSERT_EQ(subset.size(), 1u) << a;  // the frame a vertical start makes: a + 1
      for (const auto& [t, x] : subset) EXPECT_TRUE(test::intersection_free(as_rows(x), h.levels[1].rest.F)) << a;
    } catch (const UpsamplingFailed& e) {
      ++refused;
      EXPECT_EQ(std::string(e.what()).rfind("safe upsampling: ", 0), 0u) << e.what();
      EXPECT_TRUE(subset.empty()) << a;
    }
  }
  std::printf("[impact] vertical starts at frames 26-32: %d started, %d refused\n", started, refused);
  EXPECT_EQ(started + refused, 7);
}

}  // namespace
}  // namespace pd
