// Successive self-parameterization through recorded edge collapses; see intrinsic_location.h.
#include "hierarchy/intrinsic_location.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <array>
#include <cstdint>
#include <limits>
#include <numeric>
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

// A map from vertex id to T for one collapse patch (a handful of vertices): a flat vector searched
// linearly. Why: track() builds several of these per collapse, and std::map's node allocations and
// tree rebalancing dominated the build's profile. The buffers are reused across collapses.
template <class T>
class PatchMap {
 public:
  void clear() { items_.clear(); }
  const T* find(int v) const {
    for (const auto& it : items_)
      if (it.first == v) return &it.second;
    return nullptr;
  }
  T* find(int v) { return const_cast<T*>(static_cast<const PatchMap*>(this)->find(v)); }
  bool contains(int v) const { return find(v) != nullptr; }
  const T& at(int v) const {
    const T* p = find(v);
    if (!p) throw std::out_of_range("PatchMap::at: vertex not in the patch");
    return *p;
  }
  T& operator[](int v) {
    if (T* p = find(v)) return *p;
    items_.emplace_back(v, T());
    return items_.back().second;
  }
  void erase(int v) {
    for (std::size_t i = 0; i < items_.size(); ++i)
      if (items_[i].first == v) {
        items_.erase(items_.begin() + static_cast<std::ptrdiff_t>(i));
        return;
      }
  }
  std::size_t size() const { return items_.size(); }
  const std::vector<std::pair<int, T>>& items() const { return items_; }

 private:
  std::vector<std::pair<int, T>> items_;
};

using PatchPositions = PatchMap<Vec3>;
using PatchUV = PatchMap<Vec2>;

// Scratch buffers of one track() call, reused for every collapse (no allocation per collapse).
struct Workspace {
  std::vector<std::pair<int, int>> directed, next;  // boundary_loop
  std::vector<int> loop_b, loop_a, reduced;        // joint_flatten
  std::vector<double> arc;
  PatchPositions X, Xa;
  PatchUV uvb, uva;
  PatchMap<int> unknown;                            // tutte_mean_value: vertex -> row
  Eigen::MatrixXd A, b;
  Eigen::FullPivLU<Eigen::MatrixXd> lu;
  std::vector<std::array<Vec2, 3>> after_uv;        // uv of each faces_after corner
  std::vector<int> moving;
};

// The boundary loop of a patch (faces counter-clockwise): the directed edges whose reverse is not in
// the patch, chained from the smallest start vertex. Returns false unless they form exactly one
// simple cycle.
bool boundary_loop(const std::vector<Tri>& faces, std::vector<int>& loop, Workspace& ws) {
  std::vector<std::pair<int, int>>& directed = ws.directed;
  directed.clear();
  for (const Tri& t : faces)
    for (int k = 0; k < 3; ++k) directed.emplace_back(t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)]);
  std::sort(directed.begin(), directed.end());
  directed.erase(std::unique(directed.begin(), directed.end()), directed.end());
  // Sorted by start vertex, since `directed` is: a repeated start means the loop is not simple.
  std::vector<std::pair<int, int>>& next = ws.next;
  next.clear();
  for (const auto& e : directed) {
    if (std::binary_search(directed.begin(), directed.end(), std::make_pair(e.second, e.first))) continue;
    if (!next.empty() && next.back().first == e.first) return false;  // vertex visited twice: not simple
    next.push_back(e);
  }
  if (next.size() < 3) return false;
  loop.clear();
  int v = next.front().first;
  do {
    loop.push_back(v);
    auto it = std::lower_bound(next.begin(), next.end(), std::make_pair(v, std::numeric_limits<int>::min()));
    if (it == next.end() || it->first != v || loop.size() > next.size()) return false;
    v = it->second;
  } while (v != loop.front());
  return loop.size() == next.size();
}

