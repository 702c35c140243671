// The scene-wide level hierarchy; see scene_hierarchy.h.
#include "hierarchy/scene_hierarchy.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include "hierarchy/grid_coarsening.h"
#include "hierarchy/intrinsic_location.h"
#include "hierarchy/split_batches.h"
#include "util/fnv1a.h"
#include "util/input_error.h"
#include "util/parallel.h"

namespace pd {
namespace {

// Bumped whenever the build changes in a way that changes its result for the same input (so that a
// stored hierarchy with the old tag is never reused).
constexpr char kFormatTag[] = "pd-hierarchy-2";  // 2: weights renormalised only when needed

std::string level_label(int level, int finest) {
  return "level " + std::to_string(level) + (level == finest ? " (finest)" : level == 0 ? " (coarsest)" : "");
}

std::string object_prefix(const Scene& scene, std::size_t k) {
  return scene.source_path + ": objects[" + std::to_string(k) + "] (" + scene.objects[k].name + "): ";
}

// What build_levels gets for object k, and the vertex count of every scene level (0..L; n at L).
struct ObjectPlan {
  LevelSettings settings;
  bool by_ratio = true;
  std::vector<int> counts;  // explicit vertex_counts only: counts[l] for scene level l
};

// The plan of a `coarsening: "grid"` object: each coarser level keeps its sub-grid
// (grid_level_vertices) and the vertices fixed anyway (fixed_vertices), whose number is
// its vertex count; a level whose set equals the finer one's is a copy, as with repeated counts.
ObjectPlan plan_grid(const SceneObject& obj, const Scene& scene, std::size_t k, ObjectPlan plan) {
  const int L = scene.hierarchy.levels - 1;
  const int n = obj.rest.num_vertices();
  if (!obj.grid || !obj.hierarchy.vertex_counts.empty())
    throw InputError(object_prefix(scene, k) + "hierarchy.coarsening: \"grid\" needs a rectangle or box mesh and "
                     "no vertex_counts");
  if (static_cast<int>(obj.grid->coords.size()) != n)
    throw InputError(object_prefix(scene, k) + "hierarchy.coarsening: the mesh has " + std::to_string(n) +
                     " vertices, its grid " + std::to_string(obj.grid->coords.size()));
  const std::vector<char> fixed =
      fixed_vertices(obj.rest, plan.settings.locked_vertices, plan.settings.decimation.keep_boundary);
  plan.by_ratio = false;
  plan.counts.assign(static_cast<std::size_t>(L) + 1, n);
  const std::vector<std::vector<int>> grids = grid_level_vertices(*obj.grid, L);
  for (int i = 0; i < L; ++i) {
    const auto l = static_cast<std::size_t>(L - 1 - i);
    std::vector<char> keep = fixed;
    for (int v : grids[static_cast<std::size_t>(i)]) keep[static_cast<std::size_t>(v)] = 1;
    std::vector<int> kept;
    for (int v = 0; v < n; ++v)
      if (keep[static_cast<std::size_t>(v)]) kept.push_back(v);
    plan.counts[l] = static_cast<int>(kept.size());
    if (plan.counts[l] < plan.counts[l + 1]) {
      plan.settings.target_vertex_counts.push_back(plan.counts[l]);
      plan.settings.kept_vertices.push_back(std::move(kept));
    }
  }
  plan.settings.coarser_levels = 0;  // as for explicit counts: only the distinct levels are built
  return plan;
}

// Checks the scene's and object k's hierarchy settings (the reader does too, with key paths; a scene
// built in code gets the same checks here) and derives build_levels' settings. The decimation settings
// are the defaults except keep_boundary, which defaults to false (ObjectHierarchyConfig).
ObjectPlan plan_object(const Scene& scene, std::size_t k) {
  const int L = scene.hierarchy.levels - 1;
  const SceneObject& obj = scene.objects[k];
  const ObjectHierarchyConfig& hc = obj.hierarchy;
  const int n = obj.rest.num_vertices();
  ObjectPlan plan;
  plan.settings.ratio = scene.hierarchy.ratio;
  plan.settings.decimation.keep_boundary = hc.keep_boundary.value_or(false);
  if (!obj.obstacle) {
    // Pins stay on every level at their rest positions, so scripts apply unchanged (PSQ 4.1).
    for (const PinGroup& g : obj.pins)
      plan.settings.locked_vertices.insert(plan.settings.locked_vertices.end(), g.vertices.begin(), g.vertices.end());
    std::sort(plan.settings.locked_vertices.begin(), plan.settings.locked_vertices.end());
    plan.settings.locked_vertices.erase(
        std::unique(plan.settings.locked_vertices.begin(), plan.settings.locked_vertices.end()),
        plan.settings.locked_vertices.end());
  }
  if (obj.motion && obj.motion->animation) {
    // An animated obstacle keeps its whole mesh on every level: each level's cloth meets the body it
    // will meet on the finest level (the contact promise holds against the full-resolution obstacle),
    // and its vertices follow the cache's vertices one to one (scene_system.cpp's pins).
    bool coarsened = hc.grid_coarsening;
    for (int c : hc.vertex_counts) coarsened = coarsened || c != n;
    if (coarsened)
      throw InputError(object_prefix(scene, k) + "hierarchy: an animated obstacle keeps its whole mesh on every "
                       "level (no coarsening, no vertex_counts below its " + std::to_string(n) + " vertices)");
    plan.by_ratio = false;
    plan.counts.assign(static_cast<std::size_t>(L) + 1, n);
    plan.settings.coarser_levels = 0;
    return plan;
  }
  if (hc.grid_coarsening) return plan_grid(obj, scene, k, std::move(plan));
  if (hc.vertex_counts.empty()) {
    plan.settings.coarser_levels = L;
    return plan;
  }
  const std::string where = object_prefix(scene, k) + "hierarchy.vertex_counts: ";
  if (static_cast<int>(hc.vertex_counts.size()) != L)
    throw InputError(where + "has " + std::to_string(hc.vertex_counts.size()) + " counts, the scene's " +
                     std::to_string(scene.hierarchy.levels) + " levels need " + std::to_string(L));
  plan.by_ratio = false;
  plan.counts.assign(static_cast<std::size_t>(L) + 1, n);
  for (int i = 0; i < L; ++i) {
    const int l = L - 1 - i, c = hc.vertex_counts[static_cast<std::size_t>(i)];
    const int finer = plan.counts[static_cast<std::size_t>(l) + 1];
    if (c < 3 || c > finer)
      throw InputError(where + level_label(l, L) + ": count " + std::to_string(c) + " must be >= 3 and <= level " +
                       std::to_string(l + 1) + "'s " + std::to_string(finer));
    plan.counts[static_cast<std::size_t>(l)] = c;
    if (c < finer) plan.settings.target_vertex_counts.push_back(c);
  }
  // No distinct coarser count: build_levels must make no level (empty targets would mean "by ratio").
  plan.settings.coarser_levels = 0;
  return plan;
}

// "level <d>[ (finest)| (coarsest)]..." of a build_levels message about its distinct level d ->
// the same message naming scene level scene_of[d].
std::string relabel_level(const std::string& message, const std::vector<int>& scene_of, int L) {
  const std::string head = "level ";
  if (message.rfind(head, 0) != 0) return message;
  std::size_t end = head.size();
  while (end < message.size() && message[end] >= '0' && message[end] <= '9') ++end;
  if (end == head.size() || end - head.size() > 6) return message;
  const std::size_t d = static_cast<std::size_t>(std::stoi(message.substr(head.size(), end - head.size())));
  if (d >= scene_of.size()) return message;
  for (const std::string suffix : {" (finest)", " (coarsest)"})
    if (message.compare(end, suffix.size(), suffix) == 0) end += suffix.size();
  return level_label(scene_of[d], L) + message.substr(end);
}

// Level `finer` again, as the next coarser level: same vertices (identity maps), no collapses, faces
// sorted as Tri like every decimated level.
Level copy_level(const Level& finer) {
  Level c;
  c.mesh.V = finer.mesh.V;
  const std::vector<Tri> tris = sorted_tris(finer.mesh.F);
  c.mesh.F.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t f = 0; f < tris.size(); ++f)
    for (int j = 0; j < 3; ++j) c.mesh.F(static_cast<Eigen::Index>(f), j) = tris[f][static_cast<std::size_t>(j)];
  c.to_finest = finer.to_finest;
  c.coarse_to_fine.resize(static_cast<std::size_t>(finer.mesh.num_vertices()));
  std::iota(c.coarse_to_fine.begin(), c.coarse_to_fine.end(), 0);
  c.fine_to_coarse = c.coarse_to_fine;
  return c;
}

// Object k's levels 0..L: build_levels on the distinct counts, repeated counts as copies.
std::vector<Level> build_object_levels(const Scene& scene, std::size_t k, const ObjectPlan& plan) {
  const int L = scene.hierarchy.levels - 1;
  // scene_of[d]: the scene level of build_levels' level d (the finest level of a run of equal counts).
  std::vector<int> scene_of;
  if (plan.by_ratio) {
    scene_of.resize(static_cast<std::size_t>(L) + 1);
    std::iota(scene_of.begin(), scene_of.end(), 0);
  } else {
    for (int l = 0; l <= L; ++l)
      if (l == L || plan.counts[static_cast<std::size_t>(l)] < plan.counts[static_cast<std::size_t>(l) + 1])
        scene_of.push_back(l);
  }
  std::vector<Level> built;
  try {
    built = build_levels(scene.objects[k].rest, plan.settings);
  } catch (const InputError& e) {
    throw InputError(object_prefix(scene, k) + relabel_level(e.what(), scene_of, L));
  }
  if (plan.by_ratio) return built;
  std::vector<Level> out(static_cast<std::size_t>(L) + 1);
  int d = static_cast<int>(built.size()) - 1;
  out[static_cast<std::size_t>(L)] = std::move(built[static_cast<std::size_t>(d)]);
  for (int l = L - 1; l >= 0; --l) {
    // A built level's maps and records refer to the next built level's ids, which are also the ids
    // of any copies in between (copies keep ids), so the chain stays consistent.
    if (d > 0 && scene_of[static_cast<std::size_t>(d) - 1] == l) {
      --d;
      out[static_cast<std::size_t>(l)] = std::move(built[static_cast<std::size_t>(d)]);
    } else {
      out[static_cast<std::size_t>(l)] = copy_level(out[static_cast<std::size_t>(l) + 1]);
    }
  }
  return out;
}

// Stacks per-object locations on level meshes into scene ones: faces shifted by the level's offsets.
void append_locations(std::vector<SurfaceLocation>& out, std::vector<SurfaceLocation> part, int face_offset) {
  for (SurfaceLocation& s : part) {
    s.face += face_offset;
    out.push_back(s);
  }
}

std::string hash_of(const Scene& scene, const std::vector<ObjectPlan>& plans) {
  Fnv1a h;
  h.str(kFormatTag);
  h.i64(scene.hierarchy.levels);
  h.f64(scene.hierarchy.ratio);
  h.i64(static_cast<long long>(scene.objects.size()));
  for (std::size_t k = 0; k < scene.objects.size(); ++k) {
    const SceneObject& obj = scene.objects[k];
    const ObjectPlan& plan = plans[k];
    h.i64(obj.rest.num_vertices());
    for (Eigen::Index i = 0; i < obj.rest.V.rows(); ++i)
      for (int j = 0; j < 3; ++j) h.f64(obj.rest.V(i, j));
    h.i64(obj.rest.num_faces());
    for (Eigen::Index f = 0; f < obj.rest.F.rows(); ++f)
      for (int j = 0; j < 3; ++j) h.i64(obj.rest.F(f, j));
    h.i64(static_cast<long long>(plan.settings.locked_vertices.size()));
    for (int v : plan.settings.locked_vertices) h.i64(v);
    h.i64(obj.obstacle ? 1 : 0);
    // Hashed only when set, so that other scenes keep their hashes: an animated obstacle is kept whole.
    if (obj.motion && obj.motion->animation) h.str("animated");
    h.i64(static_cast<long long>(obj.hierarchy.vertex_counts.size()));
    for (int c : obj.hierarchy.vertex_counts) h.i64(c);
    // Hashed only when set, so that quadric-coarsened scenes keep their hashes.
    if (obj.hierarchy.grid_coarsening) {
      h.str("grid");
      for (const std::vector<int>& kept : plan.settings.kept_vertices) {
        h.i64(static_cast<long long>(kept.size()));
        for (int v : kept) h.i64(v);
      }
    }
    const DecimationSettings& ds = plan.settings.decimation;
    h.i64(ds.keep_boundary ? 1 : 0);
    h.f64(ds.max_normal_change_degrees);
    h.f64(ds.min_triangle_quality);
    h.f64(ds.normal_variance);
    h.f64(ds.position_variance);
    h.f64(ds.count_tolerance);
  }
  return h.hex();
}

std::vector<ObjectPlan> plan_scene(const Scene& scene) {
  if (scene.hierarchy.levels < 1)
    throw InputError(scene.source_path + ": hierarchy.levels: must be >= 1, got " + std::to_string(scene.hierarchy.levels));
  if (scene.hierarchy.levels > 1 && !(std::isfinite(scene.hierarchy.ratio) && scene.hierarchy.ratio > 1.0))
    throw InputError(scene.source_path + ": hierarchy.ratio: must be > 1, got " + std::to_string(scene.hierarchy.ratio));
  std::vector<ObjectPlan> plans;
  for (std::size_t k = 0; k < scene.objects.size(); ++k) plans.push_back(plan_object(scene, k));
  return plans;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// One object's locations: to_finest[l] (the finest vertices on level l, every level) and to_next[l]
// (level l + 1's vertices on level l, l < L), in the object's own ids; and batches[l], level l's
// collapses split into batches (split_batches; empty for the finest level).
struct ObjectLocations {
  std::vector<std::vector<SurfaceLocation>> to_finest, to_next;
  std::vector<std::vector<std::vector<int>>> batches;
};

// Every object's locations and batches, computed as independent tasks in parallel. Per object with
// L > 0: task 0 tracks the finest vertices down every level (locate_finest_on_all_levels); its first
// leg, through level L - 1's collapses, is exactly locate_through_collapses for L - 1 (the same
// points through the same collapses; the ids differ only by a rotation, undone by the rows), so
// to_next[L - 1] is a copy of to_finest[L - 1], not a second tracking of the largest leg. Task j
// (1 <= j < L) locates level j's vertices on level j - 1; task L + l splits level l's collapses into
// batches (l < L). Each task writes only its own outputs, so the result does not depend on the
// thread count. Adds each level's share of the time to seconds (the finest chain's by collapse
// counts, as the decimation's). Errors mean records that do not fit their levels (a bug, not bad
// input): std::logic_error naming the object and the level.
std::vector<ObjectLocations> locate_objects(const Scene& scene, const std::vector<ObjectHierarchy>& objects,
                                            std::vector<double>& seconds) {
  const int L = scene.hierarchy.levels - 1;
  const std::size_t nl = static_cast<std::size_t>(L) + 1, locate = L > 0 ? static_cast<std::size_t>(L) : 1;
  const std::size_t per_object = locate + static_cast<std::size_t>(L);
  std::vector<ObjectLocations> out(objects.size());
  for (ObjectLocations& o : out) {
    o.to_next.resize(nl - 1);
    o.batches.resize(nl);
  }
  std::vector<double> task_seconds(objects.size() * per_object, 0.0);
  parallel_for_index(static_cast<int>(task_seconds.size()), [&](int t) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::size_t k = static_cast<std::size_t>(t) / per_object, task = static_cast<std::size_t>(t) % per_object;
    const std::vector<Level>& lv = objects[k].levels;
    try {
      if (task == 0) {
        out[k].to_finest = locate_finest_on_all_levels(lv);
        if (L > 0) out[k].to_next[nl - 2] = out[k].to_finest[nl - 2];
      } else if (task < locate) {
        const std::size_t l = task - 1;
        out[k].to_next[l] = locate_through_collapses(lv[l + 1].mesh, lv[l].collapses, lv[l].mesh, lv[l].coarse_to_fine);
      } else {
        out[k].batches[task - locate] = split_batches(lv[task - locate].collapses);
      }
    } catch (const std::invalid_argument& e) {
      const std::string where = task == 0 ? std::string("finest locations")
                                          : level_label(static_cast<int>(task < locate ? task - 1 : task - locate), L);
      throw std::logic_error(object_prefix(scene, k) + where + ": " + e.what());
    }
    task_seconds[static_cast<std::size_t>(t)] = seconds_since(t0);
  }, 1);
  for (std::size_t k = 0; k < objects.size(); ++k) {
    std::size_t total = 0;
    for (std::size_t l = 0; l + 1 < nl; ++l) total += objects[k].levels[l].collapses.size();
    for (std::size_t l = 0; l + 1 < nl; ++l) {
      if (l + 1 < locate) seconds[l] += task_seconds[k * per_object + 1 + l];
      seconds[l] += task_seconds[k * per_object + locate + l];
      if (total > 0)
        seconds[l] += task_seconds[k * per_object] * static_cast<double>(objects[k].levels[l].collapses.size()) /
                      static_cast<double>(total);
    }
  }
  return out;
}

}  // namespace

