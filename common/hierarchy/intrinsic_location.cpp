// Successive self-parameterization through recorded edge collapses; see intrinsic_location.h.
#include "hierarchy/intrinsic_location.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <string>

namespace pd {
namespace {

using Vec2 = Eigen::Vector2d;

// A tracked point: a face as a canonical Tri and weights in the Tri's vertex order.
struct Tracked {
  Tri face{};
  Vec3 bary = Vec3::Zero();
};

// Rotates (ids, bary) together so that the smallest id comes first (canonical_tri's rotation).
Tracked canonical(const Tri& ids, const Vec3& bary) {
  int r = 0;
  if (ids[1] < ids[0] && ids[1] < ids[2]) r = 1;
  if (ids[2] < ids[0] && ids[2] < ids[1]) r = 2;
  Tracked t;
  for (int k = 0; k < 3; ++k) {
    t.face[static_cast<std::size_t>(k)] = ids[static_cast<std::size_t>((k + r) % 3)];
    t.bary[k] = bary[(k + r) % 3];
  }
  return t;
}

// Barycentric coordinates of p in the 2D triangle (a, b, c) (oriented area ratios).
Vec3 bary2(const Vec2& p, const Vec2& a, const Vec2& b, const Vec2& c) {
  auto cross = [](const Vec2& u, const Vec2& v) { return u.x() * v.y() - u.y() * v.x(); };
  const double area = cross(b - a, c - a);
  return Vec3(cross(b - p, c - p), cross(c - p, a - p), cross(a - p, b - p)) / area;
}

double signed_area2(const Vec2& a, const Vec2& b, const Vec2& c) {
  return 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
}

// The boundary loop of a patch (faces counter-clockwise): the directed edges whose reverse is not in
// the patch, chained. Returns false unless they form exactly one simple cycle.
bool boundary_loop(const std::vector<Tri>& faces, std::vector<int>& loop) {
  std::set<std::pair<int, int>> directed;
  for (const Tri& t : faces)
    for (int k = 0; k < 3; ++k) directed.insert({t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)]});
  std::map<int, int> next;
  for (const auto& e : directed) {
    if (directed.count({e.second, e.first})) continue;
    if (!next.emplace(e.first, e.second).second) return false;  // vertex visited twice: not simple
  }
  if (next.size() < 3) return false;
  loop.clear();
  int v = next.begin()->first;
  do {
    loop.push_back(v);
    auto it = next.find(v);
    if (it == next.end() || loop.size() > next.size()) return false;
    v = it->second;
  } while (v != loop.front());
  return loop.size() == next.size();
}

// Tutte embedding of the patch's vertices not in `fixed` with mean-value weights from 3D positions.
// uv holds the fixed vertices on entry and gets the others.
bool tutte_mean_value(const std::vector<Tri>& faces, const std::map<int, Vec3>& X, std::map<int, Vec2>& uv) {
  std::map<int, int> unknown;  // vertex id -> row
  for (const Tri& t : faces)
    for (int v : t)
      if (!uv.count(v) && !unknown.count(v)) {
        const int row = static_cast<int>(unknown.size());
        unknown.emplace(v, row);
      }
  if (unknown.empty()) return true;
  const int n = static_cast<int>(unknown.size());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(n, 2);
  for (const Tri& t : faces)
    for (int k = 0; k < 3; ++k) {
      const int i = t[static_cast<std::size_t>(k)];
      auto ui = unknown.find(i);
      if (ui == unknown.end()) continue;
      const int j = t[static_cast<std::size_t>((k + 1) % 3)], l = t[static_cast<std::size_t>((k + 2) % 3)];
      const Vec3 ej = X.at(j) - X.at(i), el = X.at(l) - X.at(i);
      const double lj = ej.norm(), ll = el.norm();
      if (!(lj > 0.0) || !(ll > 0.0)) return false;
      const double angle = std::atan2(ej.cross(el).norm(), ej.dot(el));
      const double th = std::tan(0.5 * angle);
      for (const auto& [nb, w] : {std::pair<int, double>{j, th / lj}, std::pair<int, double>{l, th / ll}}) {
        A(ui->second, ui->second) += w;
        auto un = unknown.find(nb);
        if (un != unknown.end()) A(ui->second, un->second) -= w;
        else b.row(ui->second) += w * uv.at(nb).transpose();
      }
    }
  const Eigen::MatrixXd sol = A.fullPivLu().solve(b);
  if (!sol.allFinite()) return false;
  for (const auto& [v, row] : unknown) uv[v] = sol.row(row).transpose();
  return true;
}

