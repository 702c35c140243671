// Safe upsampling (hierarchy/safe_upsampling.h) on contact-rich states that a coarse level really
// produces: the coarse level of a scene is simulated with the ordinary stepper, its solution is
// upsampled to the next level, and the result is checked by the independent CGAL checker, against
// the contact offset and against the strain limit; the distance to the prolongation is reported.
// Not here yet (issue 4 stays open for them): a cloth draped over a sharp box and two sheets
// stacked 1.5 mm apart on a sphere still fail (splits that never open leave pairs inside the
// contact offset, and a later split next to them finds no valid perturbation).
#include "hierarchy/safe_upsampling.h"

#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "geometry/topology.h"
#include "physics/contact/start_check.h"
#include "physics/strain_limit.h"
#include "progressive/level_stepper.h"
#include "scene/scene_file.h"
#include "support/intersection_checker.h"
#include "support/test_paths.h"

namespace pd {
namespace {

using nlohmann::json;

json scene_json(const std::string& name) {
  std::ifstream in(test::source_dir() + "/scenes/" + name + ".json");
  std::stringstream text;
  text << in.rdbuf();
  return json::parse(text.str());
}

Scene parse(const json& j, const std::string& name) {
  return parse_scene(j.dump(), name + ".json", test::source_dir() + "/scenes");
}

// The scene with every object replaced by its level-l mesh (pins mapped to the level's ids; the
// scenes used here start at rest, so the initial positions are the level's rest positions).
Scene level_scene(const Scene& scene, const SceneHierarchy& h, int l) {
  Scene out = scene;
  for (std::size_t o = 0; o < scene.objects.size(); ++o) {
    const Level& level = h.objects[o].levels[static_cast<std::size_t>(l)];
    SceneObject& obj = out.objects[o];
    std::vector<int> level_of(static_cast<std::size_t>(scene.objects[o].rest.num_vertices()), -1);
    for (std::size_t i = 0; i < level.to_finest.size(); ++i) level_of[static_cast<std::size_t>(level.to_finest[i])] = static_cast<int>(i);
    obj.rest = level.mesh;
    obj.initial = level.mesh.V;
    for (PinGroup& g : obj.pins) {
      for (int& v : g.vertices) {
        v = level_of[static_cast<std::size_t>(v)];
        EXPECT_GE(v, 0) << "pinned vertex missing on level " << l;
      }
      std::sort(g.vertices.begin(), g.vertices.end());
    }
  }
  return out;
}

// Level l of the scene stepped for `frames` frames from rest; the final positions (n_l, 3).
Positions simulate_level(const Scene& scene, const SceneHierarchy& h, int l, int frames) {
  const Scene s = level_scene(scene, h, l);
  SceneSystem sys = build_scene_system(s);
  LevelStepper stepper(sys, s.solver, s.time_step);
  Eigen::VectorXd x = sys.x0, v = sys.v0;
  for (int t = 0; t < frames; ++t) stepper.step(t, x, v);
  return as_rows(x);
}

struct Outcome {
  Positions x;
  UpsamplingReport report;
  bool intersection_free = false;
  int within_offset = 0;     // contact pairs of the result at or below the offset
  double max_stretch = 0.0;  // over strain-limited faces
};

Outcome upsample_and_check(const Scene& scene, const SceneHierarchy& h, int l, const Positions& x_coarse,
                           const char* label) {
  const SceneLevel& fine = h.levels[static_cast<std::size_t>(l + 1)];
  const UpsamplingLevel level = upsampling_level(scene, h, l);
  const Positions target = h.levels[static_cast<std::size_t>(l)].to_next->apply(x_coarse);
  Outcome out;
  out.x = safe_upsample(level, x_coarse, target, {}, &out.report);
  out.intersection_free = test::intersection_free(out.x, fine.rest.F);

  ContactPrimitives prims;
  prims.faces = fine.rest.F;
  prims.edges = build_topology(fine.rest).edges;
  prims.vertex_object = level.vertex_object;
  prims.object_self_contact = level.object_self_contact;
  int found = 0;
  find_start_violations(prims, out.x, level.offset, 0, &found);
  out.within_offset = found;
  for (int f = 0; f < fine.rest.F.rows(); ++f) {
    if (!(level.face_strain_limit[static_cast<std::size_t>(f)] > 0)) continue;
    Faces one(1, 3);
    one.row(0) = fine.rest.F.row(f);
    StrainLimitTerm term(one, fine.rest.V, StrainLimitSettings::from(level.face_strain_limit[static_cast<std::size_t>(f)], 1e6, 1e-3));
    out.max_stretch = std::max(out.max_stretch, term.max_stretch(stacked(out.x)));
  }
  const UpsamplingReport& r = out.report;
  std::printf("[%s] level %d -> %d: %d vertices, %d batches, %d splits (%d random perturbations, %d samples), "
              "%d advance events (%d close), %d redirected, %d stopped, %d relaxed patches, %d unresolved; gap %.3g -> %.3g m; "
              "target distance max %.3g m rms %.3g m; stretch %.4f -> %.4f; %.3f s (perturb %.3f, advance %.3f, "
              "relax %.3f, strain %.3f)\n",
              label, l, l + 1, static_cast<int>(out.x.rows()), r.batches, r.splits, r.random_perturbations,
              r.perturbation_samples, r.advance_events, r.close_events, r.redirections, r.stopped_vertices, r.relaxed_patches, r.unresolved_gaps,
              r.coarse_gap, r.final_gap, r.max_target_distance, r.rms_target_distance, r.max_stretch_before,
              r.max_stretch_after, r.seconds, r.perturb_seconds, r.advance_seconds, r.relax_seconds, r.strain_seconds);
  return out;
}

double mean_edge(const TriMesh& m) {
  double sum = 0;
  for (int f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) sum += (m.V.row(m.F(f, k)) - m.V.row(m.F(f, (k + 1) % 3))).norm();
  return sum / (3.0 * static_cast<double>(m.F.rows()));
}

void expect_safe(const Outcome& o, const SceneLevel& fine, double rms_fraction_of_edge) {
  EXPECT_TRUE(o.intersection_free);
  EXPECT_EQ(o.within_offset, 0);
  EXPECT_EQ(o.report.unresolved_gaps, 0);
  EXPECT_GT(o.report.final_gap, 0.0);
  EXPECT_LT(o.report.rms_target_distance, rms_fraction_of_edge * mean_edge(fine.rest));
}

// The strain limit is NOT reached yet (1.18 for a 1.05 limit, measured): the relaxation with the
// coarse vertices fixed only lowers the stretch the upsampling created (1.24); see issue 4's notes.
TEST(SafeUpsampling, SheetFoldedOntoItselfUpsamplesIntersectionFreeAndStrainRelaxationLowersTheStretch) {
  json j = scene_json("self-fold");
  j["hierarchy"] = {{"levels", 2}};
  j["objects"][0]["strain_limit"] = {{"limit", 1.05}};
  const Scene scene = parse(j, "self-fold");
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const Positions x0 = simulate_level(scene, h, 0, 110);  // the fold is laid down by t = 1 s
  ASSERT_TRUE(test::intersection_free(x0, h.levels[0].rest.F));
  const Outcome up = upsample_and_check(scene, h, 0, x0, "self-fold");
  expect_safe(up, h.levels[1], 0.1);
  EXPECT_GT(up.report.max_stretch_before, 1.05);  // the relaxation had something to do
  EXPECT_LT(up.report.max_stretch_after, up.report.max_stretch_before);
  EXPECT_NEAR(up.max_stretch, up.report.max_stretch_after, 1e-12);

  // Bit-identical on a second run.
  const Outcome again = upsample_and_check(scene, h, 0, x0, "self-fold again");
  EXPECT_TRUE((again.x.array() == up.x.array()).all());
}

TEST(SafeUpsampling, RestShapeUpsamplesToTheFineRestShape) {
  json j = scene_json("drape-sphere");
  j["hierarchy"] = {{"levels", 2}};
  const Scene scene = parse(j, "drape-sphere");
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const Outcome up = upsample_and_check(scene, h, 0, h.levels[0].rest.V, "rest");
  EXPECT_TRUE(up.intersection_free);
  // The prolonged rest is the fine rest; nothing is in contact, so every vertex gets there.
  EXPECT_LT(up.report.max_target_distance, 1e-9);
  EXPECT_LT((up.x - h.levels[1].rest.V).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(SafeUpsampling, WithoutContactTheResultIsTheProlongation) {
  json j = scene_json("drape-sphere");
  j["hierarchy"] = {{"levels", 2}};
  j.erase("contact");
  j.erase("ground");
  j["objects"].erase(1);  // the sphere obstacle (obstacles need contact)
  j["objects"][0].erase("self_contact");
  const Scene scene = parse(j, "no-contact");
  const SceneHierarchy h = build_scene_hierarchy(scene);
  Positions xc = h.levels[0].rest.V;
  xc.col(1).array() += 0.1 * xc.col(0).array().square();  // bend it
  const UpsamplingLevel level = upsampling_level(scene, h, 0);
  EXPECT_FALSE(level.contact);
  const Positions target = h.levels[0].to_next->apply(xc);
  const Positions x = safe_upsample(level, xc, target);
  EXPECT_TRUE((x.array() == target.array()).all());
}

TEST(SafeUpsampling, InconsistentSizesAreRejected) {
  json j = scene_json("drape-sphere");
  j["hierarchy"] = {{"levels", 2}};
  const Scene scene = parse(j, "drape-sphere");
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const UpsamplingLevel level = upsampling_level(scene, h, 0);
  const Positions xc = h.levels[0].rest.V;
  const Positions target = h.levels[1].rest.V;
  EXPECT_THROW(safe_upsample(level, xc.topRows(3), target), std::invalid_argument);
  EXPECT_THROW(safe_upsample(level, xc, target.topRows(3)), std::invalid_argument);
  EXPECT_THROW(upsampling_level(scene, h, 1), std::invalid_argument);
  EXPECT_THROW(upsampling_level(scene, h, -1), std::invalid_argument);
}

}  // namespace
}  // namespace pd
