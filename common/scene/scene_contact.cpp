#include "scene/scene_contact.h"

#include <string>

namespace pd::scene_json {

namespace {

// Index of the object called `name`, or a failure at `node` listing the names there are.
int object_index(const JsonNode& node, const std::vector<SceneObject>& objects) {
  const std::string name = node.string();
  std::string known;
  for (std::size_t k = 0; k < objects.size(); ++k) {
    if (objects[k].name == name) return static_cast<int>(k);
    known += (k ? ", \"" : "\"") + objects[k].name + "\"";
  }
  node.fail_got("names no object of the scene (objects: " + known + ")");
}

double friction_coefficient(const JsonNode& node) {
  const double mu = node.number();
  if (!(mu >= 0.0)) node.fail_got("a friction coefficient must be >= 0");
  return mu;
}

}  // namespace

ContactConfig read_contact(const JsonNode& node, const std::vector<SceneObject>& objects) {
  node.expect_keys({"dhat", "offset", "ccd_ratio", "friction", "eps_v", "pair_friction", "stiffness"});
  ContactConfig c;
  // dhat is required: a good value depends on the scene's scale (IPC uses 1e-3 of the bounding box
  // diagonal), and a silent default would be wrong for a 2 cm hat and a 20 m sail alike.
  c.dhat = node.required("dhat").positive();
  if (auto v = node.optional("offset")) c.offset = v->at_least(0.0);
  if (auto v = node.optional("ccd_ratio")) {
    c.ccd_ratio = v->number();
    if (!(c.ccd_ratio > 0.0 && c.ccd_ratio < 1.0)) v->fail_got("must be > 0 and < 1");
  }
  if (auto v = node.optional("friction")) c.friction = friction_coefficient(*v);
  if (auto v = node.optional("eps_v")) c.eps_v = v->positive();
  if (auto v = node.optional("stiffness")) c.stiffness = v->positive();
  if (auto list = node.optional("pair_friction")) {
    for (const JsonNode& entry : list->elements()) {
      entry.expect_keys({"objects", "friction"});
      auto names = entry.required("objects").elements(2);
      ContactConfig::PairFriction p;
      p.a = object_index(names[0], objects);
      p.b = object_index(names[1], objects);
      if (p.a > p.b) std::swap(p.a, p.b);
      p.mu = friction_coefficient(entry.required("friction"));
      for (const auto& q : c.pair_friction)
        if (q.a == p.a && q.b == p.b) entry.fail("gives the pair of objects a second friction coefficient");
      c.pair_friction.push_back(p);
    }
  }
  return c;
}

Ground read_ground(const JsonNode& node) {
  node.expect_keys({"height", "normal", "friction"});
  Ground g;
  if (auto v = node.optional("height")) g.height = v->number();
  if (auto v = node.optional("normal")) {
    const Vec3 n = v->vec3();
    if (!(n.norm() > 0.0)) v->fail_got("must be a non-zero vector");
    g.normal = n.normalized();
  }
  if (auto v = node.optional("friction")) g.friction = friction_coefficient(*v);
  return g;
}

StrainLimit read_strain_limit(const JsonNode& node) {
  node.expect_keys({"limit"});
  StrainLimit s;
  JsonNode limit = node.required("limit");
  s.limit = limit.number();
  // Below 1.0 even the rest shape would violate it; above 10 the limit means nothing for cloth.
  if (!(s.limit > 1.0 && s.limit <= 10.0)) limit.fail_got("must be > 1 (e.g. 1.1 for 10% stretch) and <= 10");
  return s;
}

}  // namespace pd::scene_json