bool all_positive(const std::vector<Tri>& faces, const std::map<int, Vec2>& uv) {
  for (const Tri& t : faces)
    if (!(signed_area2(uv.at(t[0]), uv.at(t[1]), uv.at(t[2])) > 1e-14)) return false;
  return true;
}

// Joint flattening of faces_before and faces_after (see the header). X: positions of the patch's
// vertices before the collapse (kept at kept_position_before); kept_after: kept's position after.
bool joint_flatten(const Collapse& c, const std::map<int, Vec3>& X, std::map<int, Vec2>& uv_before,
                   std::map<int, Vec2>& uv_after) {
  std::vector<int> loop_b, loop_a;
  if (!boundary_loop(c.faces_before, loop_b) || !boundary_loop(c.faces_after, loop_a)) return false;
  // The after loop must be the before loop with `removed` dropped (if it is on it).
  std::vector<int> reduced;
  for (int v : loop_b)
    if (v != c.removed) reduced.push_back(v);
  if (reduced.size() != loop_a.size()) return false;
  {
    auto it = std::find(reduced.begin(), reduced.end(), loop_a.front());
    if (it == reduced.end()) return false;
    std::rotate(reduced.begin(), it, reduced.end());
    if (reduced != loop_a) return false;
  }
  std::map<int, Vec3> Xa = X;
  Xa[c.kept] = c.kept_position_after;
  Xa.erase(c.removed);
  // Circle by arc length of the after loop.
  const std::size_t m = loop_a.size();
  std::vector<double> s(m + 1, 0.0);
  for (std::size_t i = 0; i < m; ++i) s[i + 1] = s[i] + (Xa.at(loop_a[(i + 1) % m]) - Xa.at(loop_a[i])).norm();
  if (!(s[m] > 0.0)) return false;
  uv_before.clear();
  uv_after.clear();
  for (std::size_t i = 0; i < m; ++i) {
    const double th = 2.0 * M_PI * s[i] / s[m];
    uv_after[loop_a[i]] = Vec2(std::cos(th), std::sin(th));
  }
  uv_before = uv_after;
  auto rb = std::find(loop_b.begin(), loop_b.end(), c.removed);
  if (rb != loop_b.end()) {  // removed on the boundary: onto the chord between its loop neighbours
    const std::size_t i = static_cast<std::size_t>(rb - loop_b.begin());
    const int prev = loop_b[(i + loop_b.size() - 1) % loop_b.size()], nxt = loop_b[(i + 1) % loop_b.size()];
    const double dp = (X.at(c.removed) - X.at(prev)).norm(), dn = (X.at(nxt) - X.at(c.removed)).norm();
    if (!(dp + dn > 0.0)) return false;
    const double t = dp / (dp + dn);
    uv_before[c.removed] = (1.0 - t) * uv_after.at(prev) + t * uv_after.at(nxt);
  }
  if (!tutte_mean_value(c.faces_before, X, uv_before)) return false;
  if (!tutte_mean_value(c.faces_after, Xa, uv_after)) return false;
  return all_positive(c.faces_before, uv_before) && all_positive(c.faces_after, uv_after);
}

// Closest point of the 3D triangle (a, b, c) to p, as barycentric weights (Ericson's regions).
Vec3 closest_bary3(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return Vec3(1, 0, 0);
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return Vec3(0, 1, 0);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) { const double v = d1 / (d1 - d3); return Vec3(1 - v, v, 0); }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return Vec3(0, 0, 1);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) { const double w = d2 / (d2 - d6); return Vec3(1 - w, 0, w); }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return Vec3(0, 1 - w, w);
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return Vec3(1 - v - w, v, w);
}

Vec3 clamp_normalise(Vec3 b, double* worst_negative) {
  for (int k = 0; k < 3; ++k)
    if (b[k] < 0.0) {
      if (worst_negative) *worst_negative = std::min(*worst_negative, b[k]);
      b[k] = 0.0;
    }
  return b / b.sum();
}

