#include "physics/contact/barrier_potential.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "physics/contact/barrier.h"
#include "physics/contact/ccd_additive.h"
#include "physics/contact/distance.h"
#include "physics/contact/edge_edge_mollifier.h"
#include "physics/element_loops.h"

namespace pd {

namespace {

constexpr int kPointTriangle = 0, kEdgeEdge = 1;

Vec<12> gather(const Eigen::VectorXd& x, const std::array<int, 4>& v) {
  Vec<12> out;
  for (int k = 0; k < 4; ++k) out.segment<3>(3 * k) = x.segment<3>(3 * v[k]);
  return out;
}

std::array<int, 4> point_triangle_stencil(const ContactPrimitives& p, const std::array<int, 2>& pair) {
  return {pair[0], p.faces(pair[1], 0), p.faces(pair[1], 1), p.faces(pair[1], 2)};
}

std::array<int, 4> edge_edge_stencil(const ContactPrimitives& p, const std::array<int, 2>& pair) {
  const auto& a = p.edges[pair[0]];
  const auto& b = p.edges[pair[1]];
  return {a[0], a[1], b[0], b[1]};
}

// ---- Friction: closest points, normals, tangent bases -----------------------------------------

// Parameter in [0, 1] of the point of segment (a, b) closest to p; 0 for a zero-length segment.
double segment_parameter(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 e = b - a;
  const double ee = e.squaredNorm();
  if (!(ee > 0.0)) return 0.0;
  return std::clamp((p - a).dot(e) / ee, 0.0, 1.0);
}

// v normalised, or `fallback` normalised if v is zero (or +z if both are).
Vec3 unit_or(const Vec3& v, const Vec3& fallback) {
  if (v.squaredNorm() > 0.0) return v.normalized();
  if (fallback.squaredNorm() > 0.0) return fallback.normalized();
  return Vec3::UnitZ();
}

// Orthonormal (t0, t1) with n x t0 = t1 and both orthogonal to the unit normal n; t0 is `along` with
// its normal component removed, or, if `along` is (nearly) parallel to n, the coordinate axis least
// aligned with n, so the basis is defined for every n.
Eigen::Matrix<double, 3, 2> tangent_basis(const Vec3& n, const Vec3& along) {
  Vec3 t0 = along - along.dot(n) * n;
  if (!(t0.squaredNorm() > 1e-12 * along.squaredNorm())) {  // also taken for along = 0
    Eigen::Index i = 0;
    n.cwiseAbs().minCoeff(&i);
    t0 = Vec3::Unit(i) - n[i] * n;
  }
  t0.normalize();
  Eigen::Matrix<double, 3, 2> T;
  T << t0, n.cross(t0);
  return T;
}

// Weights w (sum_k w_k x_k = closest point on the first primitive - closest point on the second), the
// unit contact normal and the direction the first tangent follows, for one pair.
//
// Weights: the closest points of the pair's distance type, clamped to the primitives, so they are
// convex combinations on each primitive. Normal (the direction friction never acts along): the
// triangle's normal for every point-triangle type and ea x eb for every edge-edge pair that is not
// (nearly) parallel, as in IPC's friction. Not the vector between the closest points: a pair is
// active up to dhat + offset away, so a cloth vertex resting on a flat tessellated obstacle also
// pairs with the triangles beside the one under it; their closest-point vectors lean sideways, and a
// basis orthogonal to them contains the obstacle's normal, so static friction would hold the cloth at
// its height and keep it from sliding (measured: a sheet on a 35 degree slope with friction 0.5 did
// not move). Parallel edges have no ea x eb and fall back to the vector between the closest points;
// their barrier, and so their normal force, is mollified to nearly zero anyway.
struct ContactFrame {
  std::array<double, 4> weights{{0, 0, 0, 0}};
  Vec3 normal = Vec3::UnitZ();
  Vec3 along = Vec3::UnitX();
};

ContactFrame point_triangle_frame(const Vec<12>& x12) {
  const Vec3 p = x12.segment<3>(0);
  const std::array<Vec3, 3> t{{x12.segment<3>(3), x12.segment<3>(6), x12.segment<3>(9)}};
  const Vec3 e0 = t[1] - t[0], e1 = t[2] - t[0];
  const Vec3 tri_normal = e0.cross(e1);
  std::array<double, 3> b{{0, 0, 0}};  // barycentric coordinates of the closest point
  const PointTriangleType type = point_triangle_type(x12);
  const int i = static_cast<int>(type);
  if (type == PointTriangleType::P_T) {
    // Projection on the plane: minimise |p - t0 - b1 e0 - b2 e1|^2 (2x2 normal equations).
    const Vec3 r = p - t[0];
    const double a00 = e0.dot(e0), a01 = e0.dot(e1), a11 = e1.dot(e1);
    const double r0 = e0.dot(r), r1 = e1.dot(r);
    const double det = a00 * a11 - a01 * a01;  // > 0: P_T is only chosen for non-degenerate triangles
    b[1] = (a11 * r0 - a01 * r1) / det;
    b[2] = (a00 * r1 - a01 * r0) / det;
    b[0] = 1.0 - b[1] - b[2];
  } else if (i <= 2) {  // P_T0..2: a vertex
    b[i] = 1.0;
  } else {  // P_E0..2: edge (t_j, t_{j+1})
    const int j = i - 3, k = (j + 1) % 3;
    const double s = segment_parameter(p, t[j], t[k]);
    b[j] = 1.0 - s;
    b[k] = s;
  }
  ContactFrame f;
  f.weights = {1.0, -b[0], -b[1], -b[2]};
  const Vec3 c = b[0] * t[0] + b[1] * t[1] + b[2] * t[2];
  f.normal = unit_or(tri_normal, p - c);
  f.along = e0;
  return f;
}

ContactFrame edge_edge_frame(const Vec<12>& x12) {
  const Vec3 a0 = x12.segment<3>(0), a1 = x12.segment<3>(3), b0 = x12.segment<3>(6), b1 = x12.segment<3>(9);
  const Vec3 ea = a1 - a0, eb = b1 - b0;
  double s = 0.0, t = 0.0;  // closest points a0 + s ea, b0 + t eb
  using T = EdgeEdgeType;
  const EdgeEdgeType type = edge_edge_type(x12);
  switch (type) {
    case T::EA0_EB0: s = 0; t = 0; break;
    case T::EA0_EB1: s = 0; t = 1; break;
    case T::EA1_EB0: s = 1; t = 0; break;
    case T::EA1_EB1: s = 1; t = 1; break;
    case T::EA_EB0: t = 0; s = segment_parameter(b0, a0, a1); break;
    case T::EA_EB1: t = 1; s = segment_parameter(b1, a0, a1); break;
    case T::EA0_EB: s = 0; t = segment_parameter(a0, b0, b1); break;
    case T::EA1_EB: s = 1; t = segment_parameter(a1, b0, b1); break;
    case T::EA_EB: {
      // Closest points of the two lines: minimise |r + s ea - t eb|^2, r = a0 - b0. The classifier
      // only picks EA_EB for non-parallel edges with both parameters inside [0, 1]; the clamp
      // removes round-off.
      const Vec3 r = a0 - b0;
      const double a = ea.dot(ea), b = ea.dot(eb), c = eb.dot(eb), d = ea.dot(r), e = eb.dot(r);
      const double det = a * c - b * b;
      s = std::clamp((b * e - c * d) / det, 0.0, 1.0);
      t = std::clamp((a * e - b * d) / det, 0.0, 1.0);
      break;
    }
  }
  ContactFrame f;
  f.weights = {1.0 - s, s, -(1.0 - t), -t};
  const Vec3 between = (a0 + s * ea) - (b0 + t * eb);
  // ea x eb unless the edges are parallel to within ~1e-3 rad (sin^2 < 1e-6), where its direction is
  // round-off; then the vector between the closest points.
  const Vec3 cross = ea.cross(eb);
  const bool parallel = !(cross.squaredNorm() > 1e-6 * ea.squaredNorm() * eb.squaredNorm());
  f.normal = parallel ? unit_or(between, cross) : cross.normalized();
  f.along = ea;
  return f;
}

}  // namespace

BarrierPotential::BarrierPotential(ContactPrimitives primitives, const Positions& rest,
                                   const ContactSettings& settings)
    : primitives_(std::move(primitives)), settings_(settings) {
  if (!(settings_.dhat > 0) || !(settings_.offset >= 0) || !(settings_.kappa >= 0))
    throw std::invalid_argument("BarrierPotential: need dhat > 0, offset >= 0, kappa >= 0");
  // |e_rest|^2 per edge: eps_x of a pair is kEdgeEdgeMollifierScale * |ea|^2 |eb|^2.
  edge_rest_length2_.reserve(primitives_.edges.size());
  for (const auto& e : primitives_.edges)
    edge_rest_length2_.push_back((rest.row(e[1]) - rest.row(e[0])).squaredNorm());
}

const CandidatePairs& BarrierPotential::candidates(const Eigen::VectorXd& x) const {
  if (cached_x_.size() != x.size() || cached_x_ != x) {
    cached_pairs_ = find_candidates(primitives_, as_rows(x), settings_.dhat + settings_.offset);
    cached_x_ = x;
  }
  return cached_pairs_;
}

void BarrierPotential::set_thin_pairs(CandidatePairs pairs) {
  for (auto* list : {&pairs.point_triangle, &pairs.edge_edge}) {
    std::sort(list->begin(), list->end());
    list->erase(std::unique(list->begin(), list->end()), list->end());
  }
  thin_ = std::move(pairs);
  active_key_.clear();  // the pairs' offsets changed
}

double BarrierPotential::pair_offset(int kind, const std::array<int, 2>& pair) const {
  const auto& list = kind == kPointTriangle ? thin_.point_triangle : thin_.edge_edge;
  return std::binary_search(list.begin(), list.end(), pair) ? 0.0 : settings_.offset;
}

double BarrierPotential::pair_dhat(double offset) const {
  return offset == settings_.offset ? settings_.dhat : settings_.dhat + settings_.offset;
}

CandidatePairs BarrierPotential::pairs_within_offset(const Eigen::VectorXd& x) const {
  CandidatePairs out;
  const double offset2 = settings_.offset * settings_.offset;
  const CandidatePairs pairs = find_candidates(primitives_, as_rows(x), settings_.offset);
  for (const auto& pair : pairs.point_triangle)
    if (point_triangle_squared_distance(gather(x, point_triangle_stencil(primitives_, pair))) <= offset2)
      out.point_triangle.push_back(pair);
  for (const auto& pair : pairs.edge_edge)
    if (edge_edge_squared_distance(gather(x, edge_edge_stencil(primitives_, pair))) <= offset2)
      out.edge_edge.push_back(pair);
  return out;
}

const std::vector<BarrierPotential::ActivePair>& BarrierPotential::active_pairs(const Eigen::VectorXd& x) const {
  if (active_key_.matches(x)) return cached_active_;
  active_key_.clear();  // until refilled: an exception below must not leave a half-built cache
  collect_active_pairs(x, candidates(x), cached_active_);
  active_key_.set(x);
  return cached_active_;
}

void BarrierPotential::collect_active_pairs(const Eigen::VectorXd& x, const CandidatePairs& pairs,
                                            std::vector<ActivePair>& out) const {
  const double active_d2 = barrier_active_squared_distance(settings_.dhat, settings_.offset);
  const double thin_active_d2 = barrier_active_squared_distance(settings_.dhat + settings_.offset, 0.0);
  const bool any_thin = !thin_.point_triangle.empty() || !thin_.edge_edge.empty();
  const int num_pt = static_cast<int>(pairs.point_triangle.size());
  const int num_candidates = num_pt + static_cast<int>(pairs.edge_edge.size());
  // Candidate i as an ActivePair, but for d2 (everything but the distance).
  const auto make_pair = [&](int i, ActivePair& p) {
    if (i < num_pt) {
      const auto& pair = pairs.point_triangle[static_cast<size_t>(i)];
      p.kind = kPointTriangle;
      p.v = point_triangle_stencil(primitives_, pair);
      p.eps_x = 0.0;
      p.offset = any_thin ? pair_offset(kPointTriangle, pair) : settings_.offset;
    } else {
      const auto& pair = pairs.edge_edge[static_cast<size_t>(i - num_pt)];
      p.kind = kEdgeEdge;
      p.v = edge_edge_stencil(primitives_, pair);
      p.eps_x = kEdgeEdgeMollifierScale * edge_rest_length2_[pair[0]] * edge_rest_length2_[pair[1]];
      p.offset = any_thin ? pair_offset(kEdgeEdge, pair) : settings_.offset;
    }
    p.x12 = gather(x, p.v);
  };
  // Two passes on every element thread: each candidate's squared distance and whether it is active
  // (9 bytes per candidate: a whole ActivePair per candidate was ~140 bytes of fresh memory per
  // call, and a third to a half of the candidates are active), then the active ones, in candidate
  // order. The same pairs and values as one pass.
  std::vector<double> d2(static_cast<size_t>(num_candidates));
  std::vector<char> active(static_cast<size_t>(num_candidates), 0);
  parallel_for_index(num_candidates, [&](int i) {
    ActivePair p;
    make_pair(i, p);
    const double d = p.kind == kPointTriangle ? point_triangle_squared_distance(p.x12) : edge_edge_squared_distance(p.x12);
    d2[static_cast<size_t>(i)] = d;
    active[static_cast<size_t>(i)] = d < (p.offset == settings_.offset ? active_d2 : thin_active_d2);
  });
  std::vector<int> index;
  for (int i = 0; i < num_candidates; ++i)
    if (active[static_cast<size_t>(i)]) index.push_back(i);
  out.resize(index.size());
  parallel_for_index(static_cast<int>(index.size()), [&](int j) {
    ActivePair& p = out[static_cast<size_t>(j)];
    make_pair(index[static_cast<size_t>(j)], p);
    p.d2 = d2[static_cast<size_t>(index[static_cast<size_t>(j)])];
  });
}

template <class F>
void BarrierPotential::for_each_active_pair(const Eigen::VectorXd& x, F&& f) const {
  for (const ActivePair& p : active_pairs(x)) f(p.kind, p.v, p.x12, p.d2, p.eps_x, p.offset);
}

double BarrierPotential::pair_energy(const ActivePair& p) const {
  const double b = barrier(p.d2, pair_dhat(p.offset), p.offset);
  return p.kind == kEdgeEdge ? edge_edge_mollifier(p.x12, p.eps_x) * b : b;
}

Vec<12> BarrierPotential::pair_gradient(const ActivePair& p) const {
  const double db = barrier_first_derivative(p.d2, pair_dhat(p.offset), p.offset);
  if (p.kind == kPointTriangle) return db * point_triangle_squared_distance_gradient(p.x12);
  // d(m b) = m b' grad d2 + b grad m
  const double b = barrier(p.d2, pair_dhat(p.offset), p.offset);
  return edge_edge_mollifier(p.x12, p.eps_x) * db * edge_edge_squared_distance_gradient(p.x12) +
         b * edge_edge_mollifier_gradient(p.x12, p.eps_x);
}

Mat<12> BarrierPotential::pair_hessian(const ActivePair& p) const {
  const double db = barrier_first_derivative(p.d2, pair_dhat(p.offset), p.offset);
  const double ddb = barrier_second_derivative(p.d2, pair_dhat(p.offset), p.offset);
  if (p.kind == kPointTriangle) {
    const Vec<12> g = point_triangle_squared_distance_gradient(p.x12);
    return ddb * g * g.transpose() + db * point_triangle_squared_distance_hessian(p.x12);
  }
  // Hessian of m b(d2): m (b'' g g^T + b' H_d) + b H_m + b' (g_m g^T + g g_m^T)
  const Vec<12> g = edge_edge_squared_distance_gradient(p.x12);
  const Vec<12> gm = edge_edge_mollifier_gradient(p.x12, p.eps_x);
  const double m = edge_edge_mollifier(p.x12, p.eps_x);
  const double b = barrier(p.d2, pair_dhat(p.offset), p.offset);
  return m * (ddb * g * g.transpose() + db * edge_edge_squared_distance_hessian(p.x12)) +
         b * edge_edge_mollifier_hessian(p.x12, p.eps_x) + db * (gm * g.transpose() + g * gm.transpose());
}

// value, gradient and Hessian run on every element thread with thread-count-independent results
// (physics/element_loops.h); sums go in active_pairs' order.
double BarrierPotential::value(const Eigen::VectorXd& x) const {
  const std::vector<ActivePair>& pairs = active_pairs(x);
  return settings_.kappa * sum_element_energies(static_cast<int>(pairs.size()),
                                                [&](int i) { return pair_energy(pairs[static_cast<size_t>(i)]); });
}

Eigen::VectorXd BarrierPotential::unit_stiffness_gradient(const Eigen::VectorXd& x) const {
  return unit_stiffness_gradient(active_pairs(x), x.size());
}

Eigen::VectorXd BarrierPotential::unit_stiffness_gradient(const std::vector<ActivePair>& pairs, Eigen::Index n) const {
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
  add_element_gradients<4>(
      static_cast<int>(pairs.size()), [&](int i) { return pairs[static_cast<size_t>(i)].v; },
      [&](int i) { return pair_gradient(pairs[static_cast<size_t>(i)]); }, g);
  return g;
}

void BarrierPotential::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  if (settings_.kappa == 0.0) return;
  grad += settings_.kappa * unit_stiffness_gradient(x);
}

