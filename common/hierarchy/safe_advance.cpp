#include "hierarchy/safe_advance.h"

#include <cmath>
#include <limits>
#include <queue>
#include <stdexcept>
#include <tuple>

#include "physics/contact/ccd_additive.h"
#include "physics/contact/distance.h"

namespace pd {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A contact pair: point-triangle (p, t0, t1, t2), edge-edge (ea0, ea1, eb0, eb1) or a ground vertex.
struct Pair {
  enum Kind { PointTriangle, EdgeEdge, Ground } kind = PointTriangle;
  std::array<int, 4> v{{-1, -1, -1, -1}};
  int count = 4;              // stencil size (1 for ground)
  double thickness = -1.0;    // fixed at the first evaluation (the thickness rule in the header)
  double keep = 0.0;          // the gap it must keep (m): ratio r times its gap at the first evaluation
  bool close = false;         // it started much closer than the reference gap
  double floor = 0.0;         // keep never goes below this (m; see the header, "Floor")
  bool redirected = false;    // it has already turned its vertices once (see the header, "Sliding")
};

constexpr int kAccdIterations = 200;  // see the header

std::vector<Pair> make_pairs(const ContactPrimitives& prims, const CandidatePairs& candidates,
                             const GroundPlane* ground, int n) {
  std::vector<Pair> pairs;
  pairs.reserve(candidates.point_triangle.size() + candidates.edge_edge.size());
  for (const auto& [v, f] : candidates.point_triangle) {
    Pair p;
    p.v = {v, prims.faces(f, 0), prims.faces(f, 1), prims.faces(f, 2)};
    pairs.push_back(p);
  }
  for (const auto& [a, b] : candidates.edge_edge) {
    Pair p;
    p.kind = Pair::EdgeEdge;
    p.v = {prims.edges[a][0], prims.edges[a][1], prims.edges[b][0], prims.edges[b][1]};
    pairs.push_back(p);
  }
  if (ground)
    for (int i = 0; i < n; ++i)
      if (ground->vertex_collides[static_cast<std::size_t>(i)]) {
        Pair p;
        p.kind = Pair::Ground;
        p.v = {i, -1, -1, -1};
        p.count = 1;
        pairs.push_back(p);
      }
  return pairs;
}

double pair_distance(const Pair& p, const Vec<12>& x) {
  return std::sqrt(p.kind == Pair::PointTriangle ? point_triangle_squared_distance(x)
                                                 : edge_edge_squared_distance(x));
}

// The header's thickness rule: measure from the offset when the pair is beyond it.
double thickness_for(double distance, double offset) { return distance > offset ? offset : 0.0; }

void check_ground(const GroundPlane* ground, int n) {
  if (ground && static_cast<int>(ground->vertex_collides.size()) != n)
    throw std::invalid_argument("safe advance: ground.vertex_collides has " +
                                std::to_string(ground->vertex_collides.size()) + " entries for " +
                                std::to_string(n) + " vertices");
}

// The state of the motion. Vertex i moves on a line x_i(s) = o_i + (s - s0_i) w_i (m; w_i in m per
// unit progress) from progress s0_i on; it starts as o = x0, s0 = 0, w = target - x0, and a stop or
// a redirection at progress s restarts the line at its current position with w = 0 or a new w.
class Motion {
 public:
  Motion(const Positions& x0, const Positions& target)
      : origin_(x0), rate_(target - x0), since_(static_cast<std::size_t>(x0.rows()), 0.0) {}
  bool stopped(int i) const { return rate_.row(i).isZero(0.0); }
  Vec3 position(int i) const {
    return (origin_.row(i) + (s_ - since_[static_cast<std::size_t>(i)]) * rate_.row(i)).transpose();
  }
  // Displacement still to go from the current progress to s = 1 (zero once stopped).
  Vec3 remaining(int i) const { return ((1.0 - s_) * rate_.row(i)).transpose(); }
  Vec3 rate(int i) const { return rate_.row(i).transpose(); }
  double progress() const { return s_; }
  void advance_to(double s) { s_ = s; }
  // Restarts i's line here with rate w (zero: stop). Returns true if i was moving.
  bool redirect(int i, const Vec3& w) {
    if (stopped(i)) return false;
    origin_.row(i) = position(i).transpose();
    since_[static_cast<std::size_t>(i)] = s_;
    rate_.row(i) = w.transpose();
    return true;
  }
  bool stop(int i) { return redirect(i, Vec3::Zero()); }
  Positions result() const {
    Positions x(origin_.rows(), 3);
    for (int i = 0; i < origin_.rows(); ++i) x.row(i) = position(i).transpose();
    return x;
  }