// Moves the tracked points through the collapses. V: positions of the start mesh (its ids).
void track(std::vector<Tracked>& pts, Positions V, const std::vector<Collapse>& collapses, LocationStats& st) {
  std::map<Tri, std::vector<int>> by_face;
  for (std::size_t i = 0; i < pts.size(); ++i) by_face[pts[i].face].push_back(static_cast<int>(i));
  const int n = static_cast<int>(V.rows());
  for (std::size_t ci = 0; ci < collapses.size(); ++ci) {
    const Collapse& c = collapses[ci];
    ++st.collapses;
    if (c.removed < 0 || c.removed >= n || c.kept < 0 || c.kept >= n || c.faces_after.empty())
      throw std::invalid_argument("locate_through_collapses: collapse " + std::to_string(ci) +
                                  ": ids out of range or no faces after it");
    V.row(c.removed) = c.removed_position.transpose();
    V.row(c.kept) = c.kept_position_before.transpose();
    std::vector<int> moving;
    for (const Tri& t : c.faces_before) {
      auto it = by_face.find(t);
      if (it == by_face.end()) continue;
      moving.insert(moving.end(), it->second.begin(), it->second.end());
      by_face.erase(it);
    }
    if (!moving.empty()) {
      std::map<int, Vec3> X;
      for (const Tri& t : c.faces_before)
        for (int v : t) {
          if (v < 0 || v >= n)
            throw std::invalid_argument("locate_through_collapses: collapse " + std::to_string(ci) + ": vertex id out of range");
          X[v] = V.row(v).transpose();
        }
      std::map<int, Vec2> uvb, uva;
      const bool flat = joint_flatten(c, X, uvb, uva);
      if (!flat) ++st.fallback_collapses;
      for (int p : moving) {
        Tracked& tp = pts[static_cast<std::size_t>(p)];
        Tracked best;
        double best_score = -1e300;
        if (flat) {
          Vec2 u = Vec2::Zero();
          for (int k = 0; k < 3; ++k) u += tp.bary[k] * uvb.at(tp.face[static_cast<std::size_t>(k)]);
          for (const Tri& t : c.faces_after) {
            const Vec3 b = bary2(u, uva.at(t[0]), uva.at(t[1]), uva.at(t[2]));
            if (b.minCoeff() > best_score) best_score = b.minCoeff(), best.face = t, best.bary = b;
          }
          best.bary = clamp_normalise(best.bary, &st.worst_negative);
        } else {
          Vec3 x = Vec3::Zero();
          for (int k = 0; k < 3; ++k) x += tp.bary[k] * X.at(tp.face[static_cast<std::size_t>(k)]);
          for (const Tri& t : c.faces_after) {
            auto P = [&](int v) -> Vec3 { return v == c.kept ? c.kept_position_after : X.at(v); };
            const Vec3 b = closest_bary3(x, P(t[0]), P(t[1]), P(t[2]));
            const double d = -(b[0] * P(t[0]) + b[1] * P(t[1]) + b[2] * P(t[2]) - x).norm();
            if (d > best_score) best_score = d, best.face = t, best.bary = b;
          }
          best.bary = clamp_normalise(best.bary, nullptr);
        }
        tp = best;
        by_face[tp.face].push_back(p);
        ++st.moved_points;
      }
    }
    V.row(c.kept) = c.kept_position_after.transpose();
  }
}

std::vector<Tracked> start_at_vertices(const TriMesh& mesh) {
  const int n = mesh.num_vertices();
  std::vector<Tracked> pts(static_cast<std::size_t>(n));
  std::vector<bool> done(static_cast<std::size_t>(n), false);
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.F(f, k);
      if (v < 0 || v >= n) throw std::invalid_argument("locate_through_collapses: face " + std::to_string(f) + " has a vertex out of range");
      if (done[static_cast<std::size_t>(v)]) continue;
      done[static_cast<std::size_t>(v)] = true;
      Vec3 b = Vec3::Zero();
      b[k] = 1.0;
      pts[static_cast<std::size_t>(v)] = canonical({mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)}, b);
    }
  for (int v = 0; v < n; ++v)
    if (!done[static_cast<std::size_t>(v)])
      throw std::invalid_argument("locate_through_collapses: vertex " + std::to_string(v) + " is in no face");
  return pts;
}