// Tutte embedding of the patch's vertices not in `fixed` with mean-value weights from 3D positions.
// uv holds the fixed vertices on entry and gets the others. Rows follow first appearance in `faces`.
bool tutte_mean_value(const std::vector<Tri>& faces, const PatchPositions& X, PatchUV& uv, Workspace& ws) {
  PatchMap<int>& unknown = ws.unknown;
  unknown.clear();
  for (const Tri& t : faces)
    for (int v : t)
      if (!uv.contains(v) && !unknown.contains(v)) {
        const int row = static_cast<int>(unknown.size());
        unknown[v] = row;
      }
  if (unknown.size() == 0) return true;
  const int n = static_cast<int>(unknown.size());
  Eigen::MatrixXd& A = ws.A;
  Eigen::MatrixXd& b = ws.b;
  A.setZero(n, n);
  b.setZero(n, 2);
  for (const Tri& t : faces)
    for (int k = 0; k < 3; ++k) {
      const int i = t[static_cast<std::size_t>(k)];
      const int* ui = unknown.find(i);
      if (!ui) continue;
      const int j = t[static_cast<std::size_t>((k + 1) % 3)], l = t[static_cast<std::size_t>((k + 2) % 3)];
      const Vec3 ej = X.at(j) - X.at(i), el = X.at(l) - X.at(i);
      const double lj = ej.norm(), ll = el.norm();
      if (!(lj > 0.0) || !(ll > 0.0)) return false;
      const double angle = std::atan2(ej.cross(el).norm(), ej.dot(el));
      const double th = std::tan(0.5 * angle);
      for (const auto& [nb, w] : {std::pair<int, double>{j, th / lj}, std::pair<int, double>{l, th / ll}}) {
        A(*ui, *ui) += w;
        const int* un = unknown.find(nb);
        if (un) A(*ui, *un) -= w;
        else b.row(*ui) += w * uv.at(nb).transpose();
      }
    }
  ws.lu.compute(A);
  const Eigen::MatrixXd sol = ws.lu.solve(b);
  if (!sol.allFinite()) return false;
  for (const auto& [v, row] : unknown.items()) uv[v] = sol.row(row).transpose();
  return true;
}

bool all_positive(const std::vector<Tri>& faces, const PatchUV& uv) {
  for (const Tri& t : faces)
    if (!(signed_area2(uv.at(t[0]), uv.at(t[1]), uv.at(t[2])) > 1e-14)) return false;
  return true;
}

// True when the before loop with `removed` dropped is the after loop (up to rotation).
bool loops_match(const Collapse& c, Workspace& ws) {
  std::vector<int>& reduced = ws.reduced;
  reduced.clear();
  for (int v : ws.loop_b)
    if (v != c.removed) reduced.push_back(v);
  if (reduced.size() != ws.loop_a.size()) return false;
  auto it = std::find(reduced.begin(), reduced.end(), ws.loop_a.front());
  if (it == reduced.end()) return false;
  std::rotate(reduced.begin(), it, reduced.end());
  return reduced == ws.loop_a;
}

