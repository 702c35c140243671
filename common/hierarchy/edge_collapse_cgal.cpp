#include "hierarchy/edge_collapse_cgal.h"

// CGAL 5.5 calls used:
//   Surface_mesh<Simple_cartesian<double>::Point_3>, built with add_vertex / add_face in the input's
//     order, so CGAL vertex index i starts as input vertex i;
//   Surface_mesh_simplification::edge_collapse with named parameters get_cost, get_placement, filter,
//     visitor, and a stop predicate;
//   GarlandHeckbert_probabilistic_plane_policies<Mesh, K, Constant_property_map<face, (nv, pv)>>:
//     the probabilistic plane quadrics of Trettner and Kobbelt 2020 with our own (unit-consistent)
//     normal and position variances. It serves as the cost; its placement is wrapped below.
//
// How CGAL 5.5 runs a collapse (internal/Edge_collapse.h), which the code below relies on:
//   - edges are popped by cost; each is checked for the link condition (topology, including "both
//     ends on the border but the edge is not"), then our placement is asked, then CGAL's own fold test
//     (dihedral angles around the link), then our filter; the collapse uses the placement (the
//     filter's return value only says yes or no);
//   - visitor.OnCollapsing(profile, placement) runs before the mesh changes and
//     visitor.OnCollapsed(profile, v) right after, with v the surviving vertex index (always one of
//     profile.v0(), profile.v1(), chosen by CGAL::Euler::collapse_edge) already at the placement;
//   - edges with coincident endpoints are collapsed without the placement, filter or OnCollapsing
//     (in collect()); decimation.cpp rejects such input (zero-area faces) before we get here.
// CGAL decides which vertex *index* survives; which *id* the merged vertex carries is our choice,
// kept in `label` (CGAL vertex index -> input id): the end nearest the placement keeps its id, so a
// fixed vertex (placement = its position) always keeps its id.
// GCC warns that CGAL's per-vertex quadric property map copies an uninitialised default Eigen 4x4
// (properties_Surface_mesh.h, add_property_map with T()); the policy's initialize() writes every
// vertex's quadric before any is read. Silenced for this file only, so PD_WERROR builds pass.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Edge_collapse_visitor_base.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_probabilistic_plane_policies.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/property_map.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <utility>

namespace pd::detail {
namespace {

namespace SMS = CGAL::Surface_mesh_simplification;
using K = CGAL::Simple_cartesian<double>;
using Point = K::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using VI = Mesh::Vertex_index;
using HI = Mesh::Halfedge_index;
using FI = Mesh::Face_index;
using FaceVariance = CGAL::Constant_property_map<FI, std::pair<double, double>>;
using GHPolicies = SMS::GarlandHeckbert_probabilistic_plane_policies<Mesh, K, FaceVariance>;
using OptPoint = boost::optional<Point>;

Vec3 to_vec(const Point& p) { return Vec3(p.x(), p.y(), p.z()); }

double quality(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double l2 = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
  const double twice_area = (b - a).cross(c - a).norm();
  return l2 > 0.0 ? 2.0 * std::sqrt(3.0) * twice_area / l2 : 0.0;
}

// Everything the placement, filter, stop predicate and visitor share. CGAL copies the visitor, so
// they all hold a pointer to one State.
struct State {
  Mesh* mesh = nullptr;
  std::vector<int> label;    // CGAL vertex index -> input id of the vertex it currently is
  std::vector<char> locked;  // by input id
  bool keep_boundary = true;
  double cos_max_normal_change = 0.0;
  double min_quality = 0.0;
  double min_area = 0.0;
  int num_vertices = 0;
  std::vector<int> targets;
  std::size_t next_target = 0;
  CollapseRule rule = CollapseRule::kQuadric;
  Vec3 centre = Vec3::Zero();  // of the start mesh's bounding box (kOntoLocked's tie-break)
  CollapseRun* run = nullptr;
  Collapse pending;
  bool has_pending = false;

  const Point& point(VI v) const { return mesh->point(v); }
  bool is_border(VI v) const { return mesh->is_border(v, true); }
  bool is_locked(VI v) const { return locked[static_cast<std::size_t>(label[v.idx()])] != 0; }
  // Never moves: locked, or on the boundary (boundary vertices never move, whether or not they may
  // be removed).
  bool immobile(VI v) const { return is_locked(v) || is_border(v); }