// Maps tracked points (in the ids that coarse_to_fine maps to) to rows of coarse.F.
std::vector<SurfaceLocation> to_rows(const std::vector<Tracked>& pts, const TriMesh& coarse,
                                     const std::vector<int>& coarse_to_fine) {
  if (static_cast<int>(coarse_to_fine.size()) != coarse.num_vertices())
    throw std::invalid_argument("locate_through_collapses: coarse_to_fine has " + std::to_string(coarse_to_fine.size()) +
                                " entries for " + std::to_string(coarse.num_vertices()) + " coarse vertices");
  std::map<Tri, std::pair<int, int>> row_of;  // fine-id Tri -> (row, rotation)
  for (int f = 0; f < coarse.num_faces(); ++f) {
    Tri ids;
    for (int k = 0; k < 3; ++k) {
      const int v = coarse.F(f, k);
      if (v < 0 || v >= coarse.num_vertices()) throw std::invalid_argument("locate_through_collapses: coarse face out of range");
      ids[static_cast<std::size_t>(k)] = coarse_to_fine[static_cast<std::size_t>(v)];
    }
    int r = 0;
    if (ids[1] < ids[0] && ids[1] < ids[2]) r = 1;
    if (ids[2] < ids[0] && ids[2] < ids[1]) r = 2;
    row_of[canonical_tri(ids[0], ids[1], ids[2])] = {f, r};
  }
  std::vector<SurfaceLocation> out(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    auto it = row_of.find(pts[i].face);
    if (it == row_of.end())
      throw std::invalid_argument("locate_through_collapses: fine vertex " + std::to_string(i) +
                                  " ends in a face that is not a coarse face (records do not fit the meshes)");
    const auto [row, r] = it->second;
    out[i].face = row;
    // canonical slot k holds row vertex (k + r) % 3.
    for (int k = 0; k < 3; ++k) out[i].bary[(k + r) % 3] = pts[i].bary[k];
  }
  return out;
}

}  // namespace

std::vector<SurfaceLocation> locate_through_collapses(const TriMesh& fine, const std::vector<Collapse>& collapses,
                                                      const TriMesh& coarse, const std::vector<int>& coarse_to_fine,
                                                      LocationStats* stats) {
  LocationStats st;
  std::vector<Tracked> pts = start_at_vertices(fine);
  track(pts, fine.V, collapses, st);
  for (int id : coarse_to_fine)
    if (id < 0 || id >= fine.num_vertices()) throw std::invalid_argument("locate_through_collapses: coarse_to_fine id out of range");
  std::vector<SurfaceLocation> out = to_rows(pts, coarse, coarse_to_fine);
  if (stats) *stats = st;
  return out;
}

std::vector<SurfaceLocation> locate_finest_on_level(const std::vector<Level>& levels, int level, LocationStats* stats) {
  if (levels.empty() || level < 0 || level >= static_cast<int>(levels.size()))
    throw std::invalid_argument("locate_finest_on_level: level " + std::to_string(level) + " out of range (" +
                                std::to_string(levels.size()) + " levels)");
  LocationStats st;
  const int L = static_cast<int>(levels.size()) - 1;
  std::vector<Tracked> pts = start_at_vertices(levels[static_cast<std::size_t>(L)].mesh);
  for (int l = L - 1; l >= level; --l) {
    const Level& lv = levels[static_cast<std::size_t>(l)];
    track(pts, levels[static_cast<std::size_t>(l + 1)].mesh.V, lv.collapses, st);
    // Relabel from level l+1 ids to level l ids.
    for (std::size_t i = 0; i < pts.size(); ++i) {
      Tri ids;
      for (int k = 0; k < 3; ++k) {
        const int v = pts[i].face[static_cast<std::size_t>(k)];
        const int c = (v >= 0 && v < static_cast<int>(lv.fine_to_coarse.size())) ? lv.fine_to_coarse[static_cast<std::size_t>(v)] : -1;
        if (c < 0)
          throw std::invalid_argument("locate_finest_on_level: level " + std::to_string(l) +
                                      ": a tracked face uses a removed vertex (records do not fit the levels)");
        ids[static_cast<std::size_t>(k)] = c;
      }
      pts[i] = canonical(ids, pts[i].bary);
    }
  }
  const TriMesh& target = levels[static_cast<std::size_t>(level)].mesh;
  std::vector<int> identity(static_cast<std::size_t>(target.num_vertices()));
  for (int i = 0; i < target.num_vertices(); ++i) identity[static_cast<std::size_t>(i)] = i;
  std::vector<SurfaceLocation> out = to_rows(pts, target, identity);
  if (stats) *stats = st;
  return out;
}

}  // namespace pd