 private:
  Positions origin_;
  Positions rate_;
  std::vector<double> since_;
  double s_ = 0.0;
};

// Unit direction from the pair's second primitive (triangle / edge b) toward its first (point /
// edge a), from the gradient of the squared distance with respect to the first primitive's vertices
// (= 2 (closest point on a - closest point on b) for the point, summed over an edge's two ends).
Vec3 pair_normal(const Pair& p, const Vec<12>& x12) {
  Vec3 n = Vec3::Zero();
  if (p.kind == Pair::PointTriangle) {
    n = point_triangle_squared_distance_gradient(x12).head<3>();
  } else {
    const Vec<12> g = edge_edge_squared_distance_gradient(x12);
    n = g.segment<3>(0) + g.segment<3>(3);
  }
  const double len = n.norm();
  return len > 0.0 ? Vec3(n / len) : Vec3::Zero();
}

}  // namespace

namespace {

// Calls f(pair, d) for every pair within `radius` of contact at x: d is the pair's distance (m; for
// a ground vertex its height above the plane).
template <class F>
void for_each_gap(const ContactPrimitives& prims, const Positions& x, double offset, double radius,
                  const GroundPlane* ground, F&& f) {
  check_ground(ground, static_cast<int>(x.rows()));
  const CandidatePairs candidates = find_candidates(prims, x, offset + radius);
  for (const Pair& p : make_pairs(prims, candidates, ground, static_cast<int>(x.rows()))) {
    double d = 0.0;
    if (p.kind == Pair::Ground) {
      d = ground->normal.dot(x.row(p.v[0]).transpose()) - ground->height;
    } else {
      Vec<12> x12;
      for (int k = 0; k < 4; ++k) x12.segment<3>(3 * k) = x.row(p.v[static_cast<std::size_t>(k)]).transpose();
      d = pair_distance(p, x12);
    }
    f(p, d);
  }
}

}  // namespace

std::vector<PairGap> pair_gaps(const ContactPrimitives& prims, const Positions& x, double offset, double radius,
                               const GroundPlane* ground) {
  std::vector<PairGap> out;
  for_each_gap(prims, x, offset, radius, ground,
               [&](const Pair& p, double d) { out.push_back({p.v, d, d - thickness_for(d, offset)}); });
  return out;
}

double min_contact_gap(const ContactPrimitives& prims, const Positions& x, double offset, double radius,
                       const GroundPlane* ground) {
  double best = kInf;
  for (const PairGap& p : pair_gaps(prims, x, offset, radius, ground)) best = std::min(best, p.gap);
  return best;
}

std::vector<std::array<int, 4>> pairs_below_gap(const ContactPrimitives& prims, const Positions& x,
                                                double offset, double min_gap, const GroundPlane* ground) {
  std::vector<std::array<int, 4>> out;
  for (const PairGap& p : pair_gaps(prims, x, offset, min_gap, ground))
    if (p.distance - offset < min_gap) out.push_back(p.stencil);
  return out;
}

