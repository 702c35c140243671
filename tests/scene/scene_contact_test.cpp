// The contact keys of a scene file: values and defaults, and one clear error per bad input.
#include "scene/scene_contact.h"

#include <gtest/gtest.h>

#include <cmath>

#include "scene/scene_test_helpers.h"

namespace pd {
namespace {

using namespace pd::test;  // valid_scene, parse, expect_error (scene_test_helpers.h)

// valid_scene() with a contact section and a second object, a fixed sphere.
json contact_scene() {
  json s = valid_scene();
  s["contact"] = {{"dhat", 1e-3}};
  s["objects"].push_back(json::parse(R"({
    "name": "ball", "mesh": {"type": "icosphere", "radius": 0.2, "subdivisions": 1},
    "transform": {"translation": [0, -0.5, 0]}, "obstacle": true})"));
  return s;
}

TEST(SceneContact, OmittedContactKeysGetTheirDocumentedDefaults) {
  const Scene scene = parse(contact_scene());
  ASSERT_TRUE(scene.contact.has_value());
  EXPECT_EQ(scene.contact->dhat, 1e-3);
  EXPECT_EQ(scene.contact->offset, 0.0);
  EXPECT_EQ(scene.contact->ccd_ratio, 0.9);
  EXPECT_EQ(scene.contact->friction, 0.0);
  EXPECT_EQ(scene.contact->eps_v, 1e-3);
  EXPECT_FALSE(scene.contact->stiffness.has_value());
  EXPECT_TRUE(scene.contact->pair_friction.empty());
  EXPECT_FALSE(scene.ground.has_value());
  EXPECT_FALSE(scene.objects[0].self_contact);
  EXPECT_TRUE(scene.objects[0].ground_contact);
  EXPECT_FALSE(scene.objects[0].obstacle);
  EXPECT_TRUE(scene.objects[1].obstacle);
  EXPECT_FALSE(scene.objects[1].ground_contact);  // obstacles never collide with the ground
  EXPECT_FALSE(scene.objects[1].motion.has_value());
}

TEST(SceneContact, GivenContactGroundAndObjectKeysAreRead) {
  json s = contact_scene();
  s["contact"] = json::parse(R"({"dhat": 2e-3, "offset": 5e-4, "ccd_ratio": 0.8, "friction": 0.3,
    "eps_v": 1e-4, "stiffness": 1e6, "pair_friction": [{"objects": ["sheet", "ball"], "friction": 0.9}]})");
  s["ground"] = json::parse(R"({"height": -1.0, "normal": [0, 2, 0], "friction": 0.4})");
  s["objects"][0]["self_contact"] = true;
  s["objects"][0]["ground_contact"] = false;
  s["objects"][0]["strain_limit"] = {{"limit", 1.1}};
  s["objects"][1]["motion"] = json::parse(R"({"angular_velocity": [0, 6.28, 0], "center": [0, -0.5, 0]})");
  const Scene scene = parse(s);
  const ContactConfig& c = *scene.contact;
  EXPECT_EQ(c.dhat, 2e-3);
  EXPECT_EQ(c.offset, 5e-4);
  EXPECT_EQ(c.ccd_ratio, 0.8);
  EXPECT_EQ(c.friction, 0.3);
  EXPECT_EQ(c.eps_v, 1e-4);
  EXPECT_EQ(*c.stiffness, 1e6);
  ASSERT_EQ(c.pair_friction.size(), 1u);
  EXPECT_EQ(c.pair_friction[0].a, 0);  // stored with a <= b whatever the order in the file
  EXPECT_EQ(c.pair_friction[0].b, 1);
  EXPECT_EQ(c.pair_friction[0].mu, 0.9);
  ASSERT_TRUE(scene.ground.has_value());
  EXPECT_EQ(scene.ground->height, -1.0);
  EXPECT_EQ(scene.ground->normal, Vec3(0, 1, 0));  // normalised
  EXPECT_EQ(scene.ground->friction, 0.4);
  EXPECT_TRUE(scene.objects[0].self_contact);
  EXPECT_FALSE(scene.objects[0].ground_contact);
  EXPECT_EQ(scene.objects[0].strain_limit->limit, 1.1);
  EXPECT_FALSE(scene.objects[0].strain_limit->barrier_start.has_value());  // the term's default band
  EXPECT_FALSE(scene.objects[0].strain_limit->stiffness.has_value());      // E * thickness
  EXPECT_EQ(scene.objects[1].motion->angular_velocity, Vec3(0, 6.28, 0));
}

TEST(SceneContact, StrainLimitBandStartAndStiffnessAreRead) {
  json s = contact_scene();
  s["objects"][0]["strain_limit"] = json::parse(R"({"limit": 1.0608, "barrier_start": 1.0, "stiffness": 0.318})");
  const Scene scene = parse(s);
  EXPECT_EQ(scene.objects[0].strain_limit->limit, 1.0608);
  EXPECT_EQ(*scene.objects[0].strain_limit->barrier_start, 1.0);
  EXPECT_EQ(*scene.objects[0].strain_limit->stiffness, 0.318);
}

TEST(SceneContact, AnObstacleNeedsNoMaterial) {
  const Scene scene = parse(contact_scene());
  EXPECT_EQ(scene.objects[1].material.density, 0.0);
  EXPECT_FALSE(scene.objects[1].wind);
}

TEST(SceneContact, KeyframedObstacleMotionStartsFromTheInitialPose) {
  json s = contact_scene();
  s["objects"][1]["motion"] = json::parse(R"({"keyframes": [
    {"time": 0.5, "translation": [0, 0.1, 0]},
    {"time": 1.0, "translation": [0, 0.1, 0], "rotation": {"axis": [0, 1, 0], "angle_deg": 90}}]})");
  const Scene scene = parse(s);
  const auto& keys = scene.objects[1].motion->keyframes;
  ASSERT_EQ(keys.size(), 3u);  // the identity keyframe at t = 0 is added
  EXPECT_EQ(keys[0].time, 0.0);
  EXPECT_EQ(keys[0].translation, Vec3::Zero());
  EXPECT_EQ(keys[1].translation, Vec3(0, 0.1, 0));
  EXPECT_NEAR(keys[2].rotation.angularDistance(Eigen::Quaterniond::Identity()), M_PI / 2, 1e-15);
}

