#include "physics/contact/barrier_potential.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "physics/contact/barrier.h"
#include "physics/contact/ccd_additive.h"
#include "physics/contact/distance.h"
#include "physics/contact/edge_edge_mollifier.h"

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

template <class F>
void BarrierPotential::for_each_active_pair(const Eigen::VectorXd& x, F&& f) const {
  const CandidatePairs& pairs = candidates(x);
  const double active_d2 = barrier_active_squared_distance(settings_.dhat, settings_.offset);
  for (const auto& pair : pairs.point_triangle) {
    const auto stencil = point_triangle_stencil(primitives_, pair);
    const Vec<12> x12 = gather(x, stencil);
    const double d2 = point_triangle_squared_distance(x12);
    if (d2 < active_d2) f(kPointTriangle, stencil, x12, d2, 0.0);
  }
  for (const auto& pair : pairs.edge_edge) {
    const auto stencil = edge_edge_stencil(primitives_, pair);
    const Vec<12> x12 = gather(x, stencil);
    const double d2 = edge_edge_squared_distance(x12);
    const double eps_x = kEdgeEdgeMollifierScale * edge_rest_length2_[pair[0]] * edge_rest_length2_[pair[1]];
    if (d2 < active_d2) f(kEdgeEdge, stencil, x12, d2, eps_x);
  }
}

double BarrierPotential::value(const Eigen::VectorXd& x) const {
  double e = 0.0;
  for_each_active_pair(x, [&](int kind, const std::array<int, 4>&, const Vec<12>& x12, double d2, double eps_x) {
    const double b = barrier(d2, settings_.dhat, settings_.offset);
    e += kind == kEdgeEdge ? edge_edge_mollifier(x12, eps_x) * b : b;
  });
  return settings_.kappa * e;
}

Eigen::VectorXd BarrierPotential::unit_stiffness_gradient(const Eigen::VectorXd& x) const {
  Eigen::VectorXd g = Eigen::VectorXd::Zero(x.size());
  for_each_active_pair(x, [&](int kind, const std::array<int, 4>& v, const Vec<12>& x12, double d2, double eps_x) {
    const double db = barrier_first_derivative(d2, settings_.dhat, settings_.offset);
    Vec<12> ge;
    if (kind == kPointTriangle) {
      ge = db * point_triangle_squared_distance_gradient(x12);
    } else {
      // d(m b) = m b' grad d2 + b grad m
      const double b = barrier(d2, settings_.dhat, settings_.offset);
      ge = edge_edge_mollifier(x12, eps_x) * db * edge_edge_squared_distance_gradient(x12) +
           b * edge_edge_mollifier_gradient(x12, eps_x);
    }
    for (int k = 0; k < 4; ++k) g.segment<3>(3 * v[k]) += ge.segment<3>(3 * k);
  });
  return g;
}

void BarrierPotential::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  if (settings_.kappa == 0.0) return;
  grad += settings_.kappa * unit_stiffness_gradient(x);
}

void BarrierPotential::add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                                   HessianAssembly& hessian) const {
  const double kappa = settings_.kappa;
  for_each_active_pair(x, [&](int kind, const std::array<int, 4>& v, const Vec<12>& x12, double d2, double eps_x) {
    const double db = barrier_first_derivative(d2, settings_.dhat, settings_.offset);
    const double ddb = barrier_second_derivative(d2, settings_.dhat, settings_.offset);
    Mat<12> H;
    if (kind == kPointTriangle) {
      const Vec<12> g = point_triangle_squared_distance_gradient(x12);
      H = ddb * g * g.transpose() + db * point_triangle_squared_distance_hessian(x12);
    } else {
      // Hessian of m b(d2): m (b'' g g^T + b' H_d) + b H_m + b' (g_m g^T + g g_m^T)
      const Vec<12> g = edge_edge_squared_distance_gradient(x12);
      const Vec<12> gm = edge_edge_mollifier_gradient(x12, eps_x);
      const double m = edge_edge_mollifier(x12, eps_x);
      const double b = barrier(d2, settings_.dhat, settings_.offset);
      H = m * (ddb * g * g.transpose() + db * edge_edge_squared_distance_hessian(x12)) +
          b * edge_edge_mollifier_hessian(x12, eps_x) + db * (gm * g.transpose() + g * gm.transpose());
    }
    hessian.add<4>(v, project_hessian<12>(kappa * H, projection));
  });
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
                                                settings_.offset, alpha));
  }
  for (const auto& pair : pairs.edge_edge) {
    const auto s = edge_edge_stencil(primitives_, pair);
    alpha = std::min(alpha, edge_edge_accd(gather(x, s), gather(dx, s), settings_.ccd_ratio,
                                           settings_.offset, alpha));
  }
  return alpha;
}

ContactStats BarrierPotential::stats(const Eigen::VectorXd& x) const {
  ContactStats s;
  s.min_gap = std::numeric_limits<double>::infinity();
  const double dhat = settings_.dhat;
  for_each_active_pair(x, [&](int kind, const std::array<int, 4>&, const Vec<12>&, double d2, double) {
    const double gap = std::sqrt(d2) - settings_.offset;
    s.min_gap = std::min(s.min_gap, gap);
    if (gap < dhat) ++(kind == kPointTriangle ? s.active_point_triangle : s.active_edge_edge);
  });
  return s;
}

}  // namespace pd