  // A boundary vertex whose two boundary neighbours are collinear with it (straight boundary there):
  // removing it along a boundary edge keeps the boundary's shape.
  bool on_straight_boundary(VI v) const {
    for (HI h : CGAL::halfedges_around_target(v, *mesh)) {
      if (!mesh->is_border(h)) continue;
      const VI a = mesh->source(h), c = mesh->target(mesh->next(h));
      if (a == c) return false;
      const Vec3 e0 = to_vec(point(v)) - to_vec(point(a)), e1 = to_vec(point(c)) - to_vec(point(v));
      const double n0 = e0.norm(), n1 = e1.norm();
      if (!(n0 > 0.0 && n1 > 0.0) || e0.dot(e1) <= 0.0) return false;
      return e0.cross(e1).norm() <= kStraightBoundaryTolerance * n0 * n1;
    }
    return false;
  }

  // kOntoLocked: which end of the edge may be removed into the other, or none. A free (unlocked)
  // interior vertex goes into a locked neighbour; a free boundary vertex into a locked boundary
  // neighbour along a straight boundary edge. Returns {removed, kept}.
  std::optional<std::pair<VI, VI>> onto_locked(VI v0, VI v1, bool boundary_edge) const {
    for (const auto& [r, k] : {std::pair{v0, v1}, std::pair{v1, v0}}) {
      if (is_locked(r) || !is_locked(k)) continue;
      if (!is_border(r)) return std::pair{r, k};
      if (!keep_boundary && boundary_edge && on_straight_boundary(r)) return std::pair{r, k};
    }
    return std::nullopt;
  }

  // Input-id triangle of a CGAL face, canonical rotation.
  Tri tri(FI f) const {
    const HI h = mesh->halfedge(f);
    return canonical_tri(label[mesh->target(h).idx()], label[mesh->target(mesh->next(h)).idx()],
                         label[mesh->target(mesh->next(mesh->next(h))).idx()]);
  }

  // Faces incident to any of `vs`, each once, in a deterministic order (CGAL traversal order).
  std::vector<FI> faces_around(std::initializer_list<VI> vs) const {
    std::vector<FI> faces;
    for (VI v : vs)
      for (HI h : CGAL::halfedges_around_target(v, *mesh)) {
        const FI f = mesh->face(h);
        if (f == Mesh::null_face()) continue;
        if (std::find(faces.begin(), faces.end(), f) == faces.end()) faces.push_back(f);
      }
    return faces;
  }

  std::vector<Tri> sorted(const std::vector<FI>& faces) const {
    std::vector<Tri> tris;
    tris.reserve(faces.size());
    for (FI f : faces) tris.push_back(tri(f));
    std::sort(tris.begin(), tris.end());
    return tris;
  }

  CollapseSnapshot snapshot() const {
    CollapseSnapshot s;
    s.num_collapses = static_cast<int>(run->collapses.size());
    s.num_vertices = num_vertices;
    s.V = Positions::Zero(static_cast<Eigen::Index>(locked.size()), 3);
    s.alive.assign(locked.size(), 0);
    for (VI v : mesh->vertices()) {
      const int id = label[v.idx()];
      s.V.row(id) = to_vec(point(v)).transpose();
      s.alive[static_cast<std::size_t>(id)] = 1;
    }
    for (FI f : mesh->faces()) s.faces.push_back(tri(f));
    std::sort(s.faces.begin(), s.faces.end());
    return s;
  }
};

// Placement: the quadric minimiser for a free edge; a fixed end's own position otherwise.
struct Placement {
  State* s;
  const GHPolicies* gh;

  template <class Profile>
  OptPoint operator()(const Profile& profile) const {
    const VI v0 = profile.v0(), v1 = profile.v1();
    if (s->rule == CollapseRule::kOntoLocked) {
      const auto ends = s->onto_locked(v0, v1, profile.is_v0_v1_a_border() || profile.is_v1_v0_a_border());
      if (!ends) return boost::none;
      return s->point(ends->second);
    }
    const bool imm0 = s->immobile(v0), imm1 = s->immobile(v1);
    if (!imm0 && !imm1) return (*gh)(profile);
    if (imm0 && !imm1) return profile.p0();
    if (imm1 && !imm0) return profile.p1();
    // Both ends fixed: only a boundary edge on a straight stretch of boundary, when allowed, merging
    // the removable end into the other, which stays.
    if (s->keep_boundary || !(profile.is_v0_v1_a_border() || profile.is_v1_v0_a_border())) return boost::none;
    if (!s->is_locked(v0) && s->on_straight_boundary(v0)) return profile.p1();
    if (!s->is_locked(v1) && s->on_straight_boundary(v1)) return profile.p0();
    return boost::none;
  }
};

// Filter: no surviving triangle flips beyond the normal-change bound, degenerates, or gets worse
// than min(min_quality, the patch's worst quality before).
struct Filter {
  State* s;

