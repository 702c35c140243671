#include "hierarchy/submesh_relaxation.h"

#include <array>
#include <cmath>
#include <optional>
#include <set>
#include <utility>

#include "hierarchy/contact_submesh.h"
#include "physics/contact/barrier_potential.h"
#include "physics/contact/ground_barrier.h"

namespace pd {

namespace {

Vec3 row(const Positions& x, int i) { return x.row(i).transpose(); }

// The submesh around the free vertices (header) with their ids in it and its ground.
struct PatchSubmesh {
  ContactSubmesh sub;
  Positions rest, x;      // of the submesh's vertices
  std::vector<int> free;  // submesh ids
  std::optional<GroundPlane> ground;  // vertex_collides per submesh vertex
  RelaxationMesh mesh(double offset) const { return {&sub.prims, &rest, offset, ground ? &*ground : nullptr}; }
};

// The faces within two rings of `free` and every face with a vertex in a cell of side `scale` next to
// a free vertex or a point of `also_near`.
PatchSubmesh patch_submesh(const ContactPrimitives& prims, const Positions& rest, const std::vector<int>& free,
                           double scale, const Positions& x, const std::vector<Vec3>& also_near,
                           const GroundPlane* ground) {
  const std::size_t n = static_cast<std::size_t>(x.rows());
  std::vector<char> region(n, 0);
  for (int v : free) region[static_cast<std::size_t>(v)] = 1;
  region = grow_by_faces(prims.faces, grow_by_faces(prims.faces, region));
  // Cells of side `scale` holding a free vertex; a vertex in one of them or a neighbouring cell is
  // near the patch (within ~2 scale, whatever the patches' spread over the mesh).
  auto cell = [&](const Vec3& p) {
    return std::array<long long, 3>{static_cast<long long>(std::floor(p[0] / scale)),
                                    static_cast<long long>(std::floor(p[1] / scale)),
                                    static_cast<long long>(std::floor(p[2] / scale))};
  };
  std::set<std::array<long long, 3>> occupied;
  for (int v : free) occupied.insert(cell(row(x, v)));
  for (const Vec3& p : also_near) occupied.insert(cell(p));
  auto near_patch = [&](const Vec3& p) {
    const auto c = cell(p);
    for (long long i = -1; i <= 1; ++i)
      for (long long j = -1; j <= 1; ++j)
        for (long long k = -1; k <= 1; ++k)
          if (occupied.count({c[0] + i, c[1] + j, c[2] + k})) return true;
    return false;
  };
  std::vector<int> taken;
  for (int f = 0; f < prims.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = prims.faces(f, k);
      if (region[static_cast<std::size_t>(v)] || near_patch(row(x, v))) {
        taken.push_back(f);
        break;
      }
    }
  Faces F(static_cast<Eigen::Index>(taken.size()), 3);
  for (std::size_t k = 0; k < taken.size(); ++k) F.row(static_cast<Eigen::Index>(k)) = prims.faces.row(taken[k]);
  PatchSubmesh p;
  p.sub = contact_submesh(F, prims.vertex_object, prims.object_self_contact);
  p.rest = gather_rows(rest, p.sub.vertices);
  p.x = gather_rows(x, p.sub.vertices);
  for (int v : free) p.free.push_back(p.sub.local(v));
  if (ground) {
    p.ground = GroundPlane{ground->normal, ground->height, {}};
    for (int v : p.sub.vertices) p.ground->vertex_collides.push_back(ground->vertex_collides[static_cast<std::size_t>(v)]);
  }
  return p;
}

// follow_path for a path of submesh positions (rows = p.sub.vertices).
void follow_submesh_path(const ContactPrimitives& prims, const Positions& rest, double offset, const GroundPlane* ground,
                         const PatchSubmesh& p, const std::vector<Positions>& sub_path, Positions& x) {
  std::vector<Positions> path;
  for (const Positions& waypoint : sub_path) {
    path.push_back(x);
    scatter_rows(waypoint, p.sub.vertices, path.back());
  }
  follow_path(prims, rest, offset, ground, path, x);
}

}  // namespace

// Marks every vertex of a face that has a marked vertex (one ring of growth).
std::vector<char> grow_by_faces(const Faces& F, const std::vector<char>& marked) {
  std::vector<char> out = marked;
  for (int f = 0; f < F.rows(); ++f)
    if (marked[static_cast<std::size_t>(F(f, 0))] || marked[static_cast<std::size_t>(F(f, 1))] ||
        marked[static_cast<std::size_t>(F(f, 2))])
      for (int k = 0; k < 3; ++k) out[static_cast<std::size_t>(F(f, k))] = 1;
  return out;
}

void follow_path(const ContactPrimitives& prims, const Positions& rest, double offset, const GroundPlane* ground,
                 const std::vector<Positions>& path, Positions& x) {
  if (path.empty()) return;
  ContactSettings cs;
  cs.dhat = 1.0;  // unused: only the step cap is asked for
  cs.offset = offset;
  BarrierPotential mesh(prims, rest, cs);
  Eigen::VectorXd xs = stacked(x);
  mesh.set_thin_pairs(mesh.pairs_within_offset(xs));
  std::optional<GroundBarrier> floor;
  if (ground) {
    std::vector<int> colliding;
    for (std::size_t v = 0; v < ground->vertex_collides.size(); ++v)
      if (ground->vertex_collides[v]) colliding.push_back(static_cast<int>(v));
    floor.emplace(std::move(colliding), ground->normal, ground->height, cs, 0.0);
  }
  for (const Positions& waypoint : path) {
    const Eigen::VectorXd dx = stacked(waypoint) - xs;
    double alpha = mesh.max_step(xs, dx);
    if (floor) alpha = std::min(alpha, floor->max_step(xs, dx));
    xs += alpha * dx;  // a segment cut short: the next one starts from here, also checked
  }
  x = as_rows(xs);
}

RelaxationReport relax_gaps_on_submesh(const ContactPrimitives& prims, const Positions& rest,
                                       const std::vector<int>& free, double offset, double min_gap, double scale,
                                       const GroundPlane* ground, Positions& x) {
  PatchSubmesh p = patch_submesh(prims, rest, free, scale, x, {}, ground);
  GapRelaxationSettings settings;
  settings.min_gap = min_gap;
  settings.max_stiffness_rounds = 8;  // 128x the starting stiffness; what is left is reported
  std::vector<Positions> sub_path;
  const RelaxationReport r = relax_gaps(p.mesh(offset), p.free, settings, p.x, &sub_path);
  follow_submesh_path(prims, rest, offset, ground, p, sub_path, x);
  return r;
}

RelaxationReport pull_toward_aims(const ContactPrimitives& prims, const Positions& rest, const std::vector<int>& free,
                                  const Positions& aim, double offset, double scale, const GroundPlane* ground,
                                  Positions& x) {
  std::vector<Vec3> aims;
  for (int v : free) aims.push_back(row(aim, v));
  PatchSubmesh p = patch_submesh(prims, rest, free, scale, x, aims, ground);
  const Positions sub_aim = gather_rows(aim, p.sub.vertices);
  std::vector<Positions> sub_path;
  const RelaxationReport r = relax_toward(p.mesh(offset), p.free, sub_aim, TargetRelaxationSettings{}, p.x, &sub_path);
  follow_submesh_path(prims, rest, offset, ground, p, sub_path, x);
  return r;
}

}  // namespace pd
