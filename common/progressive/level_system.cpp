#include "progressive/level_system.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace pd {

Scene scene_at_level(const Scene& scene, const SceneHierarchy& hierarchy, int level) {
  if (level < 0 || level > hierarchy.finest())
    throw std::invalid_argument("scene_at_level: level " + std::to_string(level) + " is not in [0, " +
                                std::to_string(hierarchy.finest()) + "]");
  if (hierarchy.objects.size() != scene.objects.size())
    throw std::invalid_argument("scene_at_level: the hierarchy has " + std::to_string(hierarchy.objects.size()) +
                                " objects, the scene " + std::to_string(scene.objects.size()));
  if (level == hierarchy.finest()) return scene;
  Scene out = scene;
  for (std::size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& finest = scene.objects[o];
    const Level& lv = hierarchy.objects[o].levels[static_cast<std::size_t>(level)];
    SceneObject& obj = out.objects[o];
    obj.rest = lv.mesh;
    obj.grid.reset();  // the lattice is the finest mesh's; a level mesh has none
    obj.initial = lv.mesh.V;
    std::vector<int> level_of(static_cast<std::size_t>(finest.rest.num_vertices()), -1);
    for (std::size_t i = 0; i < lv.to_finest.size(); ++i) {
      const int f = lv.to_finest[i];
      level_of[static_cast<std::size_t>(f)] = static_cast<int>(i);
      obj.initial.row(static_cast<Eigen::Index>(i)) += finest.initial.row(f) - finest.rest.V.row(f);
    }
    for (PinGroup& g : obj.pins) {
      for (int& v : g.vertices) {
        const int mapped = level_of[static_cast<std::size_t>(v)];
        if (mapped < 0)
          throw std::invalid_argument("scene_at_level: objects[" + std::to_string(o) + "] (" + finest.name +
                                      "): pinned vertex " + std::to_string(v) + " is not on level " +
                                      std::to_string(level));
        v = mapped;
      }
      std::sort(g.vertices.begin(), g.vertices.end());
    }
  }
  return out;
}

namespace {

// The scene's stacked initial positions, objects in scene order (the finest level's x0).
Eigen::VectorXd build_initial_positions(const Scene& scene) {
  Eigen::Index n = 0;
  for (const SceneObject& o : scene.objects) n += o.initial.rows();
  Eigen::VectorXd x(3 * n);
  Eigen::Index at = 0;
  for (const SceneObject& o : scene.objects) {
    x.segment(3 * at, 3 * o.initial.rows()) = stacked(o.initial);
    at += o.initial.rows();
  }
  return x;
}

}  // namespace

Eigen::VectorXd level_initial_positions(const Scene& scene, const SceneHierarchy& hierarchy, int level) {
  return build_initial_positions(scene_at_level(scene, hierarchy, level));
}

ProlongedHessian auto_prolonged_hessian(int level) {
  return level == 0 ? ProlongedHessian::CoarseFirst : ProlongedHessian::Lagged;
}

const std::vector<std::string>& level_hessian_names() {
  static const std::vector<std::string> names = {"auto", "galerkin", "lagged", "coarse", "coarse-first"};
  return names;
}

std::optional<ProlongedHessian> parse_level_hessian(const std::string& name) {
  if (name == "auto") return std::nullopt;
  try {
    return parse_prolonged_hessian(name);
  } catch (const std::invalid_argument&) {
    const std::vector<std::string>& names = level_hessian_names();
    std::string words;
    for (std::size_t i = 0; i < names.size(); ++i)
      words += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
    throw std::invalid_argument("unknown prolonged Hessian '" + name + "': use " + words);
  }
}

SceneSystem build_level_system(const Scene& scene, const SceneHierarchy& hierarchy, int level,
                               const LevelSystemOptions& options) {
  const Scene at_level = scene_at_level(scene, hierarchy, level);
  if (level == hierarchy.finest() || options.direct) return build_scene_system(at_level);

  SceneSystem sys = build_scene_system(at_level, /*own_shell_forces=*/false);
  const Eigen::VectorXd finest_initial = build_initial_positions(scene);
  const SceneLevel& lv = hierarchy.levels[static_cast<std::size_t>(level)];
  const SceneLevel& finest = hierarchy.levels.back();
  const ProlongedHessian hessian = options.hessian.value_or(auto_prolonged_hessian(level));
  sys.prolongation = std::make_shared<ProlongationState>(*lv.to_finest_prolongation, stacked(lv.rest.V), options.gradient);
  // Every deformable object's shell terms in one prolonged term (see prolonged_term.h), in object
  // order and, within an object, in add_shell_forces' order (the frame statistics' key order).
  std::vector<std::unique_ptr<EnergyTerm>> fine_terms, coarse_terms;
  for (std::size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    if (obj.obstacle) continue;
    const int fine_offset = finest.vertex_offsets[o], coarse_offset = lv.vertex_offsets[o];
    Faces fine_faces = obj.rest.F;
    fine_faces.array() += fine_offset;
    add_shell_forces(obj, fine_faces, fine_offset, finest.rest.V, finest_initial, fine_terms);
    if (hessian == ProlongedHessian::Coarse || hessian == ProlongedHessian::CoarseFirst) {
      const SceneObject& coarse_obj = at_level.objects[o];
      Faces coarse_faces = coarse_obj.rest.F;
      coarse_faces.array() += coarse_offset;
      add_shell_forces(coarse_obj, coarse_faces, coarse_offset, lv.rest.V, sys.x0, coarse_terms);
    }
  }
  if (!fine_terms.empty())
    sys.ip.add_term(std::make_unique<ProlongedTerm>(std::move(fine_terms), sys.prolongation, hessian,
                                                    std::move(coarse_terms)));
  return sys;
}

}  // namespace pd