  template <class Profile>
  OptPoint operator()(const Profile& profile, const OptPoint& placement) const {
    if (!placement) return boost::none;
    const Mesh& mesh = *s->mesh;
    const VI v0 = profile.v0(), v1 = profile.v1();
    const Vec3 q = to_vec(*placement);
    const std::vector<FI> faces = s->faces_around({v0, v1});

    double worst_before = 1.0;
    for (FI f : faces) {
      const HI h = mesh.halfedge(f);
      worst_before = std::min(worst_before, quality(to_vec(s->point(mesh.target(h))),
                                                    to_vec(s->point(mesh.target(mesh.next(h)))),
                                                    to_vec(s->point(mesh.source(h)))));
    }
    const double quality_floor = std::min(s->min_quality, worst_before);

    for (FI f : faces) {
      const HI h = mesh.halfedge(f);
      const VI c[3] = {mesh.target(h), mesh.target(mesh.next(h)), mesh.source(h)};
      int moved = 0;
      Vec3 before[3], after[3];
      for (int k = 0; k < 3; ++k) {
        before[k] = to_vec(s->point(c[k]));
        const bool end = c[k] == v0 || c[k] == v1;
        moved += end ? 1 : 0;
        after[k] = end ? q : before[k];
      }
      if (moved == 2) continue;  // the face disappears with the edge
      const Vec3 nb = (before[1] - before[0]).cross(before[2] - before[0]);
      const Vec3 na = (after[1] - after[0]).cross(after[2] - after[0]);
      const double na_norm = na.norm();
      if (!(0.5 * na_norm >= s->min_area)) return boost::none;
      if (nb.dot(na) < s->cos_max_normal_change * nb.norm() * na_norm) return boost::none;
      if (quality(after[0], after[1], after[2]) < quality_floor) return boost::none;
    }
    return placement;
  }
};

// kOntoLocked's order (see CollapseRule), as one number: the edge's length in millionths of the
// bounding-box diagonal (so that lengths equal but for rounding tie); then the kept vertex's distance
// to the centre in ten-thousandths of the diagonal; then, between equal edges into kept vertices
// equally far from the centre (a vertex on a diagonal of a square grid), the edge nearer the x axis,
// then the y axis, which is the same choice on both sides of each centre line. Edges that cannot
// collapse under the rule cost the most; the placement turns them down when they come up.
struct OntoLockedCost {
  State* s;
  double diagonal = 1.0;

  template <class Profile, class Placement>
  boost::optional<double> operator()(const Profile& profile, const Placement&) const {
    const auto ends = s->onto_locked(profile.v0(), profile.v1(), profile.is_v0_v1_a_border() || profile.is_v1_v0_a_border());
    if (!ends) return 1e12;
    const Vec3 kept = to_vec(s->point(ends->second));
    const Vec3 edge = kept - to_vec(s->point(ends->first));
    const double length = edge.norm();
    const double distance = std::min((kept - s->centre).norm() / diagonal, 1.0);
    const double off_axis =
        length > 0.0 ? (1.0 - std::abs(edge.x()) / length) + 1e-3 * (1.0 - std::abs(edge.y()) / length) : 0.0;
    return std::round(length / diagonal * 1e6) + 0.5e-4 * std::round(distance * 1e4) + 1e-5 * off_axis;
  }
};

struct StopAtTarget {
  State* s;
  template <class FT, class Profile>
  bool operator()(const FT&, const Profile&, std::size_t, std::size_t) const {
    return s->num_vertices <= s->targets.back();
  }
};

struct Recorder : SMS::Edge_collapse_visitor_base<Mesh> {
  State* s;
  explicit Recorder(State* state) : s(state) {}

  template <class Profile>
  void OnCollapsing(const Profile& profile, const OptPoint& placement) {
    if (!placement) throw std::logic_error("decimation: collapse without a placement");
    const VI v0 = profile.v0(), v1 = profile.v1();
    const Vec3 p0 = to_vec(profile.p0()), p1 = to_vec(profile.p1()), q = to_vec(*placement);
    const int a = s->label[v0.idx()], b = s->label[v1.idx()];
    const double d0 = (q - p0).squaredNorm(), d1 = (q - p1).squaredNorm();
    const bool keep0 = d0 < d1 || (d0 == d1 && a < b);
    Collapse& c = s->pending;
    c.kept = keep0 ? a : b;
    c.removed = keep0 ? b : a;
    c.kept_position_before = keep0 ? p0 : p1;
    c.removed_position = keep0 ? p1 : p0;
    c.faces_before = s->sorted(s->faces_around({v0, v1}));
    c.faces_after.clear();
    s->has_pending = true;
  }