TEST(SceneContactErrors, BadKeyframesAreRejected) {
  const std::pair<const char*, const char*> cases[] = {
      {R"({"keyframes": []})", "objects[1].motion.keyframes: must list at least one keyframe"},
      {R"({"keyframes": [{"time": 1.0}, {"time": 0.5}]})",
       "objects[1].motion.keyframes[1].time: must be later than the previous keyframe's time (1)"},
      {R"({"keyframes": [{"time": 0, "translation": [1, 0, 0]}]})",
       "objects[1].motion.keyframes[0]: is at time 0 but not the initial pose"},
      {R"({"keyframes": [{"time": 1, "rotation": {"axis": [0, 0, 0], "angle_deg": 5}}]})",
       "objects[1].motion.keyframes[0].rotation.axis: must be a non-zero vector"},
      {R"({"velocity": [1, 0, 0], "keyframes": [{"time": 1}]})",
       "objects[1].motion.velocity: cannot be combined with \"keyframes\""},
  };
  for (const auto& [motion, expected] : cases) {
    json s = contact_scene();
    s["objects"][1]["motion"] = json::parse(motion);
    expect_error(s, {expected});
  }
}

TEST(SceneContactErrors, ContactParametersOutOfRangeAreRejected) {
  const std::pair<const char*, const char*> cases[] = {
      {R"({"dhat": -1e-3})", "contact.dhat"},
      {R"({"dhat": 0})", "contact.dhat"},
      {R"({})", "contact.dhat: required key is missing"},
      {R"({"dhat": 1e-3, "offset": -1e-4})", "contact.offset"},
      {R"({"dhat": 1e-3, "ccd_ratio": 1.0})", "contact.ccd_ratio: must be > 0 and < 1"},
      {R"({"dhat": 1e-3, "friction": -0.1})", "contact.friction: a friction coefficient must be from 0 to 10, got -0.1"},
      {R"({"dhat": 1e-3, "eps_v": 0})", "contact.eps_v"},
      {R"({"dhat": 1e-3, "stiffness": -5})", "contact.stiffness"},
      {R"({"dhat": 1e-3, "dhats": 1})", "contact.dhats: unknown key"},
  };
  for (const auto& [contact, expected] : cases) {
    json s = contact_scene();
    s["contact"] = json::parse(contact);
    expect_error(s, {expected});
  }
}

