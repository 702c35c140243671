#include "hierarchy/decimation.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <string>

#include "geometry/topology.h"
#include "hierarchy/edge_collapse_cgal.h"
#include "util/input_error.h"

namespace pd {

Tri canonical_tri(int a, int b, int c) {
  if (b < a && b < c) return {b, c, a};
  if (c < a && c < b) return {c, a, b};
  return {a, b, c};
}

std::vector<Tri> sorted_tris(const Faces& F) {
  std::vector<Tri> tris;
  tris.reserve(static_cast<std::size_t>(F.rows()));
  for (Eigen::Index f = 0; f < F.rows(); ++f) tris.push_back(canonical_tri(F(f, 0), F(f, 1), F(f, 2)));
  std::sort(tris.begin(), tris.end());
  return tris;
}

namespace {

std::string level_name(int l, int L) {
  std::string name = "level " + std::to_string(l);
  if (l == L) name += " (finest)";
  else if (l == 0) name += " (coarsest)";
  return name;
}

// Union-find over face corners.
struct Corners {
  std::vector<int> parent;
  explicit Corners(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int x) {
    while (parent[static_cast<std::size_t>(x)] != x) {
      parent[static_cast<std::size_t>(x)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
      x = parent[static_cast<std::size_t>(x)];
    }
    return x;
  }
  void join(int a, int b) { parent[static_cast<std::size_t>(find(a))] = find(b); }
};

// validate_mesh checks edges; this checks vertices: the faces around each vertex must form a single
// fan (connected through edges at that vertex), or a halfedge mesh cannot hold it.
// Requires a mesh that passed validate_mesh.
void check_manifold_vertices(const TriMesh& mesh, const std::string& what) {
  const Faces& F = mesh.F;
  const int m = mesh.num_faces();
  struct Side {
    std::uint64_t key;
    int corner_lo, corner_hi;  // corners (3 f + k) of the edge's lower and higher vertex in face f
  };
  std::vector<Side> sides;
  sides.reserve(3 * static_cast<std::size_t>(m));
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      const int ca = 3 * f + k, cb = 3 * f + (k + 1) % 3;
      const auto lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
      sides.push_back({lo << 32 | hi, a < b ? ca : cb, a < b ? cb : ca});
    }
  std::sort(sides.begin(), sides.end(), [](const Side& x, const Side& y) {
    return x.key != y.key ? x.key < y.key : x.corner_lo < y.corner_lo;
  });
  Corners corners(3 * static_cast<std::size_t>(m));
  for (std::size_t i = 0; i + 1 < sides.size(); ++i)
    if (sides[i].key == sides[i + 1].key) {
      corners.join(sides[i].corner_lo, sides[i + 1].corner_lo);
      corners.join(sides[i].corner_hi, sides[i + 1].corner_hi);
    }
  const int n = mesh.num_vertices();
  std::vector<int> root(static_cast<std::size_t>(n), -1), fans(static_cast<std::size_t>(n), 0);
  std::vector<std::pair<int, int>> vertex_roots;  // (vertex, root), deduplicated below
  vertex_roots.reserve(3 * static_cast<std::size_t>(m));
  for (int c = 0; c < 3 * m; ++c) vertex_roots.emplace_back(F.data()[c], corners.find(c));
  std::sort(vertex_roots.begin(), vertex_roots.end());
  vertex_roots.erase(std::unique(vertex_roots.begin(), vertex_roots.end()), vertex_roots.end());
  for (const auto& vr : vertex_roots) ++fans[static_cast<std::size_t>(vr.first)];
  for (int v = 0; v < n; ++v)
    if (fans[static_cast<std::size_t>(v)] > 1)
      throw InputError(what + ": vertex " + std::to_string(v) + " is non-manifold: its faces form " +
                       std::to_string(fans[static_cast<std::size_t>(v)]) +
                       " separate fans (a manifold vertex has one)");
}

// Boundary vertices that can never be removed when keep_boundary is off: those where the boundary
// turns (corners, curved stretches). Removing straight-stretch vertices never changes the directions
// of the boundary edges at a corner, so this set is fixed for the whole run.
std::vector<char> boundary_turns(const TriMesh& mesh) {
  const Faces& F = mesh.F;
  struct Directed {
    std::uint64_t key;
    int from, to;
  };
  std::vector<Directed> d;
  d.reserve(3 * static_cast<std::size_t>(F.rows()));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      const auto lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
      d.push_back({lo << 32 | hi, a, b});
    }
  std::sort(d.begin(), d.end(), [](const Directed& x, const Directed& y) { return x.key < y.key; });
  const std::size_t n = static_cast<std::size_t>(mesh.num_vertices());
  std::vector<int> next(n, -1), prev(n, -1);
  for (std::size_t i = 0; i < d.size();) {
    std::size_t j = i + 1;
    while (j < d.size() && d[j].key == d[i].key) ++j;
    if (j - i == 1) {  // boundary edge, running from -> to along its face
      next[static_cast<std::size_t>(d[i].from)] = d[i].to;
      prev[static_cast<std::size_t>(d[i].to)] = d[i].from;
    }
    i = j;
  }
  std::vector<char> turns(n, 0);
  for (std::size_t v = 0; v < n; ++v) {
    if (next[v] < 0) continue;
    const Vec3 a = mesh.V.row(prev[v]).transpose(), b = mesh.V.row(static_cast<Eigen::Index>(v)).transpose(),
               c = mesh.V.row(next[v]).transpose();
    const Vec3 e0 = b - a, e1 = c - b;
    const bool straight = prev[v] != next[v] && e0.dot(e1) > 0.0 &&
                          e0.cross(e1).norm() <= detail::kStraightBoundaryTolerance * e0.norm() * e1.norm();
    turns[v] = straight ? 0 : 1;
  }
  return turns;
}

// Every id v of `tris` replaced by map[v]; an increasing map keeps canonical rotations and sorted order.
void relabel(std::vector<Tri>& tris, const std::vector<int>& map) {
  for (Tri& t : tris)
    for (int& v : t) v = map[static_cast<std::size_t>(v)];
}

// The same for every id of a collapse record.
void relabel(Collapse& c, const std::vector<int>& map) {
  c.removed = map[static_cast<std::size_t>(c.removed)];
  c.kept = map[static_cast<std::size_t>(c.kept)];
  relabel(c.faces_before, map);
  relabel(c.faces_after, map);
}

// Builds level l's data from the run's state after its collapses. `finer_map` maps finest ids to
// level l+1 ids (-1 if not there); `collapses` is the run's records for this level, level l+1 ids.
Level assemble_level(const detail::CollapseSnapshot& state, const std::vector<int>& finer_to_finest,
                     const std::vector<int>& finer_map, std::vector<Collapse> collapses,
                     std::vector<int>& this_map) {
  const int n_finest = static_cast<int>(state.alive.size());
  Level level;
  this_map.assign(static_cast<std::size_t>(n_finest), -1);
  for (int i = 0; i < n_finest; ++i)
    if (state.alive[static_cast<std::size_t>(i)]) {
      this_map[static_cast<std::size_t>(i)] = static_cast<int>(level.to_finest.size());
      level.to_finest.push_back(i);
    }
  const int n = static_cast<int>(level.to_finest.size());
  level.mesh.V.resize(n, 3);
  for (int i = 0; i < n; ++i) level.mesh.V.row(i) = state.V.row(level.to_finest[static_cast<std::size_t>(i)]);
  // The maps are increasing, so canonical rotation and sorted order carry over unchanged.
  level.mesh.F.resize(static_cast<Eigen::Index>(state.faces.size()), 3);
  for (std::size_t f = 0; f < state.faces.size(); ++f)
    for (int k = 0; k < 3; ++k)
      level.mesh.F(static_cast<Eigen::Index>(f), k) = this_map[static_cast<std::size_t>(state.faces[f][static_cast<std::size_t>(k)])];

  level.coarse_to_fine.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    level.coarse_to_fine[static_cast<std::size_t>(i)] = finer_map[static_cast<std::size_t>(level.to_finest[static_cast<std::size_t>(i)])];
  level.fine_to_coarse.resize(finer_to_finest.size());
  for (std::size_t j = 0; j < finer_to_finest.size(); ++j)
    level.fine_to_coarse[j] = this_map[static_cast<std::size_t>(finer_to_finest[j])];

  level.collapses = std::move(collapses);
  return level;
}

// The run's ids are those of the mesh it started from, level l+1's; the rest of build_levels works
// in finest ids. `to_finest` is level l+1's map (increasing, so canonical rotations and sorted face
// lists carry over unchanged).
detail::CollapseSnapshot snapshot_in_finest_ids(const detail::CollapseSnapshot& s, const std::vector<int>& to_finest,
                                                int n_finest) {
  detail::CollapseSnapshot out;
  out.num_collapses = s.num_collapses;
  out.num_vertices = s.num_vertices;
  out.V = Positions::Zero(n_finest, 3);
  out.alive.assign(static_cast<std::size_t>(n_finest), 0);
  for (std::size_t i = 0; i < s.alive.size(); ++i) {
    const int f = to_finest[i];
    out.V.row(f) = s.V.row(static_cast<Eigen::Index>(i));
    out.alive[static_cast<std::size_t>(f)] = s.alive[i];
  }
  out.faces = s.faces;
  relabel(out.faces, to_finest);
  return out;
}

// build_levels with prescribed vertex sets (LevelSettings::kept_vertices): each level decimated from
// the one above it in a run of its own, its kept vertices locked. `levels` has the finest level set;
// `locked` (pins) and `fixed` (pins and the boundary vertices never removed) are by finest id.
void build_kept_levels(std::vector<Level>& levels, const std::vector<int>& targets, const std::vector<char>& locked,
                       const std::vector<char>& fixed_anyway, const LevelSettings& settings) {
  const int L = static_cast<int>(targets.size());
  const std::size_t n = locked.size();
  std::vector<int> finer_map(n);
  std::iota(finer_map.begin(), finer_map.end(), 0);
  for (int k = 0; k < L; ++k) {
    const int l = L - 1 - k, t = targets[static_cast<std::size_t>(k)];
    const std::string name = level_name(l, L);
    const Level& finer = levels[static_cast<std::size_t>(l) + 1];
    std::vector<char> keep(n, 0);
    for (int id : settings.kept_vertices[static_cast<std::size_t>(k)]) {
      if (id < 0 || static_cast<std::size_t>(id) >= n || finer_map[static_cast<std::size_t>(id)] < 0)
        throw InputError(name + ": kept vertex " + std::to_string(id) + " is not a vertex of level " +
                         std::to_string(l + 1));
      keep[static_cast<std::size_t>(id)] = 1;
    }
    std::vector<char> fixed(finer.to_finest.size(), 0);
    for (std::size_t i = 0; i < fixed.size(); ++i) {
      const auto f = static_cast<std::size_t>(finer.to_finest[i]);
      fixed[i] = (locked[f] || keep[f]) ? 1 : 0;
    }
    detail::CollapseRun run;
    try {
      run = detail::run_edge_collapse(finer.mesh, fixed, {t}, settings.decimation, detail::CollapseRule::kOntoLocked);
    } catch (const std::invalid_argument& e) {
      throw InputError(name + ": " + e.what());
    }
    if (run.reached.empty()) {
      std::string left;  // the first few vertices that could not be removed, finest ids
      int count = 0;
      for (std::size_t i = 0; i < fixed.size(); ++i)
        if (run.final_state.alive[i] && !fixed[i] && ++count <= 5)
          left += (count > 1 ? ", " : "") + std::to_string(finer.to_finest[i]);
      throw InputError(name + ": decimation of level " + std::to_string(l + 1) + "'s " +
                       std::to_string(finer.mesh.num_vertices()) + " vertices to its kept vertex set stopped at " +
                       std::to_string(run.final_state.num_vertices) + ", above the target of " + std::to_string(t) +
                       ": no collapse is left that keeps the mesh manifold, the triangles unflipped and well-shaped "
                       "and removes vertex " + left + (count > 5 ? " or " + std::to_string(count - 5) + " more" : ""));
    }
    const detail::CollapseSnapshot state = snapshot_in_finest_ids(run.reached.front(), finer.to_finest, static_cast<int>(n));
    for (std::size_t f = 0; f < n; ++f)
      if (state.alive[f] && !keep[f] && !fixed_anyway[f])
        throw InputError(name + ": the target of " + std::to_string(t) + " vertices leaves vertex " + std::to_string(f) +
                         ", which is neither kept nor fixed (the target must count the kept and fixed vertices)");
    // The run started from level l+1's mesh: its records are in level l+1 ids already.
    std::vector<Collapse> records(run.collapses.begin(), run.collapses.begin() + state.num_collapses);
    std::vector<int> this_map;
    levels[static_cast<std::size_t>(l)] = assemble_level(state, finer.to_finest, finer_map, std::move(records), this_map);
    finer_map = std::move(this_map);
  }
}

}  // namespace

