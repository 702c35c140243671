#include "hierarchy/safe_upsampling.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <stdexcept>
#include <string>

#include "hierarchy/contact_submesh.h"
#include "hierarchy/patch_relaxation.h"
#include "hierarchy/submesh_relaxation.h"
#include "physics/contact/start_check.h"
#include "hierarchy/strain_projection.h"
#include "physics/strain_limit.h"

namespace pd {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

constexpr double kPi = 3.14159265358979323846;

Vec3 row(const Positions& x, int i) { return x.row(i).transpose(); }

// A unit vector from two raw mt19937_64 draws (uniform on the sphere: z uniform in [-1, 1], angle
// uniform), by hand so that the same seed gives the same directions with every standard library.
Vec3 random_direction(std::mt19937_64& rng) {
  const double u = static_cast<double>(rng() >> 11) * 0x1.0p-53;  // [0, 1)
  const double v = static_cast<double>(rng() >> 11) * 0x1.0p-53;
  const double z = 2.0 * u - 1.0, phi = 2.0 * kPi * v;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

// The mesh of the present vertices (those the current faces use: every vertex of level l and the
// ones restored so far), renumbered 0..m-1.
struct CompactMesh {
  std::vector<int> global;     // compact id -> level l+1 id
  std::vector<int> compact;    // level l+1 id -> compact id, -1 if absent
  ContactPrimitives prims;
  Positions rest;              // level l+1 rest positions of the present vertices
};

CompactMesh compact_mesh(const UpsamplingLevel& level, const std::set<Tri>& faces) {
  Faces F(static_cast<Eigen::Index>(faces.size()), 3);
  int f = 0;
  for (const Tri& t : faces) F.row(f++) << t[0], t[1], t[2];
  ContactSubmesh sub = contact_submesh(F, level.vertex_object, level.object_self_contact);
  CompactMesh m;
  m.compact.assign(static_cast<std::size_t>(level.fine.V.rows()), -1);
  for (std::size_t k = 0; k < sub.vertices.size(); ++k) m.compact[static_cast<std::size_t>(sub.vertices[k])] = static_cast<int>(k);
  m.rest = gather_rows(level.fine.V, sub.vertices);
  m.global = std::move(sub.vertices);
  m.prims = std::move(sub.prims);
  return m;
}

std::optional<GroundPlane> compact_ground(const UpsamplingLevel& level, const CompactMesh& m) {
  if (!level.ground) return std::nullopt;
  GroundPlane g = *level.ground;
  g.vertex_collides.resize(m.global.size());
  for (std::size_t k = 0; k < m.global.size(); ++k)
    g.vertex_collides[k] = level.ground->vertex_collides[static_cast<std::size_t>(m.global[k])];
  return g;
}

double mean_edge_length(const TriMesh& mesh) {
  double sum = 0.0;
  for (int f = 0; f < mesh.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) sum += (mesh.V.row(mesh.F(f, k)) - mesh.V.row(mesh.F(f, (k + 1) % 3))).norm();
  return mesh.F.rows() > 0 ? sum / (3.0 * static_cast<double>(mesh.F.rows())) : 1.0;
}

// Is the patch of a split valid with the restored vertex at x (positions by level l+1 id)? See the
// header, step 3: no touching or crossing primitives within the patch, and every new sliver face
// (kept, restored, a) facing the same side as its neighbours across the edges at a. Only the slivers
// depend on the perturbation's direction (the other faces of the restored vertex are copies of
// triangles at its kept vertex, moved by eps), and a sliver opened to the wrong side folds onto its
// neighbours.
bool patch_valid(const Collapse& c, const Positions& x, double tolerance) {
  auto has = [](const Tri& t, int v) { return t[0] == v || t[1] == v || t[2] == v; };
  auto normal = [&](const Tri& t) -> Vec3 {
    return (row(x, t[1]) - row(x, t[0])).cross(row(x, t[2]) - row(x, t[0]));
  };

  for (const Tri& t : c.faces_before) {
    if (!has(t, c.removed) || !has(t, c.kept)) continue;
    const int a = t[0] != c.removed && t[0] != c.kept ? t[0] : (t[1] != c.removed && t[1] != c.kept ? t[1] : t[2]);
    Vec3 reference = Vec3::Zero();
    for (const Tri& u : c.faces_before)
      if (u != t && has(u, a) && (has(u, c.kept) || has(u, c.removed))) {
        const Vec3 nu = normal(u);
        if (nu.norm() > 0.0) reference += nu.normalized();
      }
    const Vec3 n = normal(t);
    const double e1 = (row(x, t[1]) - row(x, t[0])).norm(), e2 = (row(x, t[2]) - row(x, t[0])).norm();
    if (!(n.norm() > 1e-12 * e1 * e2)) return false;
    if (reference.norm() > 0.0 && !(n.dot(reference) > 0.0)) return false;
  }
  Faces F(static_cast<Eigen::Index>(c.faces_before.size()), 3);
  for (std::size_t f = 0; f < c.faces_before.size(); ++f)
    F.row(static_cast<Eigen::Index>(f)) << c.faces_before[f][0], c.faces_before[f][1], c.faces_before[f][2];
  const ContactSubmesh patch = contact_submesh(F, {}, {1});
  const ContactPrimitives& prims = patch.prims;
  const std::vector<int>& ids = patch.vertices;
// Only what involves the restored vertex counts: a pair elsewhere in the patch that was already
  // that close (left by an earlier stop) is no reason to reject a direction, and no direction fixes it.
  const int j = patch.local(c.removed);
  int total = 0;
  find_start_violations(prims, gather_rows(x, ids), tolerance, 0, &total);
  if (total == 0) return true;
  for (const StartViolation& v : find_start_violations(prims, gather_rows(x, ids), tolerance, total)) {
    const bool a_has = v.kind == StartViolation::Kind::PointTriangle ? v.a == j : prims.edges[static_cast<std::size_t>(v.a)][0] == j || prims.edges[static_cast<std::size_t>(v.a)][1] == j;
    const bool b_has = v.kind == StartViolation::Kind::EdgeEdge
                           ? prims.edges[static_cast<std::size_t>(v.b)][0] == j || prims.edges[static_cast<std::size_t>(v.b)][1] == j
                           : (prims.faces(v.b, 0) == j || prims.faces(v.b, 1) == j || prims.faces(v.b, 2) == j);
    if (a_has || b_has) return false;
  }
  return true;
}

void check_sizes(const UpsamplingLevel& level, const Positions& x_coarse, const Positions& target) {
  const auto nf = static_cast<std::size_t>(level.fine.V.rows());
  const auto nc = level.collapses.coarse_to_fine.size();
  auto fail = [](const std::string& what) { throw std::invalid_argument("safe upsampling: " + what); };
  if (static_cast<std::size_t>(x_coarse.rows()) != nc || x_coarse.cols() != 3)
    fail("coarse positions must be (" + std::to_string(nc) + ", 3)");
  if (static_cast<std::size_t>(target.rows()) != nf || target.cols() != 3)
    fail("targets must be (" + std::to_string(nf) + ", 3)");
  if (level.vertex_object.size() != nf || level.vertex_fixed.size() != nf)
    fail("vertex_object and vertex_fixed need one entry per fine vertex");
  if (level.face_strain_limit.size() != static_cast<std::size_t>(level.fine.F.rows()))
    fail("face_strain_limit needs one entry per fine face");
  if (level.ground && level.ground->vertex_collides.size() != nf)
    fail("ground.vertex_collides needs one entry per fine vertex");
  for (int id : level.collapses.coarse_to_fine)
    if (id < 0 || static_cast<std::size_t>(id) >= nf) fail("coarse_to_fine id out of range");
}

// The marked vertices of m (compact ids) and their one-ring, without the fixed ones: what a
// relaxation may move.
std::vector<int> movable_ring(const CompactMesh& m, const std::vector<char>& marked, const std::vector<char>& vertex_fixed) {
  const std::vector<char> grown = grow_by_faces(m.prims.faces, marked);
  std::vector<int> free;
  for (std::size_t v = 0; v < grown.size(); ++v)
    if (grown[v] && !vertex_fixed[static_cast<std::size_t>(m.global[v])]) free.push_back(static_cast<int>(v));
  return free;
}

// Largest sigma_max over the faces with a limit (> 0) in `limit` (one per row of F), at x.
// StrainLimitTerm::max_stretch depends only on the faces and rest shape, not on the settings.
double max_stretch_of(const Faces& F, const Positions& rest, const std::vector<double>& limit, const Positions& x) {
  std::vector<int> rows;
  for (int f = 0; f < F.rows(); ++f)
    if (limit[static_cast<std::size_t>(f)] > 0.0) rows.push_back(f);
  if (rows.empty()) return 0.0;
  Faces limited(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t k = 0; k < rows.size(); ++k) limited.row(static_cast<Eigen::Index>(k)) = F.row(rows[k]);
  const StrainLimitTerm term(limited, rest, StrainLimitSettings::from(1.1, 1.0, 1.0));
  return term.max_stretch(stacked(x));
}

// The first limit that x's stretch reaches or exceeds on a face it limits, as (sigma_max, limit) of
// that group of faces; nullopt when every limited face is below its limit (the strain-limit energy of
// the level's solve is finite only then).
std::optional<std::pair<double, double>> strain_limit_violation(const Faces& F, const Positions& rest,
                                                                const std::vector<double>& limit, const Positions& x) {
  std::map<double, std::vector<int>> by_limit;
  for (int f = 0; f < F.rows(); ++f)
    if (limit[static_cast<std::size_t>(f)] > 0.0) by_limit[limit[static_cast<std::size_t>(f)]].push_back(f);
  for (const auto& [s, rows] : by_limit) {
    std::vector<double> only(limit.size(), 0.0);  // this group's faces alone
    for (int f : rows) only[static_cast<std::size_t>(f)] = s;
    const double sigma = max_stretch_of(F, rest, only, x);
    if (sigma >= s) return std::make_pair(sigma, s);
  }
  return std::nullopt;
}

}  // namespace

Positions safe_upsample(const UpsamplingLevel& level, const Positions& x_coarse, const Positions& target,
                        const UpsamplingSettings& settings, UpsamplingReport* report_out) {
  const auto clock_start = std::chrono::steady_clock::now();
  check_sizes(level, x_coarse, target);
  UpsamplingReport report;
  const int nf = static_cast<int>(level.fine.V.rows());
  const double scale = mean_edge_length(level.fine);

  // The dynamic mesh: level l in level l+1 ids.
  Positions x = Positions::Zero(nf, 3);
  for (std::size_t c = 0; c < level.collapses.coarse_to_fine.size(); ++c)
    x.row(level.collapses.coarse_to_fine[c]) = x_coarse.row(static_cast<Eigen::Index>(c));
  std::set<Tri> faces;
  for (int f = 0; f < level.coarse_faces.rows(); ++f) {
    const auto& c2f = level.collapses.coarse_to_fine;
    faces.insert(canonical_tri(c2f[static_cast<std::size_t>(level.coarse_faces(f, 0))],
                               c2f[static_cast<std::size_t>(level.coarse_faces(f, 1))],
                               c2f[static_cast<std::size_t>(level.coarse_faces(f, 2))]));
  }

  // The compact mesh of the current faces. A batch's mesh after its splits is the next batch's mesh
  // before them (advancement and relaxation move vertices, not faces), so each is built once.
  std::optional<CompactMesh> current;
  if (!level.contact) {
    // Nothing can intersect: the upsampled state is the prolongation itself, on level l+1's mesh.
    faces.clear();
    for (int f = 0; f < level.fine.F.rows(); ++f)
      faces.insert(canonical_tri(level.fine.F(f, 0), level.fine.F(f, 1), level.fine.F(f, 2)));
    x = target;
  } else {
    current = compact_mesh(level, faces);
    const std::optional<GroundPlane> g0 = compact_ground(level, *current);
    report.coarse_gap = std::min(scale, min_contact_gap(current->prims, gather_rows(x, current->global), level.offset,
                                                        scale, g0 ? &*g0 : nullptr));
  }
  const double min_gap = settings.min_gap_fraction * report.coarse_gap;
  const double g_ref = report.coarse_gap > 0.0 ? report.coarse_gap : scale;

  // Intermediate targets. Between batches the mesh has an intermediate connectivity of the
  // decimation, and vertex v's rest position there is q_v = kept_position_after of the last collapse
  // not yet undone that kept v (v's level-l+1 rest position when there is none). Aiming every vertex
  // at its FINAL target while the connectivity is intermediate folds faces (a kept vertex at its fine
  // position can lie outside the fan of the vertex it is about to release). So each batch aims at
  // the intermediate rest shape carried into the deformed shape: target_v + A_v (q_v - rest_v), A_v
  // the deformation of v's coarse face (ShellProlongation::vertex_deformations: with the rotation
  // alone, a squashed sphere's intermediate shapes folded and splits found no valid perturbation);
  // after the last batch no collapse is pending and these are the final targets.
  const std::vector<Collapse>& records = level.collapses.collapses;
  std::vector<std::vector<int>> kept_in(static_cast<std::size_t>(nf));  // collapse ids, increasing
  for (std::size_t k = 0; k < records.size(); ++k) kept_in[static_cast<std::size_t>(records[k].kept)].push_back(static_cast<int>(k));
  std::vector<std::size_t> pending(static_cast<std::size_t>(nf));
  for (int v = 0; v < nf; ++v) pending[static_cast<std::size_t>(v)] = kept_in[static_cast<std::size_t>(v)].size();
  const std::vector<Mat3> deformations =
      level.to_next ? level.to_next->vertex_deformations(x_coarse) : std::vector<Mat3>(static_cast<std::size_t>(nf), Mat3::Identity());
  auto intermediate_rest = [&](int v) -> Vec3 {
    const std::size_t p = pending[static_cast<std::size_t>(v)];
    return p == 0 ? row(level.fine.V, v)
                  : records[static_cast<std::size_t>(kept_in[static_cast<std::size_t>(v)][p - 1])].kept_position_after;
  };
  auto intermediate_target = [&](int v) -> Vec3 {
    return row(target, v) + deformations[static_cast<std::size_t>(v)] * (intermediate_rest(v) - row(level.fine.V, v));
  };

  static const std::vector<std::vector<int>> kNoBatches;
  for (const std::vector<int>& batch : level.contact ? level.collapses.batches : kNoBatches) {
    ++report.batches;
    const auto perturb_start = Clock::now();
    // 1. The gaps of the current mesh bound the perturbations: a restored vertex starts as a copy of
    // its kept vertex i, so its pairs start where i's pairs are. Pairs that lie entirely within the
    // patch are left to the exact local check (patch_valid), so only pairs reaching outside it count.
    // Gaps are looked at up to a tenth of an edge: beyond that a perturbation of 0.01 of it (1e-3
    // edge) is small enough, and a radius of a whole edge made every neighbour a pair (measured: the
    // pair search then took 65-92% of an upsampling).
    const double reach = 0.1 * scale;
    std::vector<double> kept_gap(batch.size(), reach);
    {
      const CompactMesh& m = *current;
      const std::optional<GroundPlane> gp = compact_ground(level, m);
      std::vector<int> patch_of(m.global.size(), -1), split_of_kept(m.global.size(), -1);
      for (std::size_t b = 0; b < batch.size(); ++b) {
        const Collapse& c = records[static_cast<std::size_t>(batch[b])];
        split_of_kept[static_cast<std::size_t>(m.compact[static_cast<std::size_t>(c.kept)])] = static_cast<int>(b);
        for (const Tri& t : c.faces_after)
          for (int v : t) patch_of[static_cast<std::size_t>(m.compact[static_cast<std::size_t>(v)])] = static_cast<int>(b);
      }
      for (const PairGap& p : pair_gaps(m.prims, gather_rows(x, m.global), level.offset, reach, gp ? &*gp : nullptr))
        for (int v : p.stencil) {
          if (v < 0) continue;
          const int b = split_of_kept[static_cast<std::size_t>(v)];
          if (b < 0) continue;
          const bool leaves_patch = std::any_of(p.stencil.begin(), p.stencil.end(), [&](int u) {
            return u < 0 || patch_of[static_cast<std::size_t>(u)] != b;
          });
          if (leaves_patch) kept_gap[static_cast<std::size_t>(b)] = std::min(kept_gap[static_cast<std::size_t>(b)], p.gap);
        }
      for (std::size_t b = 0; b < batch.size(); ++b)
        if (!(kept_gap[b] > 0.0))
          throw UpsamplingFailed("safe upsampling: vertex " + std::to_string(records[static_cast<std::size_t>(batch[b])].kept) +
                                 " touches another primitive before batch " + std::to_string(report.batches - 1));
    }
    // 2. Topology: undo the batch's collapses; each restored vertex starts on its kept vertex.
    for (int k : batch) {
      const Collapse& c = level.collapses.collapses[static_cast<std::size_t>(k)];
      for (const Tri& t : c.faces_after) faces.erase(t);
      for (const Tri& t : c.faces_before) faces.insert(t);
      // Splits undo collapses last-first per vertex (split_batches orders overlapping patches), so
      // this collapse is the top of kept_in[c.kept].
      std::size_t& top = pending[static_cast<std::size_t>(c.kept)];
      if (top == 0 || kept_in[static_cast<std::size_t>(c.kept)][top - 1] != k)
        throw std::invalid_argument("safe upsampling: batches undo the collapses of vertex " + std::to_string(c.kept) +
                                    " out of order");
      --top;
      x.row(c.removed) = x.row(c.kept);
      ++report.splits;
    }
    // 3. Safe perturbation by eps = 0.01 g (Algorithm 5), g the kept vertex's smallest gap.
    for (std::size_t b = 0; b < batch.size(); ++b) {
      const int k = batch[b];
      const Collapse& c = level.collapses.collapses[static_cast<std::size_t>(k)];
      const double eps = settings.perturbation_fraction * kept_gap[b];
      const Vec3 base = row(x, c.kept);
      const Vec3 toward = intermediate_target(c.removed) - base;
      std::mt19937_64 rng(settings.seed ^ (0x9e3779b97f4a7c15ULL * static_cast<std::uint64_t>(c.removed + 1)));
      bool placed = false;
      for (int attempt = 0; attempt <= settings.max_perturbation_samples && !placed; ++attempt) {
        Vec3 dir;
        if (attempt == 0) {
          if (!(toward.norm() > 1e-12 * scale)) continue;
          dir = toward.normalized();
        } else {
          dir = random_direction(rng);
          ++report.perturbation_samples;
        }
        x.row(c.removed) = (base + eps * dir).transpose();
        placed = patch_valid(c, x, 1e-6 * eps);
        if (placed && attempt > 0) ++report.random_perturbations;
      }
      if (!placed)
        throw UpsamplingFailed("safe upsampling: no valid perturbation found for restored vertex " +
                               std::to_string(c.removed) + " after " +
                               std::to_string(settings.max_perturbation_samples) + " random directions");
    }
    report.perturb_seconds += since(perturb_start);
    // 4. Additive advancement of every present vertex toward its target.
    const auto advance_start = Clock::now();
    current = compact_mesh(level, faces);
    const CompactMesh& m = *current;
    const std::optional<GroundPlane> gp = compact_ground(level, m);
    Positions xc = gather_rows(x, m.global);
    Positions aim(xc.rows(), 3), rest_now(xc.rows(), 3);  // the relaxation's rest shape is the intermediate one
    for (std::size_t k = 0; k < m.global.size(); ++k) {
      aim.row(static_cast<Eigen::Index>(k)) = intermediate_target(m.global[k]).transpose();
      rest_now.row(static_cast<Eigen::Index>(k)) = intermediate_rest(m.global[k]).transpose();
    }
    std::vector<int> vertex_patch(m.global.size(), -1);
    for (int k : batch)
      for (const Tri& t : records[static_cast<std::size_t>(k)].faces_before)
        for (int v : t) vertex_patch[static_cast<std::size_t>(m.compact[static_cast<std::size_t>(v)])] = k;
    // The ratio classes are relative to the coarse solution's gap (PSQ computes g once per
    // refinement): relative to the current, shrinking minimum, the closest pair would always count
    // as "far", lose 90% in every batch, and the gap would vanish geometrically over the batches.
    const AdvanceReport adv = advance_toward_targets(m.prims, level.offset, g_ref, gp ? &*gp : nullptr, aim, xc,
                                                     settings.advance, &vertex_patch);
    report.advance_seconds += since(advance_start);
    report.advance_events += adv.events;
    report.close_events += adv.close_events;
    report.stopped_vertices += adv.stopped_vertices;
    report.redirections += adv.redirections;
    const auto relax_start = Clock::now();
    // 4b. Splits that did not open: the restored vertex is still nearer its kept vertex than half
    // the distance between their aims (both in tight contact, their straight paths were blocked).
    {
      std::vector<char> lagging(m.global.size(), 0);
      int unopened = 0;
      for (int k : batch) {
        const Collapse& c = records[static_cast<std::size_t>(k)];
        const int r = m.compact[static_cast<std::size_t>(c.removed)], kk = m.compact[static_cast<std::size_t>(c.kept)];
        const double want = (aim.row(r) - aim.row(kk)).norm();
        if (!((xc.row(r) - xc.row(kk)).norm() < settings.unopened_fraction * want)) continue;
        ++unopened;
        for (const Tri& t : c.faces_before)
          for (int v : t) lagging[static_cast<std::size_t>(m.compact[static_cast<std::size_t>(v)])] = 1;
      }
      report.unopened_splits += unopened;
      const std::vector<int> free = unopened > 0 ? movable_ring(m, lagging, level.vertex_fixed) : std::vector<int>{};
      if (!free.empty())
        report.pull_newton_iterations +=
            pull_toward_aims(m.prims, rest_now, free, aim, level.offset, scale, gp ? &*gp : nullptr, xc).newton_iterations;
    }
    // 5. Relax pairs left too close and badly shaped new triangles.
    std::vector<int> seeds;
    for (const auto& stencil : pairs_below_gap(m.prims, xc, level.offset, min_gap, gp ? &*gp : nullptr))
      for (int v : stencil)
        if (v >= 0) seeds.push_back(v);
    for (int k : batch)
      for (const Tri& t : level.collapses.collapses[static_cast<std::size_t>(k)].faces_before) {
        const int a = m.compact[static_cast<std::size_t>(t[0])], b = m.compact[static_cast<std::size_t>(t[1])],
                  d = m.compact[static_cast<std::size_t>(t[2])];
        const double q = triangle_quality(row(xc, a), row(xc, b), row(xc, d));
        const double q_rest = triangle_quality(row(rest_now, a), row(rest_now, b), row(rest_now, d));
        if (q < settings.min_quality && q < 0.5 * q_rest) seeds.insert(seeds.end(), {a, b, d});
      }
    if (!seeds.empty()) {
      std::vector<char> marked(m.global.size(), 0);
      for (int v : seeds) marked[static_cast<std::size_t>(v)] = 1;
      const std::vector<int> free = movable_ring(m, marked, level.vertex_fixed);
      if (!free.empty()) {
        ++report.relaxed_patches;
        relax_gaps_on_submesh(m.prims, rest_now, free, level.offset, min_gap > 0.0 ? min_gap : 1e-3 * scale, scale,
                    gp ? &*gp : nullptr, xc);
      }
    }
    report.relax_seconds += since(relax_start);
    scatter_rows(xc, m.global, x);
  }

  const CompactMesh m = compact_mesh(level, faces);
  Positions xc = gather_rows(x, m.global);
  const std::optional<GroundPlane> gp = level.contact ? compact_ground(level, m) : std::nullopt;
  // 6. Vertices left short of their targets (stopped by the advancement where the target is beside
  // a collider, or where the prolongation itself interpenetrates) are pulled toward them with the
  // level's mesh and contact (relax_toward), as in step 4b but over all of them at once.
  if (level.contact) {
    const auto pull_start = Clock::now();
    std::vector<char> short_of(m.global.size(), 0);
    int count = 0;
    for (std::size_t k = 0; k < m.global.size(); ++k)
      if ((xc.row(static_cast<Eigen::Index>(k)) - target.row(m.global[k])).norm() > settings.short_fraction * scale) {
        short_of[k] = 1;
        ++count;
      }
    report.final_pull_vertices = count;
    const std::vector<int> free = count > 0 ? movable_ring(m, short_of, level.vertex_fixed) : std::vector<int>{};
    if (!free.empty())
      report.pull_newton_iterations += pull_toward_aims(m.prims, m.rest, free, gather_rows(target, m.global), level.offset,
                                                        scale, gp ? &*gp : nullptr, xc).newton_iterations;
    report.pull_seconds = since(pull_start);
  }
  // 7. Strain limits (PSQ 4.4.5): first only the vertices level l did not have (PSQ); if that does
  // not reach the limits, every vertex that is not fixed.
  // Without contact the barrier relaxation has nothing to keep apart: limits are then left to the
  // level's own solve (scene files only accept strain limits with a contact section anyway).
  const bool limited = level.contact && std::any_of(level.face_strain_limit.begin(), level.face_strain_limit.end(),
                                                    [](double s) { return s > 0.0; });
  if (limited) {
    const auto strain_start = Clock::now();
    std::vector<char> old(static_cast<std::size_t>(nf), 0);
    for (int i : level.collapses.coarse_to_fine) old[static_cast<std::size_t>(i)] = 1;
    std::vector<int> new_free, all_free;
    for (std::size_t k = 0; k < m.global.size(); ++k) {
      const int i = m.global[k];
      if (level.vertex_fixed[static_cast<std::size_t>(i)]) continue;
      all_free.push_back(static_cast<int>(k));
      if (!old[static_cast<std::size_t>(i)]) new_free.push_back(static_cast<int>(k));
    }
    // Faces of the final mesh are exactly level l+1's, but compact_mesh orders them as the face set:
    // map each limit by its canonical triangle.
    std::vector<double> limit(static_cast<std::size_t>(m.prims.faces.rows()), 0.0);
    std::map<Tri, double> by_tri;
    for (int f = 0; f < level.fine.F.rows(); ++f)
      by_tri[canonical_tri(level.fine.F(f, 0), level.fine.F(f, 1), level.fine.F(f, 2))] =
          level.face_strain_limit[static_cast<std::size_t>(f)];
    int f = 0;
    for (const Tri& t : faces) limit[static_cast<std::size_t>(f++)] = by_tri.count(t) ? by_tri.at(t) : 0.0;
    const RelaxationMesh rm{&m.prims, &m.rest, level.offset, gp ? &*gp : nullptr};
    report.max_stretch_before = max_stretch_of(m.prims.faces, m.rest, limit, xc);
    // 7a. The projection (strain_projection.h): a pass over the stretched triangles per iteration,
    // and on the flag's finer levels all it takes. Its path is followed only when it met the limits:
    // one that stalled can end further from them than it started.
    {
      std::vector<char> free_mask(m.global.size(), 0);
      for (int k : all_free) free_mask[static_cast<std::size_t>(k)] = 1;
      Positions projected = xc;
      std::vector<Positions> path;
      const StrainProjectionReport pr = project_strain(m.rest, m.prims.faces, limit, free_mask, {}, projected, &path);
      report.strain_projection_iterations = pr.iterations;
      if (pr.satisfied) follow_path(m.prims, m.rest, level.offset, gp ? &*gp : nullptr, path, xc);
    }
    // 7b. What the projection left (it stalled, or contact cut its path short): the reweighted
    // membrane relaxations, first of the new vertices alone (PSQ), then of all that may move, the
    // latter for up to 24 rounds even when a round does not improve (not monotone, see
    // StrainRelaxationSettings::stop_without_progress; with 8 rounds and the early stop it left
    // every vertical start of the flag over its limit).
    for (const std::vector<int>* free : {&new_free, &all_free}) {
      if (!strain_limit_violation(m.prims.faces, m.rest, limit, xc)) break;
      StrainRelaxationSettings settings;
      if (free == &all_free) {
        settings.max_rounds = 24;
        settings.stop_without_progress = false;
      }
      Positions relaxed = xc;
      std::vector<Positions> path;
      relax_strain(rm, *free, limit, settings, relaxed, &path);
      // Followed, not copied: the path is the one that was CCD-checked.
      follow_path(m.prims, m.rest, level.offset, gp ? &*gp : nullptr, path, xc);
      ++report.strain_passes;
    }
    report.strain_seconds = since(strain_start);
    report.max_stretch_after = max_stretch_of(m.prims.faces, m.rest, limit, xc);
    // A start state at or beyond a strain limit has infinite strain-limit energy: the level's first
    // Newton step would be NaN (seen: "broad phase: non-finite position" on the flag's vertical
    // starts). Refused here, by name, instead.
    if (const auto v = strain_limit_violation(m.prims.faces, m.rest, limit, xc)) {
      char text[200];
      std::snprintf(text, sizeof text,
                    "safe upsampling: the strain projection and relaxation left a stretch of %.4f on faces limited to "
                    "%.4f (%d relaxation passes); the level cannot start from it",
                    v->first, v->second, report.strain_passes);
      throw UpsamplingFailed(text);
    }
  }
  scatter_rows(xc, m.global, x);
  if (level.contact) {
    report.final_gap = min_contact_gap(m.prims, xc, level.offset, scale, gp ? &*gp : nullptr);
    if (min_gap > 0.0)
      report.unresolved_gaps =
          static_cast<int>(pairs_below_gap(m.prims, xc, level.offset, min_gap, gp ? &*gp : nullptr).size());
  }
  double sum2 = 0.0;
  for (int i = 0; i < nf; ++i) {
    const double d = (x.row(i) - target.row(i)).norm();
    report.max_target_distance = std::max(report.max_target_distance, d);
    sum2 += d * d;
  }
  report.rms_target_distance = std::sqrt(sum2 / std::max(1, nf));
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  if (report_out) *report_out = report;
  return x;
}

UpsamplingLevel upsampling_level(const Scene& scene, const SceneHierarchy& hierarchy, int level) {
  if (level < 0 || level >= hierarchy.finest())
    throw std::invalid_argument("upsampling_level: level " + std::to_string(level) + " is not in [0, " +
                                std::to_string(hierarchy.finest()) + ")");
  const SceneLevel& coarse = hierarchy.levels[static_cast<std::size_t>(level)];
  const SceneLevel& fine = hierarchy.levels[static_cast<std::size_t>(level + 1)];
  const SceneLevel& finest = hierarchy.levels.back();
  UpsamplingLevel out;
  out.coarse_faces = coarse.rest.F;
  out.fine = fine.rest;
  out.collapses = scene_collapses(hierarchy, level);
  out.to_next = &*coarse.to_next;
  out.contact = scene.contact.has_value();
  out.offset = scene.contact ? scene.contact->offset : 0.0;
  const int nf = static_cast<int>(fine.rest.V.rows());
  out.vertex_object.assign(static_cast<std::size_t>(nf), 0);
  out.vertex_fixed.assign(static_cast<std::size_t>(nf), 0);
  out.face_strain_limit.assign(static_cast<std::size_t>(fine.rest.F.rows()), 0.0);
  if (scene.ground) {
    out.ground = GroundPlane{scene.ground->normal, scene.ground->height, {}};
    out.ground->vertex_collides.assign(static_cast<std::size_t>(nf), 0);
  }
  for (std::size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    out.object_self_contact.push_back(obj.self_contact ? 1 : 0);
    std::vector<char> pinned;
    if (!obj.obstacle) {
      pinned.assign(static_cast<std::size_t>(obj.rest.V.rows()), 0);
      for (const PinGroup& g : obj.pins)
        for (int v : g.vertices) pinned[static_cast<std::size_t>(v)] = 1;
    }
    for (int v = fine.vertex_offsets[o]; v < fine.vertex_offsets[o + 1]; ++v) {
      out.vertex_object[static_cast<std::size_t>(v)] = static_cast<int>(o);
      const int local_finest = fine.to_finest[static_cast<std::size_t>(v)] - finest.vertex_offsets[o];
      out.vertex_fixed[static_cast<std::size_t>(v)] =
          obj.obstacle || pinned[static_cast<std::size_t>(local_finest)] ? 1 : 0;
      if (out.ground) out.ground->vertex_collides[static_cast<std::size_t>(v)] = obj.ground_contact ? 1 : 0;
    }
    if (obj.strain_limit)
      for (int f = fine.face_offsets[o]; f < fine.face_offsets[o + 1]; ++f)
        out.face_strain_limit[static_cast<std::size_t>(f)] = obj.strain_limit->limit;
  }
  return out;
}

}  // namespace pd
