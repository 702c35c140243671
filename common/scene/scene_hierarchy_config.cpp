#include "scene/scene_hierarchy_config.h"

#include <climits>
#include <string>

namespace pd::scene_json {

namespace {

// Levels beyond this would mean counts below 3 vertices for any mesh the scene reader accepts
// (a ratio of at least ~2 per level); a larger value is almost certainly a typo.
constexpr long long kMaxLevels = 20;

// Smallest count of a level: a single triangle (the decimation itself needs 4 for a closed mesh and
// reports that with the object's level).
constexpr int kMinLevelVertices = 3;

std::string level_label(int level, int finest) {
  return "level " + std::to_string(level) + (level == 0 ? " (coarsest)" : "") + (level == finest ? " (finest)" : "");
}

}  // namespace

HierarchyConfig read_hierarchy(const JsonNode& node) {
  node.expect_keys({"levels", "ratio"});
  HierarchyConfig c;
  if (auto v = node.optional("levels")) c.levels = static_cast<int>(v->integer(1, kMaxLevels));
  if (auto v = node.optional("ratio")) {
    c.ratio = v->number();
    if (!(c.ratio > 1.0)) v->fail_got("must be > 1 (vertex-count ratio between neighbouring levels)");
    // Above 1000 even a 2 000 000-vertex mesh has fewer than 3 vertices on its second level.
    if (!(c.ratio <= limits::kHierarchyRatio.upper)) v->fail_got("must be <= 1000");
  }
  return c;
}

ObjectHierarchyConfig read_object_hierarchy(const JsonNode& node, const HierarchyConfig& scene_config,
                                            const SceneObject& object) {
  node.expect_keys({"vertex_counts", "keep_boundary", "coarsening"});
  ObjectHierarchyConfig c;
  if (auto kb = node.optional("keep_boundary")) c.keep_boundary = kb->boolean();
  auto counts_node = node.optional("vertex_counts");
  if (auto coarsening = node.optional("coarsening")) {
    c.grid_coarsening = coarsening->choice({"quadric", "grid"}, "coarsening") == "grid";
    if (c.grid_coarsening && !object.grid)
      coarsening->fail_got("\"grid\" needs a mesh of type \"rectangle\" or \"box\" (object \"" + object.name + "\")");
    if (c.grid_coarsening && counts_node)
      counts_node->fail("must be left out with coarsening \"grid\", whose sub-grids set the vertex counts (object \"" +
                        object.name + "\")");
  }
  if (!counts_node) return c;
  const int finest = scene_config.levels - 1;  // index of the finest level
  const int n = object.rest.num_vertices();
  const std::vector<JsonNode> list = counts_node->elements();
  if (static_cast<int>(list.size()) != finest) {
    counts_node->fail("must list one vertex count per coarser level, next-to-finest first: " + std::to_string(finest) +
                      " for the scene's " + std::to_string(scene_config.levels) + " levels (hierarchy.levels), got " +
                      std::to_string(list.size()) + " for object \"" + object.name + "\"");
  }
  int finer = n;  // the next finer level's count
  for (std::size_t i = 0; i < list.size(); ++i) {
    const int level = finest - 1 - static_cast<int>(i);
    const std::string who = level_label(level, finest) + " of object \"" + object.name + "\"";
    const long long v = list[i].integer(LLONG_MIN / 2, LLONG_MAX / 2);
    if (v < kMinLevelVertices) list[i].fail_got(who + " needs at least " + std::to_string(kMinLevelVertices) + " vertices");
    if (v > n) list[i].fail_got(who + " cannot have more vertices than the object's finest mesh (" + std::to_string(n) + ")");
    if (v > finer)
      list[i].fail_got(who + " cannot have more vertices than level " + std::to_string(level + 1) + " (" +
                       std::to_string(finer) + "): counts must not increase toward the coarsest level");
    finer = static_cast<int>(v);
    c.vertex_counts.push_back(finer);
  }
  return c;
}

void read_hierarchy_sections(const JsonNode& root, const std::vector<JsonNode>& objects, Scene& scene) {
  if (auto h = root.optional("hierarchy")) scene.hierarchy = read_hierarchy(*h);
  for (std::size_t i = 0; i < objects.size() && i < scene.objects.size(); ++i)
    if (auto h = objects[i].optional("hierarchy"))
      scene.objects[i].hierarchy = read_object_hierarchy(*h, scene.hierarchy, scene.objects[i]);
}

}  // namespace pd::scene_json