TEST(SceneContactErrors, BadPairFrictionNamesTheEntry) {
  const std::pair<const char*, const char*> cases[] = {
      {R"([{"objects": ["sheet", "cloth"], "friction": 0.5}])",
       "contact.pair_friction[0].objects[1]: names no object of the scene (objects: \"sheet\", \"ball\")"},
      {R"([{"objects": ["sheet"], "friction": 0.5}])", "contact.pair_friction[0].objects"},
      {R"([{"objects": ["sheet", "ball"], "friction": -1}])", "contact.pair_friction[0].friction"},
      {R"([{"objects": ["sheet", "ball"], "friction": 0.5}, {"objects": ["ball", "sheet"], "friction": 0.2}])",
       "contact.pair_friction[1]: gives the pair of objects a second friction coefficient"},
  };
  for (const auto& [pairs, expected] : cases) {
    json s = contact_scene();
    s["contact"]["pair_friction"] = json::parse(pairs);
    expect_error(s, {expected});
  }
}

TEST(SceneContactErrors, ContactKeysWithoutAContactSectionAreRejected) {
  json s = valid_scene();
  s["objects"][0]["self_contact"] = true;
  expect_error(s, {"objects[0].self_contact: is true but the scene has no top-level \"contact\" section"});
  s = contact_scene();
  s.erase("contact");
  expect_error(s, {"objects[1].obstacle: is true but the scene has no top-level \"contact\" section"});
  s = valid_scene();
  s["ground"] = json::object();
  expect_error(s, {"ground: needs a top-level \"contact\" section"});
}

TEST(SceneContactErrors, DynamicsKeysOnAnObstacleAreRejected) {
  for (const char* key : {"pins", "initial_velocity", "pressure", "wind", "self_contact", "ground_contact",
                          "strain_limit"}) {
    json s = contact_scene();
    s["objects"][1][key] = json::parse(std::string(key) == "pins" ? "[]" : std::string(key) == "initial_velocity"
                                                                              ? "[0, 0, 0]"
                                                                              : "true");
    expect_error(s, {"objects[1]." + std::string(key) + ": does not apply to an obstacle"});
  }
  json s = contact_scene();
  s["objects"][0]["motion"] = json::parse(R"({"velocity": [1, 0, 0]})");
  expect_error(s, {"objects[0].motion: applies to obstacles only"});
}

TEST(SceneContactErrors, BadGroundAndStrainLimitAreRejected) {
  json s = contact_scene();
  s["ground"] = json::parse(R"({"normal": [0, 0, 0]})");
  expect_error(s, {"ground.normal: must be a non-zero vector"});
  s["ground"] = json::parse(R"({"friction": -0.2})");
  expect_error(s, {"ground.friction"});
  for (const char* limit : {"1.0", "0.9", "11"}) {
    s = contact_scene();
    s["objects"][0]["strain_limit"] = json::parse(std::string(R"({"limit": )") + limit + "}");
    expect_error(s, {"objects[0].strain_limit.limit: must be > 1"});
  }
  // The band must start at or above rest and below the limit; the stiffness is a positive J/m^2.
  for (const char* start : {"0.99", "1.1", "1.2", "\"1\""}) {
    s = contact_scene();
    s["objects"][0]["strain_limit"] = json::parse(std::string(R"({"limit": 1.1, "barrier_start": )") + start + "}");
    expect_error(s, {"objects[0].strain_limit.barrier_start: must be"});
  }
  for (const char* stiffness : {"0", "-1", "1e20", "null"}) {
    s = contact_scene();
    s["objects"][0]["strain_limit"] = json::parse(std::string(R"({"limit": 1.1, "stiffness": )") + stiffness + "}");
    expect_error(s, {"objects[0].strain_limit.stiffness: must be"});
  }
  s = contact_scene();
  s["objects"][0]["strain_limit"] = json::parse(R"({"limit": 1.1, "barrier_stat": 1.0})");
  expect_error(s, {"objects[0].strain_limit.barrier_stat: unknown key, did you mean 'barrier_start'?"});
}

}  // namespace
}  // namespace pd
