#include "scene/scene_contact.h"

#include <set>
#include <string>
#include <utility>

#include "util/message_text.h"

namespace pd::scene_json {

namespace {

// Index of the object called `name`, or a failure at `node` listing the names there are.
int object_index(const JsonNode& node, const std::vector<SceneObject>& objects) {
  const std::string name = node.string();
  std::string known;
  for (std::size_t k = 0; k < objects.size(); ++k)
    if (objects[k].name == name) return static_cast<int>(k);
  for (std::size_t k = 0; k < objects.size(); ++k) {
    if (k == 8) {
      known += ", ... (" + std::to_string(objects.size()) + " objects)";
      break;
    }
    known += (k ? ", " : "") + quoted_for_message(objects[k].name, 40);
  }
  node.fail_got("names no object of the scene (objects: " + known + ")");
}

double friction_coefficient(const JsonNode& node) {
  const double mu = node.number();
  const Range& r = limits::kFriction;
  if (!(mu >= r.lower && mu <= r.upper)) node.fail_got("a friction coefficient must be from 0 to 10");
  return mu;
}

}  // namespace

ContactConfig read_contact(const JsonNode& node, const std::vector<SceneObject>& objects) {
  node.expect_keys({"dhat", "offset", "ccd_ratio", "friction", "eps_v", "pair_friction", "stiffness"});
  ContactConfig c;
  // dhat is required: a good value depends on the scene's scale (IPC uses 1e-3 of the bounding box
  // diagonal), and a silent default would be wrong for a 2 cm hat and a 20 m sail alike.
  c.dhat = node.required("dhat").in_range(limits::kDhat);
  if (auto v = node.optional("offset")) c.offset = v->in_range(limits::kContactOffset);
  if (auto v = node.optional("ccd_ratio")) {
    c.ccd_ratio = v->number();
    if (!(c.ccd_ratio > 0.0 && c.ccd_ratio < 1.0)) v->fail_got("must be > 0 and < 1");
  }
  if (auto v = node.optional("friction")) c.friction = friction_coefficient(*v);
  if (auto v = node.optional("eps_v")) c.eps_v = v->in_range(limits::kEpsV);
  if (auto v = node.optional("stiffness")) c.stiffness = v->in_range(limits::kBarrierStiffness);
  if (auto list = node.optional("pair_friction")) {
    std::set<std::pair<int, int>> pairs;  // a set, so a long list costs no quadratic search
    for (const JsonNode& entry : list->elements()) {
      entry.expect_keys({"objects", "friction"});
      auto names = entry.required("objects").elements(2);
      ContactConfig::PairFriction p;
      p.a = object_index(names[0], objects);
      p.b = object_index(names[1], objects);
      if (p.a > p.b) std::swap(p.a, p.b);
      p.mu = friction_coefficient(entry.required("friction"));
      if (!pairs.insert({p.a, p.b}).second) entry.fail("gives the pair of objects a second friction coefficient");
      c.pair_friction.push_back(p);
    }
  }
  return c;
}

Ground read_ground(const JsonNode& node) {
  node.expect_keys({"height", "normal", "friction"});
  Ground g;
  if (auto v = node.optional("height")) g.height = v->in_range(limits::kPosition);
  if (auto v = node.optional("normal")) g.normal = v->direction();
  if (auto v = node.optional("friction")) g.friction = friction_coefficient(*v);
  return g;
}

StrainLimit read_strain_limit(const JsonNode& node) {
  node.expect_keys({"limit", "barrier_start", "stiffness"});
  StrainLimit s;
  JsonNode limit = node.required("limit");
  s.limit = limit.number();
  // Below 1.0 even the rest shape would violate it; above 10 the limit means nothing for cloth.
  if (!(s.limit > 1.0 && s.limit <= 10.0)) limit.fail_got("must be > 1 (e.g. 1.1 for 10% stretch) and <= 10");
  if (auto v = node.optional("barrier_start")) {
    s.barrier_start = v->number();
    // Below 1 the barrier would push on unstretched cloth; at the limit it would have no band.
    if (!(*s.barrier_start >= 1.0 && *s.barrier_start < s.limit))
      v->fail_got("must be >= 1 and below limit");
  }
  if (auto v = node.optional("stiffness")) s.stiffness = v->in_range(limits::kStrainLimitStiffness);
  return s;
}

}  // namespace pd::scene_json