// Pairs that are not candidates at `reference` are farther apart there than the candidate radius
// dhat + offset, the barrier's support; within kHessianProductStep of it they can come inside only
// by a sliver where the barrier and its first two derivatives vanish (b(d) ~ (d - dhat)^2 near
// dhat), so dropping them changes the gradient by far less than a difference of gradients resolves.
// The active set itself is computed at x, and not cached: x is a neighbour, not an iterate.
void BarrierPotential::add_gradient_near(const Eigen::VectorXd& reference, const Eigen::VectorXd& x,
                                         Eigen::VectorXd& grad) const {
  if (settings_.kappa == 0.0) return;
  std::vector<ActivePair> pairs;
  collect_active_pairs(x, candidates(reference), pairs);
  grad += settings_.kappa * unit_stiffness_gradient(pairs, x.size());
}

void BarrierPotential::add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                                   HessianAssembly& hessian) const {
  const double kappa = settings_.kappa;
  const std::vector<ActivePair>& pairs = active_pairs(x);
  add_element_hessians<4>(
      static_cast<int>(pairs.size()), [&](int i) { return pairs[static_cast<size_t>(i)].v; },
      [&](int i) { return project_hessian<12>(kappa * pair_hessian(pairs[static_cast<size_t>(i)]), projection); },
      hessian);
}

