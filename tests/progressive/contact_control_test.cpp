// The contact part of a scene's system: which terms a scene pays for, the start-state check, the
// adaptive barrier stiffness and statistics, and obstacles that move without passing through cloth.
#include "progressive/contact_control.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "physics/contact/barrier_potential.h"
#include "physics/strain_limit.h"
#include "progressive/test_scenes.h"
#include "support/intersection_checker.h"
#include "util/input_error.h"

namespace pd {
namespace {

using test::cotton;
using test::make_object;
using test::make_scene;

std::vector<std::string> term_names(const SceneSystem& sys) {
  std::vector<std::string> names;
  for (const auto& t : sys.ip.terms()) names.push_back(t->name());
  return names;
}

bool has_term(const SceneSystem& sys, const std::string& name) {
  const auto names = term_names(sys);
  return std::find(names.begin(), names.end(), name) != names.end();
}

// A horizontal cotton square (normal +y) of side `size` at height y.
SceneObject flat_sheet(const std::string& name, double size, int cells, double y) {
  TriMesh m = make_rectangle(size, size, cells, cells);
  for (int i = 0; i < m.num_vertices(); ++i) m.V.row(i) = Vec3(m.V(i, 0), y, -m.V(i, 1)).transpose();
  return make_object(name, m, cotton());
}

SceneObject obstacle(const std::string& name, TriMesh mesh, const Vec3& at) {
  for (int i = 0; i < mesh.num_vertices(); ++i) mesh.V.row(i) += at.transpose();
  SceneObject o = make_object(name, mesh, Material{});
  o.obstacle = true;
  o.ground_contact = false;
  return o;
}

Scene contact_scene(double h, int frames) {
  Scene s = make_scene(h, frames, Vec3(0, -9.81, 0));
  s.source_path = "shots/contact.json";
  s.contact = ContactConfig{};
  s.contact->dhat = 1e-3;
  return s;
}

// Number of the (column) entry of `name` in a frame's contact statistics; fails if absent.
double stat(const FrameRecord& r, const std::string& name) {
  for (const auto& [k, v] : r.contact)
    if (k == name) return v;
  ADD_FAILURE() << "no statistic " << name;
  return 0;
}

TEST(ContactControl, ASceneWithoutContactHasNoContactTermsOrStatistics) {
  Scene s = make_scene(0.01, 1, Vec3(0, -9.81, 0));
  s.objects.push_back(flat_sheet("sheet", 0.2, 2, 0.1));
  SceneSystem sys = build_scene_system(s);
  for (const char* name : {"contact", "ground", "friction", "strain_limit"}) EXPECT_FALSE(has_term(sys, name)) << name;
  EXPECT_FALSE(sys.contact.has_barrier());
  EXPECT_TRUE(sys.contact.stats(sys.x0).empty());
}

TEST(ContactControl, TermsAreBuiltOnlyAsTheSceneDeclares) {
  Scene s = contact_scene(0.01, 1);
  s.objects.push_back(flat_sheet("sheet", 0.2, 2, 0.1));
  {
    SceneSystem sys = build_scene_system(s);
    EXPECT_TRUE(has_term(sys, "contact"));
    for (const char* name : {"ground", "friction", "strain_limit"}) EXPECT_FALSE(has_term(sys, name)) << name;
  }
  s.ground = Ground{};
  s.ground->friction = 0.4;
  s.objects[0].strain_limit = StrainLimit{1.1, {}, {}};
  SceneSystem sys = build_scene_system(s);
  for (const char* name : {"contact", "ground", "friction", "strain_limit"}) EXPECT_TRUE(has_term(sys, name)) << name;
  // The ground only for objects that collide with it: none here, so no ground term.
  s.objects[0].ground_contact = false;
  EXPECT_FALSE(has_term(build_scene_system(s), "ground"));
}

TEST(ContactControl, TheStrainLimitTermTakesTheScenesBandAndStiffnessOrTheDefaults) {
  Scene s = contact_scene(0.01, 1);
  s.objects.push_back(flat_sheet("sheet", 0.2, 2, 0.1));
  s.objects[0].strain_limit = StrainLimit{1.1, {}, {}};
  const SceneObject& obj = s.objects[0];
  {
    SceneSystem sys = build_scene_system(s);
    ASSERT_EQ(sys.contact.strain_limits.size(), 1u);
    const StrainLimitSettings& got = sys.contact.strain_limits[0]->settings();
    EXPECT_EQ(got.limit, 1.1);
    EXPECT_EQ(got.activation, default_strain_limit_activation(1.1));
    EXPECT_EQ(got.stiffness, obj.material.youngs_modulus * obj.material.thickness);
  }
  s.objects[0].strain_limit->barrier_start = 1.0;
  s.objects[0].strain_limit->stiffness = 0.25;
  SceneSystem sys = build_scene_system(s);
  const StrainLimitSettings& got = sys.contact.strain_limits[0]->settings();
  EXPECT_EQ(got.limit - got.activation, 1.0);  // the band starts at rest
  EXPECT_EQ(got.stiffness, 0.25);
}

TEST(ContactControl, ObstaclesArePinnedMasslessAndHaveNoElasticTerms) {
  Scene s = contact_scene(0.01, 1);
  s.objects.push_back(obstacle("ball", make_icosphere(0.1, 1), Vec3(0, 0, 0)));
  SceneSystem sys = build_scene_system(s);
  EXPECT_EQ(sys.pins.size(), static_cast<size_t>(sys.rest.num_vertices()));
  EXPECT_EQ(sys.masses.maxCoeff(), 0.0);
  for (const char* name : {"membrane", "bending"}) EXPECT_FALSE(has_term(sys, name)) << name;
  // The centre of a massless object is its vertex average.
  EXPECT_LT(centers_of_mass(sys, sys.x0).row(0).norm(), 1e-12);
}

TEST(ContactControl, ObjectsThatStartIntersectingAreRejectedNamingBothObjects) {
  Scene s = contact_scene(0.01, 1);
  s.objects.push_back(flat_sheet("cloth", 0.5, 4, 0.0));
  s.objects.push_back(obstacle("ball", make_icosphere(0.1, 2), Vec3(0.01, 0.0, 0.02)));
  const SceneSystem sys = build_scene_system(s);
  try {
    check_start_state(s, sys);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind("shots/contact.json: contact:", 0), 0u) << m;
    EXPECT_NE(m.find("'cloth'"), std::string::npos) << m;
    EXPECT_NE(m.find("'ball'"), std::string::npos) << m;
  }
}

TEST(ContactControl, VerticesStartingBelowTheGroundAreRejected) {
  Scene s = contact_scene(0.01, 1);
  s.objects.push_back(flat_sheet("cloth", 0.5, 4, 0.0));
  s.ground = Ground{};
  s.ground->height = 0.0;  // the sheet lies exactly on it: a zero gap
  const SceneSystem sys = build_scene_system(s);
  try {
    check_start_state(s, sys);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("shots/contact.json: ground: 25 vertices start at or below"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("object 'cloth'"), std::string::npos) << e.what();
  }
  s.ground->height = -0.01;
  EXPECT_NO_THROW(check_start_state(s, build_scene_system(s)));
}

TEST(ContactControl, AStartBeyondTheStrainLimitIsRejectedNamingTheObject) {
  Scene s = make_scene(0.01, 1, Vec3(0, -9.81, 0));
  s.source_path = "shots/flag.json";
  s.objects.push_back(flat_sheet("flag", 0.5, 4, 0.0));
  s.objects[0].initial.col(0) *= 1.2;  // stretched 20% along x
  s.objects[0].strain_limit = StrainLimit{1.1, {}, {}};
  try {
    check_start_state(s, build_scene_system(s));
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("objects[0].strain_limit.limit: object 'flag' starts stretched to 1.2"),
              std::string::npos)
        << e.what();
  }
}