  template <class Profile>
  void OnCollapsed(const Profile& profile, const VI& v) {
    if (!s->has_pending || (v != profile.v0() && v != profile.v1()))
      throw std::logic_error("decimation: unexpected collapse (coincident vertices?)");
    Collapse& c = s->pending;
    s->label[v.idx()] = c.kept;
    c.kept_position_after = to_vec(s->point(v));
    c.faces_after = s->sorted(s->faces_around({v}));
    s->run->collapses.push_back(std::move(c));
    s->pending = Collapse{};
    s->has_pending = false;
    --s->num_vertices;
    if (s->next_target < s->targets.size() && s->num_vertices == s->targets[s->next_target]) {
      s->run->reached.push_back(s->snapshot());
      ++s->next_target;
    }
  }
};

}  // namespace

CollapseRun run_edge_collapse(const TriMesh& input, const std::vector<char>& locked,
                              const std::vector<int>& targets, const DecimationSettings& settings,
                              CollapseRule rule) {
  const int n = input.num_vertices();
  if (targets.empty() || static_cast<int>(locked.size()) != n)
    throw std::invalid_argument("run_edge_collapse: bad arguments");

  Mesh mesh;
  mesh.reserve(static_cast<Mesh::size_type>(n), static_cast<Mesh::size_type>(3 * input.num_faces()),
               static_cast<Mesh::size_type>(input.num_faces()));
  for (int i = 0; i < n; ++i) mesh.add_vertex(Point(input.V(i, 0), input.V(i, 1), input.V(i, 2)));
  for (int f = 0; f < input.num_faces(); ++f) {
    const FI face = mesh.add_face(VI(static_cast<Mesh::size_type>(input.F(f, 0))),
                                  VI(static_cast<Mesh::size_type>(input.F(f, 1))),
                                  VI(static_cast<Mesh::size_type>(input.F(f, 2))));
    if (face == Mesh::null_face())
      throw std::invalid_argument("run_edge_collapse: face " + std::to_string(f) +
                                  " cannot be added (mesh not validated as an oriented manifold)");
  }

  double edge_sum = 0.0;
  std::size_t edge_count = 0;
  for (const auto e : mesh.edges()) {
    edge_sum += std::sqrt(CGAL::squared_distance(mesh.point(mesh.vertex(e, 0)), mesh.point(mesh.vertex(e, 1))));
    ++edge_count;
  }
  const double mean_edge = edge_count > 0 ? edge_sum / static_cast<double>(edge_count) : 0.0;
  const double diag2 = (input.V.colwise().maxCoeff() - input.V.colwise().minCoeff()).squaredNorm();

  CollapseRun run;
  State s;
  s.mesh = &mesh;
  s.label.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) s.label[static_cast<std::size_t>(i)] = i;
  s.locked = locked;
  s.keep_boundary = settings.keep_boundary;
  s.cos_max_normal_change = std::cos(settings.max_normal_change_degrees * M_PI / 180.0);
  s.min_quality = settings.min_triangle_quality;
  // 100x validate_mesh's zero-area threshold, so the coarse meshes pass it with room to spare.
  s.min_area = 1e-10 * diag2;
  s.num_vertices = n;
  s.targets = targets;
  s.rule = rule;
  s.centre = 0.5 * (input.V.colwise().maxCoeff() + input.V.colwise().minCoeff()).transpose();
  s.run = &run;

  // Discontinuity multiplier 100 (CGAL's default) on boundary-edge quadrics; immaterial where
  // boundary vertices are fixed.
  const GHPolicies gh(mesh, 100.0,
                      FaceVariance(std::make_pair(settings.normal_variance,
                                                  settings.position_variance * mean_edge * mean_edge)));
  const Placement placement{&s, &gh};
  const Filter filter{&s};
  const StopAtTarget stop{&s};
  Recorder recorder(&s);

  if (rule == CollapseRule::kOntoLocked) {
    const OntoLockedCost cost{&s, std::max(std::sqrt(diag2), 1e-300)};
    SMS::edge_collapse(mesh, stop,
                       CGAL::parameters::get_cost(cost).get_placement(placement).filter(filter).visitor(recorder));
  } else {
    SMS::edge_collapse(mesh, stop,
                       CGAL::parameters::get_cost(gh).get_placement(placement).filter(filter).visitor(recorder));
  }

  run.final_state = s.snapshot();
  return run;
}

}  // namespace pd::detail