double BarrierPotential::max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const {
  const Eigen::VectorXd x1 = x + dx;
  // Pairs that come within the offset anywhere along the step have overlapping swept boxes
  // inflated by the offset.
  const CandidatePairs pairs = find_swept_candidates(primitives_, as_rows(x), as_rows(x1), settings_.offset);
  double alpha = 1.0;
  for (const auto& pair : pairs.point_triangle) {
    const auto s = point_triangle_stencil(primitives_, pair);
    alpha = std::min(alpha, point_triangle_accd(gather(x, s), gather(dx, s), settings_.ccd_ratio,
                                                pair_offset(kPointTriangle, pair), alpha));
  }
  for (const auto& pair : pairs.edge_edge) {
    const auto s = edge_edge_stencil(primitives_, pair);
    alpha = std::min(alpha, edge_edge_accd(gather(x, s), gather(dx, s), settings_.ccd_ratio,
                                           pair_offset(kEdgeEdge, pair), alpha));
  }
  return alpha;
}

ContactStats BarrierPotential::stats(const Eigen::VectorXd& x) const {
  ContactStats s;
  s.min_gap = std::numeric_limits<double>::infinity();
  for_each_active_pair(x, [&](int kind, const std::array<int, 4>&, const Vec<12>&, double d2, double, double offset) {
    const double gap = std::sqrt(d2) - offset;
    s.min_gap = std::min(s.min_gap, gap);
    if (gap < pair_dhat(offset)) ++(kind == kPointTriangle ? s.active_point_triangle : s.active_edge_edge);
  });
  return s;
}