std::vector<char> fixed_vertices(const TriMesh& mesh, const std::vector<int>& locked, bool keep_boundary) {
  const Topology topo = build_topology(mesh);
  const std::vector<char> turns = keep_boundary ? std::vector<char>() : boundary_turns(mesh);
  std::vector<char> fixed(static_cast<std::size_t>(mesh.num_vertices()), 0);
  for (std::size_t u = 0; u < fixed.size(); ++u)
    fixed[u] = topo.boundary_vertex[u] != 0 && (keep_boundary || turns[u] != 0) ? 1 : 0;
  for (int id : locked) fixed[static_cast<std::size_t>(id)] = 1;
  return fixed;
}

std::vector<Level> build_levels(const TriMesh& finest, const LevelSettings& settings) {
  const DecimationSettings& ds = settings.decimation;
  const int n = finest.num_vertices();
  std::vector<int> targets = settings.target_vertex_counts;  // level L-1 first
  const bool by_ratio = targets.empty();
  const int L = by_ratio ? settings.coarser_levels : static_cast<int>(targets.size());
  if (by_ratio) {
    if (!(settings.coarser_levels >= 0))
      throw InputError("level settings: coarser_levels must be >= 0, got " + std::to_string(settings.coarser_levels));
    if (!(std::isfinite(settings.ratio) && settings.ratio > 1.0))
      throw InputError("level settings: ratio must be > 1, got " + std::to_string(settings.ratio));
  }
  if (!(ds.max_normal_change_degrees > 0.0 && ds.max_normal_change_degrees <= 180.0) ||
      !(ds.min_triangle_quality >= 0.0 && ds.min_triangle_quality < 1.0) || !(ds.normal_variance > 0.0) ||
      !(ds.position_variance >= 0.0) || !(ds.count_tolerance >= 0.0))
    throw InputError("level settings: decimation settings out of range (max_normal_change_degrees in (0, 180], "
                     "min_triangle_quality in [0, 1), normal_variance > 0, position_variance >= 0, "
                     "count_tolerance >= 0)");

  const std::string finest_name = level_name(L, L);
  validate_mesh(finest, finest_name);
  check_manifold_vertices(finest, finest_name);

  std::vector<char> locked(static_cast<std::size_t>(n), 0);
  for (int id : settings.locked_vertices) {
    if (id < 0 || id >= n)
      throw InputError(finest_name + ": locked vertex " + std::to_string(id) + " does not exist (the mesh has " +
                       std::to_string(n) + " vertices)");
    locked[static_cast<std::size_t>(id)] = 1;
  }
  const Topology topo = build_topology(finest);
  const std::vector<char> fixed = fixed_vertices(finest, settings.locked_vertices, ds.keep_boundary);
  int num_locked = 0, num_fixed = 0;
  for (std::size_t u = 0; u < fixed.size(); ++u) {
    num_locked += locked[u] != 0 ? 1 : 0;
    num_fixed += fixed[u] != 0 ? 1 : 0;
  }
  const int num_fixed_boundary = num_fixed - num_locked;
  const std::string fixed_detail =
      std::to_string(num_fixed) + " vertices are never removed (" + std::to_string(num_locked) + " locked, " +
      std::to_string(num_fixed_boundary) + " other " +
      (ds.keep_boundary ? "boundary vertices" : "boundary vertices where the boundary is not straight") + ")";

  if (by_ratio)
    for (int l = L - 1; l >= 0; --l)
      targets.push_back(static_cast<int>(std::lround(static_cast<double>(n) / std::pow(settings.ratio, L - l))));
  const int min_vertices = topo.closed() ? 4 : 3;
  for (int k = 0; k < L; ++k) {
    const int l = L - 1 - k, t = targets[static_cast<std::size_t>(k)];
    const int above = k == 0 ? n : targets[static_cast<std::size_t>(k - 1)];
    const std::string name = level_name(l, L);
    if (t >= above)
      throw InputError(name + ": target of " + std::to_string(t) + " vertices is not below level " +
                       std::to_string(l + 1) + "'s " + std::to_string(above) +
                       " (targets must decrease from the finest level)");
    if (t < min_vertices)
      throw InputError(name + ": target of " + std::to_string(t) + " vertices is too few (at least " +
                       std::to_string(min_vertices) + " for " + (topo.closed() ? "a closed" : "an open") +
                       " mesh); the finest mesh has " + std::to_string(n));
    if (t < num_fixed)
      throw InputError(name + ": target of " + std::to_string(t) + " vertices cannot be reached from " +
                       std::to_string(n) + ": " + fixed_detail);
  }

  std::vector<Level> levels(static_cast<std::size_t>(L) + 1);
  Level& top = levels[static_cast<std::size_t>(L)];
  top.mesh = finest;
  top.to_finest.resize(static_cast<std::size_t>(n));
  std::iota(top.to_finest.begin(), top.to_finest.end(), 0);
  if (L == 0) return levels;
  if (!settings.kept_vertices.empty()) {
    if (by_ratio || settings.kept_vertices.size() != targets.size())
      throw InputError("level settings: kept_vertices needs one list per entry of target_vertex_counts");
    build_kept_levels(levels, targets, locked, fixed, settings);
    return levels;
  }

  detail::CollapseRun run;
  try {
    run = detail::run_edge_collapse(finest, locked, targets, ds);
  } catch (const std::invalid_argument& e) {
    throw InputError(finest_name + ": " + e.what());
  }

  std::vector<int> finer_map(static_cast<std::size_t>(n));
  std::iota(finer_map.begin(), finer_map.end(), 0);
  int first_record = 0;
  for (int k = 0; k < L; ++k) {
    const int l = L - 1 - k, t = targets[static_cast<std::size_t>(k)];
    const detail::CollapseSnapshot* state = nullptr;
    if (static_cast<std::size_t>(k) < run.reached.size()) {
      state = &run.reached[static_cast<std::size_t>(k)];
    } else if (static_cast<std::size_t>(k) == run.reached.size() &&
               run.final_state.num_vertices <= t + static_cast<int>(std::floor(ds.count_tolerance * t))) {
      state = &run.final_state;
    } else {
      const bool this_level = static_cast<std::size_t>(k) == run.reached.size();
      throw InputError(level_name(l, L) + ": decimation of " + std::to_string(n) + " vertices stopped at " +
                       std::to_string(run.final_state.num_vertices) +
                       (this_level ? std::string() : " (within tolerance of level " + std::to_string(l + 1) + ")") +
                       ", above the target of " + std::to_string(t) + " (tolerance " +
                       std::to_string(static_cast<int>(std::lround(100.0 * ds.count_tolerance))) +
                       "%): no collapse is left that keeps the mesh manifold, the triangles unflipped and "
                       "well-shaped, and the fixed vertices in place; " + fixed_detail);
    }
    std::vector<Collapse> records(run.collapses.begin() + first_record, run.collapses.begin() + state->num_collapses);
    first_record = state->num_collapses;
    for (Collapse& c : records) relabel(c, finer_map);  // the run's ids are finest ids
    std::vector<int> this_map;
    const Level& finer = levels[static_cast<std::size_t>(l) + 1];
    levels[static_cast<std::size_t>(l)] = assemble_level(*state, finer.to_finest, finer_map, std::move(records), this_map);
    finer_map = std::move(this_map);
  }
  return levels;
}

Decimation decimate(const TriMesh& fine, int target_vertices, const std::vector<int>& locked,
                    const DecimationSettings& settings) {
  LevelSettings ls;
  ls.target_vertex_counts = {target_vertices};
  ls.locked_vertices = locked;
  ls.decimation = settings;
  std::vector<Level> levels = build_levels(fine, ls);
  Level& coarse = levels.front();
  Decimation d;
  d.coarse = std::move(coarse.mesh);
  d.coarse_to_fine = std::move(coarse.coarse_to_fine);
  d.fine_to_coarse = std::move(coarse.fine_to_coarse);
  d.collapses = std::move(coarse.collapses);
  return d;
}

}  // namespace pd