// A sheet dropped 5 mm onto the ground: contact becomes active, the statistics report it, kappa
// stays within IPC's bounds, and the sheet comes to rest above the ground.
TEST(ContactControl, ASheetRestingOnTheGroundReportsActiveContactAndAGapBelowDhat) {
  Scene s = contact_scene(0.01, 30);
  s.objects.push_back(flat_sheet("cloth", 0.3, 6, 0.005));
  s.ground = Ground{};
  SceneSystem sys = build_scene_system(s);
  check_start_state(s, sys);
  const FrameRecord first = LevelStepper(sys, s.solver, s.time_step).initial_frame();
  EXPECT_EQ(stat(first, "contact_active_pairs"), 0);
  const double kappa0 = stat(first, "barrier_stiffness");
  FrameRecord last;
  test::run_scene(s, sys, nullptr, [&](const FrameRecord& r) { last = r; });
  EXPECT_EQ(stat(last, "contact_active_pairs"), 49);  // every vertex on the ground
  const double gap = stat(last, "contact_min_gap");
  EXPECT_GT(gap, 0.0);
  EXPECT_LT(gap, 1e-3);
  EXPECT_GE(stat(last, "barrier_stiffness"), kappa0);
  EXPECT_LT(last.kinetic_energy, 1e-8);
}

// A box obstacle rising at 1 m/s (1 cm per step, ten times dhat) into a sheet lying on it: the
// obstacle's steps are capped by CCD and the sheet is solved out of the way, so the box lifts the
// sheet instead of passing through it.
TEST(ContactControl, ARisingObstacleLiftsTheSheetWithoutPassingThroughIt) {
  Scene s = contact_scene(0.01, 20);
  s.objects.push_back(flat_sheet("cloth", 0.3, 8, 0.0525));
  s.objects[0].self_contact = true;  // its flaps fold under the box's edges
  s.objects.push_back(obstacle("box", make_box(Vec3(0.2, 0.1, 0.2), 2), Vec3(0, 0, 0)));
  PinScript up;
  up.velocity = Vec3(0, 1.0, 0);
  s.objects[1].motion = up;
  SceneSystem sys = build_scene_system(s);
  check_start_state(s, sys);
  int rounds = 0, frames = 0;
  const Eigen::VectorXd x = test::run_scene(s, sys, nullptr, [&](const FrameRecord& r) {
    rounds += r.pin_rounds;
    ++frames;
    EXPECT_TRUE(test::intersection_free(as_rows(r.x), sys.rest.F)) << "frame " << r.frame;
    EXPECT_GE(r.pin_rounds, 0) << "frame " << r.frame;
  });
  EXPECT_EQ(frames, 20);
  EXPECT_GT(rounds, 0);  // the obstacle had to make room at least once
  // The box's top rose from 0.05 m to 0.25 m; the sheet's centre vertex (40 of 9 x 9) rides on it
  // and its flaps hang down the sides.
  EXPECT_NEAR(centers_of_mass(sys, x)(1, 1), 0.2, 1e-12);
  EXPECT_GT(x[3 * 40 + 1], 0.25);
  EXPECT_LT(x[3 * 40 + 1], 0.25 + 2e-3);
}

}  // namespace
}  // namespace pd