void BarrierPotential::set_friction(Eigen::MatrixXd mu) {
  const Eigen::Index objects = static_cast<Eigen::Index>(primitives_.object_self_contact.size());
  if (mu.size() != 0) {
    if (mu.rows() != objects || mu.cols() != objects)
      throw std::invalid_argument("BarrierPotential::set_friction: mu must be #objects x #objects");
    if (!mu.allFinite() || (mu.array() < 0.0).any())
      throw std::invalid_argument("BarrierPotential::set_friction: mu must be finite and >= 0");
    if (mu != mu.transpose()) throw std::invalid_argument("BarrierPotential::set_friction: mu must be symmetric");
  }
  friction_mu_ = std::move(mu);
}

void BarrierPotential::friction_contacts(const Eigen::VectorXd& x, std::vector<FrictionContact>& out) const {
  if (friction_mu_.size() == 0) return;
  const std::vector<int>& object = primitives_.vertex_object;
  for_each_active_pair(x, [&](int kind, const std::array<int, 4>& v, const Vec<12>& x12, double d2, double eps_x, double offset) {
    // Objects of the two primitives: the point and the face (PT), edge a and edge b (EE).
    const double mu = friction_mu_(object[v[0]], object[v[kind == kPointTriangle ? 1 : 2]]);
    if (!(mu > 0.0)) return;
    const ContactFrame frame = kind == kPointTriangle ? point_triangle_frame(x12) : edge_edge_frame(x12);
    FrictionContact c;
    c.vertices = v;
    c.count = 4;
    c.weights = frame.weights;
    c.basis = tangent_basis(frame.normal, frame.along);
    // |d (kappa b) / d d| with d = sqrt(d2): b is a function of d2 and d(d2)/dd = 2 d.
    c.normal_force = -settings_.kappa * barrier_first_derivative(d2, pair_dhat(offset), offset) * 2.0 *
                     std::sqrt(d2);
    if (kind == kEdgeEdge) c.normal_force *= edge_edge_mollifier(x12, eps_x);
    c.mu = mu;
    out.push_back(c);
  });
}

}  // namespace pd