std::string hierarchy_hash(const Scene& scene) { return hash_of(scene, plan_scene(scene)); }

SceneHierarchy build_scene_hierarchy(const Scene& scene, std::vector<HierarchyLevelReport>* report) {
  const std::vector<ObjectPlan> plans = plan_scene(scene);
  const int L = scene.hierarchy.levels - 1;
  const auto nl = static_cast<std::size_t>(L) + 1;
  SceneHierarchy h;
  h.hash = hash_of(scene, plans);
  std::vector<double> seconds(nl, 0.0);

  // Per object, objects in parallel (each decimation reads only its own object; CGAL's edge
  // collapse keeps no shared state between meshes; an error is the one of the first object that
  // fails, as in a serial loop). One decimation run makes all of an object's levels; its time is
  // split over the levels in proportion to their collapse counts.
  h.objects.resize(scene.objects.size());
  std::vector<double> build_time(scene.objects.size(), 0.0);
  parallel_for_index(static_cast<int>(scene.objects.size()), [&](int k) {
    const auto t0 = std::chrono::steady_clock::now();
    h.objects[static_cast<std::size_t>(k)].levels = build_object_levels(scene, static_cast<std::size_t>(k), plans[static_cast<std::size_t>(k)]);
    build_time[static_cast<std::size_t>(k)] = seconds_since(t0);
  }, 1);
  for (std::size_t k = 0; k < h.objects.size(); ++k) {
    const std::vector<Level>& levels = h.objects[k].levels;
    std::size_t total = 0;
    for (int l = 0; l < L; ++l) total += levels[static_cast<std::size_t>(l)].collapses.size();
    for (int l = 0; l < L; ++l)
      if (total > 0)
        seconds[static_cast<std::size_t>(l)] +=
            build_time[k] * static_cast<double>(levels[static_cast<std::size_t>(l)].collapses.size()) / static_cast<double>(total);
  }

  // Stacked meshes, objects in scene order (SceneSystem's global ids at the finest level).
  h.levels.resize(nl);
  for (std::size_t l = 0; l < nl; ++l) {
    SceneLevel& s = h.levels[l];
    s.vertex_offsets.assign(1, 0);
    s.face_offsets.assign(1, 0);
    for (const ObjectHierarchy& oh : h.objects) {
      s.vertex_offsets.push_back(s.vertex_offsets.back() + oh.levels[l].mesh.num_vertices());
      s.face_offsets.push_back(s.face_offsets.back() + oh.levels[l].mesh.num_faces());
    }
    s.rest.V.resize(s.vertex_offsets.back(), 3);
    s.rest.F.resize(s.face_offsets.back(), 3);
    s.to_finest.reserve(static_cast<std::size_t>(s.vertex_offsets.back()));
  }
  for (std::size_t l = 0; l < nl; ++l) {
    SceneLevel& s = h.levels[l];
    for (std::size_t k = 0; k < h.objects.size(); ++k) {
      const Level& lv = h.objects[k].levels[l];
      const int voff = s.vertex_offsets[k], foff = s.face_offsets[k];
      s.rest.V.middleRows(voff, lv.mesh.num_vertices()) = lv.mesh.V;
      s.rest.F.middleRows(foff, lv.mesh.num_faces()) = lv.mesh.F.array() + voff;
      for (int id : lv.to_finest) s.to_finest.push_back(h.levels[static_cast<std::size_t>(L)].vertex_offsets[k] + id);
    }
  }

  // Operators. Locations are computed per object (each on its own meshes) and shifted to the stacked
  // face ids; then every level's two operators are built, each its own task in parallel (task 2l:
  // level l's to_finest_prolongation, task 2l + 1: its to_next).
  const Positions& finest_rest = h.levels[static_cast<std::size_t>(L)].rest.V;
  std::vector<ObjectLocations> located = locate_objects(scene, h.objects, seconds);
  const std::size_t no = h.objects.size();
  for (std::size_t k = 0; k < no; ++k) h.objects[k].batches = std::move(located[k].batches);
  std::vector<std::vector<SurfaceLocation>> to_next(nl - 1), to_finest(nl);
  for (std::size_t l = 0; l < nl; ++l)
    for (std::size_t k = 0; k < no; ++k) {
      if (l + 1 < nl) append_locations(to_next[l], std::move(located[k].to_next[l]), h.levels[l].face_offsets[k]);
      append_locations(to_finest[l], std::move(located[k].to_finest[l]), h.levels[l].face_offsets[k]);
    }
  std::vector<double> operator_seconds(2 * nl - 1, 0.0);
  parallel_for_index(static_cast<int>(operator_seconds.size()), [&](int t) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::size_t l = static_cast<std::size_t>(t) / 2;
    SceneLevel& s = h.levels[l];
    if (t % 2 == 0) s.to_finest_prolongation.emplace(s.rest.V, s.rest.F, finest_rest, to_finest[l]);
    else s.to_next.emplace(s.rest.V, s.rest.F, h.levels[l + 1].rest.V, to_next[l]);
    operator_seconds[static_cast<std::size_t>(t)] = seconds_since(t0);
  }, 1);
  for (std::size_t t = 0; t < operator_seconds.size(); ++t) seconds[t / 2] += operator_seconds[t];

  if (report) {
    report->assign(nl, HierarchyLevelReport{});
    for (std::size_t l = 0; l < nl; ++l) {
      const SceneLevel& s = h.levels[l];
      HierarchyLevelReport& r = (*report)[l];
      r.vertices = s.rest.num_vertices();
      r.triangles = s.rest.num_faces();
      r.build_seconds = seconds[l];
      const Positions recovered = s.to_finest_prolongation->apply(s.rest.V);
      r.rest_prolongation_error = recovered.rows() ? (recovered - finest_rest).rowwise().norm().maxCoeff() : 0.0;
    }
  }
  return h;
}