AdvanceReport advance_toward_targets(const ContactPrimitives& prims, double offset, double gap,
                                     const GroundPlane* ground, const Positions& target, Positions& x,
                                     const AdvanceSettings& settings, const std::vector<int>* vertex_patch) {
  const int n = static_cast<int>(x.rows());
  if (target.rows() != n || target.cols() != 3 || x.cols() != 3)
    throw std::invalid_argument("safe advance: positions and targets must both be (" + std::to_string(n) + ", 3)");
  if (!(gap > 0.0) || !std::isfinite(gap))
    throw std::invalid_argument("safe advance: the reference gap must be positive and finite");
  check_ground(ground, n);
  if (vertex_patch && static_cast<int>(vertex_patch->size()) != n)
    throw std::invalid_argument("safe advance: vertex_patch needs one entry per vertex");

  AdvanceReport report;
  const Positions start = x;
  const CandidatePairs candidates = find_swept_candidates(prims, start, target, offset + gap);
  std::vector<Pair> pairs = make_pairs(prims, candidates, ground, n);
  report.candidate_pairs = static_cast<int>(candidates.point_triangle.size() + candidates.edge_edge.size());

  std::vector<std::vector<int>> pairs_of_vertex(static_cast<std::size_t>(n));
  for (int k = 0; k < static_cast<int>(pairs.size()); ++k)
    for (int j = 0; j < pairs[static_cast<std::size_t>(k)].count; ++j)
      pairs_of_vertex[static_cast<std::size_t>(pairs[static_cast<std::size_t>(k)].v[static_cast<std::size_t>(j)])]
          .push_back(k);

  Motion motion(start, target);
  std::vector<int> version(pairs.size(), 0);
  // (s_p, pair, version): the earliest certified progress first; ties broken by pair index, so the
  // order of events (and so the result) is deterministic.
  using Event = std::tuple<double, int, int>;
  std::priority_queue<Event, std::vector<Event>, std::greater<Event>> events;

  // Thickness and the gap to keep, from the pair's distance d when it is first seen.
  auto first_evaluation = [&](Pair& p, double d) {
    p.thickness = thickness_for(d, offset);
    const double g0 = d - p.thickness;
    bool one_patch = vertex_patch != nullptr && p.kind != Pair::Ground;
    for (int j = 0; one_patch && j < 4; ++j) {
      const int patch = (*vertex_patch)[static_cast<std::size_t>(p.v[static_cast<std::size_t>(j)])];
      one_patch = patch >= 0 && patch == (*vertex_patch)[static_cast<std::size_t>(p.v[0])];
    }
    p.close = !one_patch && g0 < settings.close_fraction * gap;
    p.keep = (p.close ? settings.close_ratio : settings.far_ratio) * g0;
    p.floor = one_patch ? 0.0 : std::min(settings.close_fraction * settings.far_ratio * gap, settings.close_ratio * g0);
    p.keep = std::max(p.keep, p.floor);
  };
  // The progress up to which pair k's current motion is certified (+inf: not bounded before s = 1).
  auto evaluate = [&](int k) -> double {
    Pair& p = pairs[static_cast<std::size_t>(k)];
    const double s = motion.progress();
    ++report.accd_queries;
    if (p.kind == Pair::Ground) {
      const Vec3 pos = motion.position(p.v[0]);
      const double along = ground->normal.dot(motion.remaining(p.v[0]));
      const double d = ground->normal.dot(pos) - ground->height;
      if (p.thickness < 0.0) first_evaluation(p, d);
      if (!(along < 0.0)) return kInf;
      const double g_now = d - p.thickness;
      if (!(g_now > p.keep)) return s;
      const double t = (g_now - p.keep) / -along;  // the gap falls linearly along the motion
      return t >= 1.0 ? kInf : s + t * (1.0 - s);
    }
    Vec<12> x12, dx12;
    bool moving = false;
    for (int j = 0; j < 4; ++j) {
      const int v = p.v[static_cast<std::size_t>(j)];
      x12.segment<3>(3 * j) = motion.position(v);
      dx12.segment<3>(3 * j) = motion.remaining(v);
      moving = moving || !motion.stopped(v);
    }
    if (!moving) return kInf;
    const double d = pair_distance(p, x12);
    if (p.thickness < 0.0) first_evaluation(p, d);
    // ACCD stops where the gap falls below (1 - eta) of its value now; ask for the fraction that
    // still keeps p.keep. Past 0.999 ACCD's resolution ends: the pair stops here.
    const double g_now = d - p.thickness;
    if (!(g_now > 0.0)) return s;  // touching already: nothing may move it (bad input)
    const double fraction = p.keep / g_now;
    if (!(fraction <= 0.999)) return s;
    const double eta = 1.0 - fraction;
    const double t = p.kind == Pair::PointTriangle ? point_triangle_accd(x12, dx12, eta, p.thickness, 1.0, nullptr, kAccdIterations)
                                                   : edge_edge_accd(x12, dx12, eta, p.thickness, 1.0, nullptr, kAccdIterations);
    return t >= 1.0 ? kInf : s + t * (1.0 - s);
  };
  auto schedule = [&](int k) {
    const int ver = ++version[static_cast<std::size_t>(k)];
    const double sp = evaluate(k);
    if (sp < kInf) events.emplace(sp, k, ver);
  };

  for (int k = 0; k < static_cast<int>(pairs.size()); ++k) schedule(k);
  std::vector<int> redirects(static_cast<std::size_t>(n), 0);
  std::vector<int> changed;
  while (!events.empty()) {
    const auto [sp, k, ver] = events.top();
    events.pop();
    if (ver != version[static_cast<std::size_t>(k)]) continue;  // superseded by a re-evaluation
    motion.advance_to(std::max(sp, motion.progress()));
    ++report.events;
    Pair& p = pairs[static_cast<std::size_t>(k)];
    report.close_events += p.close;
    report.ground_events += p.kind == Pair::Ground;
    // The pair's normal (from its second primitive toward its first) and which side each vertex is on.
    Vec3 normal = Vec3::Zero();
    if (p.kind == Pair::Ground) {
      normal = ground->normal;
    } else {
      Vec<12> x12;
      for (int j = 0; j < 4; ++j) x12.segment<3>(3 * j) = motion.position(p.v[static_cast<std::size_t>(j)]);
      normal = pair_normal(p, x12);
    }
    auto side = [&](int j) { return p.kind == Pair::EdgeEdge ? (j < 2 ? 1.0 : -1.0) : (j == 0 ? 1.0 : -1.0); };
    changed.clear();
    bool approaching = false;
    for (int j = 0; j < p.count; ++j) {
      const int v = p.v[static_cast<std::size_t>(j)];
      if (motion.stopped(v)) continue;
      const Vec3 w = motion.rate(v);
      if (!(side(j) * w.dot(normal) < 0.0)) continue;
      approaching = true;
      if (!p.redirected && redirects[static_cast<std::size_t>(v)] < settings.max_redirects) {
        ++redirects[static_cast<std::size_t>(v)];
        ++report.redirections;
        motion.redirect(v, w - w.dot(normal) * normal);
      } else {
        motion.stop(v);
        ++report.stopped_vertices;
      }
      changed.push_back(v);
    }
    if (approaching) {
      p.redirected = true;
      // Slack for what the first-order projection misses (rotation, sliding off an edge): half the
      // kept gap for a far pair, 1% for a close one (which must not come much closer).
      p.keep = std::max(p.keep * (p.close ? 0.99 : 0.5), p.floor);
    } else {
      // Bounded by second-order motion alone: stop the stencil (PSQ's rule).
      for (int j = 0; j < p.count; ++j)
        if (motion.stop(p.v[static_cast<std::size_t>(j)])) {
          ++report.stopped_vertices;
          changed.push_back(p.v[static_cast<std::size_t>(j)]);
        }
    }
    for (int v : changed)
      for (int q : pairs_of_vertex[static_cast<std::size_t>(v)]) schedule(q);
  }
  motion.advance_to(1.0);  // no pair bounds the rest of the motion
  x = motion.result();
  return report;
}

}  // namespace pd