// Joint flattening of faces_before and faces_after (see the header) into ws.uvb and ws.uva. ws.X:
// positions of the patch's vertices before the collapse (kept at kept_position_before).
bool joint_flatten(const Collapse& c, Workspace& ws) {
  const PatchPositions& X = ws.X;
  if (!boundary_loop(c.faces_before, ws.loop_b, ws) || !boundary_loop(c.faces_after, ws.loop_a, ws)) return false;
  if (!loops_match(c, ws)) return false;
  const std::vector<int>& loop_a = ws.loop_a;
  const std::vector<int>& loop_b = ws.loop_b;
  PatchPositions& Xa = ws.Xa;
  Xa = X;
  Xa[c.kept] = c.kept_position_after;
  Xa.erase(c.removed);
  // Circle by arc length of the after loop.
  const std::size_t m = loop_a.size();
  std::vector<double>& s = ws.arc;
  s.assign(m + 1, 0.0);
  for (std::size_t i = 0; i < m; ++i) s[i + 1] = s[i] + (Xa.at(loop_a[(i + 1) % m]) - Xa.at(loop_a[i])).norm();
  if (!(s[m] > 0.0)) return false;
  PatchUV& uv_before = ws.uvb;
  PatchUV& uv_after = ws.uva;
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
  if (!tutte_mean_value(c.faces_before, X, uv_before, ws)) return false;
  if (!tutte_mean_value(c.faces_after, Xa, uv_after, ws)) return false;
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

// Tracked points grouped by their current face: an open-addressing (linear probing) table from Tri
// to the head of an intrusive list of point indices. Why: track() looks up every face of every
// collapse, and the std::map<Tri, std::vector<int>> it replaces spent most of its time in node and
// vector allocation. The order of points within a face does not matter: every point is moved on its
// own (its new location depends only on its old one and on the collapse).
class FacePoints {
 public:
  FacePoints(const std::vector<Tracked>& pts) : next_(pts.size(), -1) {
    std::size_t cap = 16;
    while (cap < 2 * pts.size() + 16) cap *= 2;
    slots_.assign(cap, Slot{});
    for (std::size_t i = 0; i < pts.size(); ++i) add(pts[i].face, static_cast<int>(i));
  }
  void add(const Tri& t, int p) {
    std::size_t i = probe(t);
    if (slots_[i].head < 0) {
      if (2 * (size_ + 1) > slots_.size()) {
        grow();
        i = probe(t);
      }
      slots_[i].key = t;
      ++size_;
    }
    next_[static_cast<std::size_t>(p)] = slots_[i].head;
    slots_[i].head = p;
  }
  // Appends the points in face t to `out` and forgets the face.
  void take(const Tri& t, std::vector<int>& out) {
    std::size_t i = probe(t);
    if (slots_[i].head < 0) return;
    for (int p = slots_[i].head; p >= 0; p = next_[static_cast<std::size_t>(p)]) out.push_back(p);
    --size_;
    // Backward-shift deletion: move later entries of the probe run into the hole.
    const std::size_t mask = slots_.size() - 1;
    for (std::size_t j = (i + 1) & mask; slots_[j].head >= 0; j = (j + 1) & mask) {
      const std::size_t home = hash(slots_[j].key) & mask;
      if (((j - home) & mask) >= ((j - i) & mask)) {
        slots_[i] = slots_[j];
        i = j;
      }
    }
    slots_[i].head = -1;
  }

 private:
  struct Slot {
    Tri key{};
    int head = -1;  // -1: empty slot
  };
  static std::size_t hash(const Tri& t) {
    std::uint64_t h = static_cast<std::uint32_t>(t[0]);
    h = h * 0x9E3779B97F4A7C15ULL ^ static_cast<std::uint32_t>(t[1]);
    h = h * 0x9E3779B97F4A7C15ULL ^ static_cast<std::uint32_t>(t[2]);
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ULL;
    return static_cast<std::size_t>(h ^ (h >> 32));
  }
  std::size_t probe(const Tri& t) const {
    const std::size_t mask = slots_.size() - 1;
    std::size_t i = hash(t) & mask;
    while (slots_[i].head >= 0 && slots_[i].key != t) i = (i + 1) & mask;
    return i;
  }
  void grow() {
    std::vector<Slot> old;
    old.swap(slots_);
    slots_.assign(2 * old.size(), Slot{});
    for (const Slot& s : old)
      if (s.head >= 0) slots_[probe(s.key)] = s;
  }
  std::vector<Slot> slots_;
  std::vector<int> next_;
  std::size_t size_ = 0;
};

// One moving point's new location in faces_after: in the joint flattening (ws.uvb / ws.after_uv)
// when `flat`, else by 3D closest point (ws.X, kept at kept_position_after).
Tracked relocate(const Tracked& tp, const Collapse& c, bool flat, Workspace& ws, LocationStats& st) {
  Tracked best;
  double best_score = -1e300;
  if (flat) {
    Vec2 u = Vec2::Zero();
    for (int k = 0; k < 3; ++k) u += tp.bary[k] * ws.uvb.at(tp.face[static_cast<std::size_t>(k)]);
    for (std::size_t f = 0; f < c.faces_after.size(); ++f) {
      const std::array<Vec2, 3>& q = ws.after_uv[f];
      const Vec3 b = bary2(u, q[0], q[1], q[2]);
      if (b.minCoeff() > best_score) best_score = b.minCoeff(), best.face = c.faces_after[f], best.bary = b;
    }
    best.bary = clamp_normalise(best.bary, &st.worst_negative);
  } else {
    const PatchPositions& X = ws.X;
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
  return best;
}

// Moves the tracked points through the collapses. V: positions of the start mesh (its ids).
void track(std::vector<Tracked>& pts, Positions V, const std::vector<Collapse>& collapses, LocationStats& st) {
  FacePoints by_face(pts);
  Workspace ws;
  const int n = static_cast<int>(V.rows());
  for (std::size_t ci = 0; ci < collapses.size(); ++ci) {
    const Collapse& c = collapses[ci];
    ++st.collapses;
    if (c.removed < 0 || c.removed >= n || c.kept < 0 || c.kept >= n || c.faces_after.empty())
      throw std::invalid_argument("locate_through_collapses: collapse " + std::to_string(ci) +
                                  ": ids out of range or no faces after it");
    V.row(c.removed) = c.removed_position.transpose();
    V.row(c.kept) = c.kept_position_before.transpose();
    ws.moving.clear();
    for (const Tri& t : c.faces_before) by_face.take(t, ws.moving);
    if (!ws.moving.empty()) {
      ws.X.clear();
      for (const Tri& t : c.faces_before)
        for (int v : t) {
          if (v < 0 || v >= n)
            throw std::invalid_argument("locate_through_collapses: collapse " + std::to_string(ci) + ": vertex id out of range");
          ws.X[v] = V.row(v).transpose();
        }
      const bool flat = joint_flatten(c, ws);
      if (!flat) ++st.fallback_collapses;
      if (flat) {
        ws.after_uv.resize(c.faces_after.size());
        for (std::size_t f = 0; f < c.faces_after.size(); ++f)
          for (std::size_t k = 0; k < 3; ++k) ws.after_uv[f][k] = ws.uva.at(c.faces_after[f][k]);
      }
      for (int p : ws.moving) {
        Tracked& tp = pts[static_cast<std::size_t>(p)];
        tp = relocate(tp, c, flat, ws, st);
        by_face.add(tp.face, p);
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

namespace {

// Moves points located on levels[l + 1] (its ids) through level l's collapses and relabels them to
// level l's ids: one step of the finest vertices' descent.
void descend_one_level(std::vector<Tracked>& pts, const std::vector<Level>& levels, int l, LocationStats& st) {
  const Level& lv = levels[static_cast<std::size_t>(l)];
  track(pts, levels[static_cast<std::size_t>(l + 1)].mesh.V, lv.collapses, st);
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

// Rows of points located on levels[l] (its ids): every vertex of a level is its own id there.
std::vector<SurfaceLocation> rows_on_level(const std::vector<Tracked>& pts, const TriMesh& target) {
  std::vector<int> identity(static_cast<std::size_t>(target.num_vertices()));
  std::iota(identity.begin(), identity.end(), 0);
  return to_rows(pts, target, identity);
}

}  // namespace

std::vector<SurfaceLocation> locate_finest_on_level(const std::vector<Level>& levels, int level, LocationStats* stats) {
  if (levels.empty() || level < 0 || level >= static_cast<int>(levels.size()))
    throw std::invalid_argument("locate_finest_on_level: level " + std::to_string(level) + " out of range (" +
                                std::to_string(levels.size()) + " levels)");
  LocationStats st;
  const int L = static_cast<int>(levels.size()) - 1;
  std::vector<Tracked> pts = start_at_vertices(levels[static_cast<std::size_t>(L)].mesh);
  for (int l = L - 1; l >= level; --l) descend_one_level(pts, levels, l, st);
  std::vector<SurfaceLocation> out = rows_on_level(pts, levels[static_cast<std::size_t>(level)].mesh);
  if (stats) *stats = st;
  return out;
}

std::vector<std::vector<SurfaceLocation>> locate_finest_on_all_levels(const std::vector<Level>& levels) {
  if (levels.empty()) throw std::invalid_argument("locate_finest_on_all_levels: no levels");
  const int L = static_cast<int>(levels.size()) - 1;
  std::vector<std::vector<SurfaceLocation>> out(levels.size());
  LocationStats st;
  std::vector<Tracked> pts = start_at_vertices(levels[static_cast<std::size_t>(L)].mesh);
  out[static_cast<std::size_t>(L)] = rows_on_level(pts, levels[static_cast<std::size_t>(L)].mesh);
  for (int l = L - 1; l >= 0; --l) {
    descend_one_level(pts, levels, l, st);
    out[static_cast<std::size_t>(l)] = rows_on_level(pts, levels[static_cast<std::size_t>(l)].mesh);
  }
  return out;
}

}  // namespace pd