SceneCollapses scene_collapses(const SceneHierarchy& hierarchy, int level) {
  const int L = hierarchy.finest();
  if (level < 0 || level >= L)
    throw std::invalid_argument("scene_collapses: level " + std::to_string(level) + " out of range [0, " +
                                std::to_string(L) + ") (the hierarchy has " + std::to_string(hierarchy.num_levels()) +
                                " levels; the finest has no collapses)");
  const auto l = static_cast<std::size_t>(level);
  const SceneLevel& coarse = hierarchy.levels[l];
  const SceneLevel& fine = hierarchy.levels[l + 1];
  SceneCollapses out;
  out.coarse_to_fine.reserve(static_cast<std::size_t>(coarse.rest.num_vertices()));
  for (std::size_t k = 0; k < hierarchy.objects.size(); ++k) {
    const ObjectHierarchy& oh = hierarchy.objects[k];
    const Level& lv = oh.levels[l];
    const int off = fine.vertex_offsets[k];
    const int first = static_cast<int>(out.collapses.size());
    for (Collapse c : lv.collapses) {
      c.removed += off;
      c.kept += off;
      for (Tri& t : c.faces_before) for (int& v : t) v += off;
      for (Tri& t : c.faces_after) for (int& v : t) v += off;
      out.collapses.push_back(std::move(c));
    }
    // Shifting every id by the same offset keeps the smallest-first rotation and sorted order.
    const std::vector<std::vector<int>>& batches = oh.batches[l];
    if (batches.size() > out.batches.size()) out.batches.resize(batches.size());
    for (std::size_t b = 0; b < batches.size(); ++b)
      for (int i : batches[b]) out.batches[b].push_back(first + i);
    for (int id : lv.coarse_to_fine) out.coarse_to_fine.push_back(off + id);
  }
  return out;
}

}  // namespace pd
