// The contact scenes of scenes/, as users run them (some shortened or coarsened for CI, each change
// stated): every stored frame passes the independent CGAL intersection check, and each scene shows
// the behaviour it exists for.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "progressive/level_stepper.h"
#include "scene/scene_file.h"
#include "support/intersection_checker.h"
#include "support/test_paths.h"

namespace pd {
namespace {

using nlohmann::json;

json scene_json(const std::string& name) {
  const std::string path = test::source_dir() + "/scenes/" + name + ".json";
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return json::parse(text.str());
}

json& object_named(json& scene, const std::string& name) {
  for (json& o : scene["objects"])
    if (o["name"] == name) return o;
  throw std::runtime_error("no object " + name);
}

// Runs the scene (after `edit` changed its JSON), checks the start state and every frame for
// intersections, and returns all frames including frame 0.
struct SceneRun {
  Scene scene;
  SceneSystem sys;
  std::vector<FrameRecord> frames;
  int not_converged = 0;
};

SceneRun run(const std::string& name, const std::function<void(json&)>& edit = {}) {
  json j = scene_json(name);
  if (edit) edit(j);
  SceneRun r;
  r.scene = parse_scene(j.dump(), name + ".json", test::source_dir() + "/scenes");
  r.sys = build_scene_system(r.scene);
  check_start_state(r.scene, r.sys);
  LevelStepper stepper(r.sys, r.scene.solver, r.scene.time_step);
  r.frames.push_back(stepper.initial_frame());
  Eigen::VectorXd x = r.sys.x0, v = r.sys.v0;
  int intersecting = 0;
  for (int t = 0; t < r.scene.frames; ++t) {
    FrameRecord f = stepper.step(t, x, v);
    r.not_converged += !f.newton.converged;
    if (!test::intersection_free(as_rows(f.x), r.sys.rest.F)) {
      ++intersecting;
      ADD_FAILURE() << name << ": frame " << f.frame << " intersects";
    }
    r.frames.push_back(std::move(f));
  }
  EXPECT_EQ(intersecting, 0) << name;
  return r;
}

double stat(const FrameRecord& f, const std::string& key) {
  for (const auto& [k, v] : f.contact)
    if (k == key) return v;
  ADD_FAILURE() << "no statistic " << key;
  return NAN;
}

Vec3 com(const SceneRun& r, int frame, const std::string& object) {
  const auto& names = r.sys.object_names;
  const int o = static_cast<int>(std::find(names.begin(), names.end(), object) - names.begin());
  return r.frames[frame].center_of_mass.row(o).transpose();
}

int newton_iterations(const SceneRun& r) {
  int n = 0;
  for (const FrameRecord& f : r.frames) n += f.newton.iterations;
  return n;
}

// Slope angles below and above the friction angle atan(0.5) = 26.6 deg: the 20 deg square stays
// where it landed, the 35 deg square slides with a = g (sin 35 - 0.5 cos 35); with both of
// Newton's friction stopping rules (solver.friction_stopping).
TEST(ContactScenes, SlopeFrictionSticksBelowTheFrictionAngleAndSlidesAboveWithEitherStoppingRule) {
  for (const char* rule : {"contacts", "uniform"}) {
    SCOPED_TRACE(rule);
    const SceneRun r = run("slope-friction", [rule](json& j) { j["solver"]["friction_stopping"] = rule; });
    EXPECT_EQ(r.not_converged, 0);
    const double kPi = 3.14159265358979323846;
    auto along = [&](const char* sheet, double deg, int frame) {
      const double t = deg * kPi / 180;
      const Vec3 downhill(-std::cos(t), -std::sin(t), 0);
      return (com(r, frame, sheet) - com(r, 0, sheet)).dot(downhill);
    };
    const int last = r.scene.frames;
    const double duration = last * r.scene.time_step;
    // Both squares first fall 2 mm onto their slopes (about 0.02 s) and settle into the barrier's
    // gap; from frame 10 on, the gentle one must not creep (eps_v = 1 mm/s allows at most 0.5 mm).
    const double landing = along("sheet_gentle", 20, 10), gentle = along("sheet_gentle", 20, last) - landing;
    std::printf("%s: gentle slope: %.3g mm downhill while landing, then %.3g mm in %.2f s\n", rule, landing * 1e3,
                gentle * 1e3, duration - 0.1);
    EXPECT_LT(std::abs(gentle), 0.5e-3);
    const double a = 9.81 * (std::sin(35 * kPi / 180) - 0.5 * std::cos(35 * kPi / 180));
    const double steep = along("sheet_steep", 35, last), expected = 0.5 * a * duration * duration;
    std::printf("%s: steep slope: %.4f m downhill in %.2f s, Coulomb sliding from rest %.4f m (ratio %.3f); %d Newton "
                "iterations\n",
                rule, steep, duration, expected, steep / expected, newton_iterations(r));
    EXPECT_NEAR(steep / expected, 1.0, 0.15);
    // Both were in contact from the landing on, with friction acting.
    EXPECT_GT(stat(r.frames[last], "friction_contacts"), 0);
  }
}

// A heavy stiff box on a soft pinned sheet: it dents the sheet, is thrown back up (its centre's
// velocity turns upward after the impact), and never passes through.
TEST(ContactScenes, CubeOnTrampolineBouncesWithoutTunnelling) {
  const SceneRun r = run("cube-trampoline", [](json& j) { j["frames"] = 80; });  // 0.8 s: impact and rebound
  EXPECT_EQ(r.not_converged, 0);
  int lowest = 0;
  for (int t = 0; t <= r.scene.frames; ++t)
    if (com(r, t, "cube")[1] < com(r, lowest, "cube")[1]) lowest = t;
  const double dent = 0.3 + 0.1 - com(r, lowest, "cube")[1];  // below resting on the flat sheet
  std::printf("cube: lowest centre at frame %d, %.1f mm below touching the flat sheet; %.1f mm back up by frame %d\n",
              lowest, dent * 1e3, (com(r, r.scene.frames, "cube")[1] - com(r, lowest, "cube")[1]) * 1e3,
              r.scene.frames);
  EXPECT_GT(dent, 0.02);
  EXPECT_LT(lowest, r.scene.frames - 5);
  EXPECT_GT(com(r, lowest + 5, "cube")[1], com(r, lowest, "cube")[1] + 1e-3);
}

// A square dropped on a fixed sphere drapes over it (self-contact on): every frame clean, the
// middle rests on the sphere's top, the corners hang far below it. Coarsened to 16 x 16 cells and
// 1 s for CI (the scene file: 24 x 24, 1.5 s).
TEST(ContactScenes, DrapeOnASphereRestsOnTopWithoutIntersecting) {
  const SceneRun r = run("drape-sphere", [](json& j) {
    object_named(j, "cloth")["mesh"]["cells"] = {16, 16};
    j["frames"] = 100;
  });
  EXPECT_EQ(r.not_converged, 0);
  const Eigen::VectorXd& x = r.frames.back().x;
  const int centre = 8 * 17 + 8;
  // The sphere's top is at 0.41 m; the cloth's centre rests on it, a few millimetres up where its
  // stiffness spans the facets around the top (3.8 mm measured).
  EXPECT_GT(x[3 * centre + 1], 0.405);
  EXPECT_LT(x[3 * centre + 1], 0.416);
  double lowest = 1e9;
  for (int v = 0; v < 17 * 17; ++v) lowest = std::min(lowest, x[3 * v + 1]);
  EXPECT_LT(lowest, 0.25);
  // Coming to rest: the kinetic energy falls three orders of magnitude below its peak at impact.
  double peak = 0;
  for (const FrameRecord& f : r.frames) peak = std::max(peak, f.kinetic_energy);
  EXPECT_LT(r.frames.back().kinetic_energy, 2e-3 * peak);
  std::printf("drape: centre at %.4f m, lowest cloth vertex %.3f m, contact pairs %g, kinetic energy %.2e J "
              "(peak %.2e J)\n",
              x[3 * centre + 1], lowest, stat(r.frames.back(), "contact_active_pairs"), r.frames.back().kinetic_energy,
              peak);
}

// The cloth on a sphere spinning at 2 rev/s with friction 0.8 is dragged around the axis: its
// vertices' mean angle about the axis advances. 0.6 s, 12 x 12 cells for CI.
TEST(ContactScenes, ClothOnASpinningHighFrictionSphereWindsUp) {
  const SceneRun r = run("spin-sphere", [](json& j) {
    object_named(j, "cloth")["mesh"]["cells"] = {12, 12};
    j["frames"] = 60;
  });
  EXPECT_EQ(r.not_converged, 0);
  // Mean angle about y of the cloth's vertices relative to their start (unwrapped per vertex).
  const int n = 13 * 13;
  double turned = 0;
  for (int v = 0; v < n; ++v) {
    double total = 0;
    for (size_t t = 1; t < r.frames.size(); ++t) {
      const Eigen::VectorXd& p = r.frames[t - 1].x;
      const Eigen::VectorXd& q = r.frames[t].x;
      const double before = std::atan2(p[3 * v + 2], p[3 * v]), after = std::atan2(q[3 * v + 2], q[3 * v]);
      double d = after - before;
      d -= 2 * M_PI * std::round(d / (2 * M_PI));
      total += d;
    }
    turned += total / n;
  }
  std::printf("spin: the cloth turned %.2f rad about the axis in %.1f s (sphere: %.1f rad)\n", turned,
              r.scene.frames * r.scene.time_step, 4 * M_PI * r.scene.frames * r.scene.time_step);
  // The sphere turns about +y; a rotation by theta about +y lowers atan2(z, x) by theta, so the cloth
  // is dragged along when its mean angle falls (measured: -2.85 rad while the sphere turned 7.5).
  EXPECT_LT(turned, -0.5);
}

// The strain-limited flag never stretches past 5%; without the limit the same flag does within
// 0.2 s (so the limit is doing the work). 0.5 s for CI.
TEST(ContactScenes, StrainLimitedFlagNeverExceedsItsLimit) {
  const SceneRun r = run("flag", [](json& j) { j["frames"] = 50; });
  EXPECT_EQ(r.not_converged, 0);
  double worst = 0;
  for (const FrameRecord& f : r.frames) worst = std::max(worst, stat(f, "max_stretch"));
  EXPECT_LT(worst, 1.05);
  std::printf("flag: largest stretch %.5f with the 1.05 limit\n", worst);

  json free_flag = scene_json("flag");
  free_flag["frames"] = 20;
  free_flag["objects"][0].erase("strain_limit");
  free_flag["objects"][0]["self_contact"] = false;
  Scene s = parse_scene(free_flag.dump(), "flag.json", "");
  SceneSystem sys = build_scene_system(s);
  s.objects[0].strain_limit = StrainLimit{10.0, {}, {}};  // a limit that never binds, only to measure stretch
  SceneSystem measured = build_scene_system(s);
  LevelStepper stepper(sys, s.solver, s.time_step);
  Eigen::VectorXd x = sys.x0, v = sys.v0;
  double unlimited = 0;
  for (int t = 0; t < s.frames; ++t) {
    stepper.step(t, x, v);
    for (const auto& [k, value] : measured.contact.stats(x))
      if (k == "max_stretch") unlimited = std::max(unlimited, value);
  }
  std::printf("flag without the limit: largest stretch %.4f\n", unlimited);
  EXPECT_GT(unlimited, 1.05);
}

// A 0.07 mm sheet whose edge is carried over onto its other half folds onto itself without
// passing through: every frame clean, and the carried edge ends above the far half.
TEST(ContactScenes, ThinSheetFoldsOntoItselfWithoutPassingThrough) {
  const SceneRun r = run("self-fold", [](json& j) {
    object_named(j, "sheet")["mesh"]["cells"] = {24, 6};
    j["frames"] = 120;
  });
  EXPECT_EQ(r.not_converged, 0);
  const Eigen::VectorXd& x = r.frames.back().x;
  // Vertex 0 is the carried edge's corner (x = -0.2 at the start); it is now over the right half.
  EXPECT_GT(x[0], 0.15);
  double min_gap = 1e9;
  for (const FrameRecord& f : r.frames) min_gap = std::min(min_gap, stat(f, "contact_min_gap"));
  EXPECT_GT(min_gap, 0.0);
  std::printf("fold: carried corner at x = %.3f m, y = %.4f m; smallest gap over all frames %.2e m\n", x[0], x[1],
              min_gap);
}

// Contact, friction, a moving obstacle and adaptive kappa keep runs bit-for-bit reproducible.
TEST(ContactScenes, SameSceneGivesBitIdenticalFrames) {
  auto shortened = [](json& j) {
    object_named(j, "cloth")["mesh"]["cells"] = {8, 8};
    j["frames"] = 25;
  };
  const SceneRun a = run("spin-sphere", shortened), b = run("spin-sphere", shortened);
  ASSERT_EQ(a.frames.size(), b.frames.size());
  for (size_t t = 0; t < a.frames.size(); ++t)
    ASSERT_TRUE(a.frames[t].x == b.frames[t].x) << "frame " << t << " differs";
  EXPECT_GT(stat(a.frames.back(), "contact_active_pairs"), 0);
}

}  // namespace
}  // namespace pd
