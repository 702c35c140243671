// Tests of the contact distance primitives (physics/contact/distance.h): classification, per-type
// closed-form derivatives, agreement with a brute-force minimisation, continuity and invariance.
// Positions are in metres, O(1) in size; configurations are random with fixed seeds.
#include "physics/contact/distance.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "support/finite_difference.h"

namespace pd {
namespace {

using PT = PointTriangleType;
using EE = EdgeEdgeType;
using Vec2 = Eigen::Vector2d;

constexpr double kGradTol = 1e-6, kHessTol = 1e-5;

double uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}
Vec3 random_point(std::mt19937& rng) {
  return Vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
}
Vec3 random_unit(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  return Vec3(n(rng), n(rng), n(rng)).normalized();
}
Vec<12> pack(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  Vec<12> x;
  x << a, b, c, d;
  return x;
}
Vec3 blk(const Vec<12>& x, int i) { return x.segment<3>(3 * i); }
Vec<12> random_config(std::mt19937& rng) {
  return pack(random_point(rng), random_point(rng), random_point(rng), random_point(rng));
}

// Worst FD errors seen per category, printed by the tests so the measured accuracy is on record.
struct Worst {
  double grad = 0, hess = 0;
  void print(const char* what) const {
    std::printf("  [%s] worst FD rel. error: gradient %.2e, Hessian %.2e\n", what, grad, hess);
  }
};

// FD check of f (value), g (gradient), h (Hessian) at x, with both the step-count and the
// "comparisons ran" assertions of support/finite_difference.h; also checks H is symmetric.
template <int N>
void expect_fd(const std::function<double(const Vec<N>&)>& f,
               const std::function<Vec<N>(const Vec<N>&)>& g,
               const std::function<Mat<N>(const Vec<N>&)>& h, const Vec<N>& x, Worst& worst,
               const std::vector<double>& steps = test::default_steps(), const char* label = "") {
  using Dyn = Eigen::VectorXd;
  const auto rg = test::check_gradient([&](const Dyn& y) { return f(y); }, x, g(x), steps);
  const auto rh = test::check_hessian([&](const Dyn& y) -> Dyn { return g(y); }, x, h(x), steps);
  EXPECT_GT(rg.comparisons, 0);
  EXPECT_GT(rh.comparisons, 0);
  EXPECT_GE(rg.steps_within(kGradTol), 2) << label << " gradient, best " << rg.best_rel_error;
  EXPECT_GE(rh.steps_within(kHessTol), 2) << label << " Hessian, best " << rh.best_rel_error;
  EXPECT_LT((h(x) - h(x).transpose()).norm(), 1e-12 * std::max(1.0, h(x).norm())) << label;
  worst.grad = std::max(worst.grad, rg.best_rel_error);
  worst.hess = std::max(worst.hess, rh.best_rel_error);
}

// A per-type function of K points as a function of their stacked 3K-vector.
template <int K, class F, std::size_t... I>
auto call_blocks(F fn, const Vec<3 * K>& y, std::index_sequence<I...>) {
  return fn(Vec3(y.template segment<3>(3 * I))...);
}
template <int K, class F>
auto stacked(F fn) {
  return [fn](const Vec<3 * K>& y) { return call_blocks<K>(fn, y, std::make_index_sequence<K>()); };
}
template <int K, class F, class G, class H>
void expect_fd_per_type(F f, G g, H h, const Vec<3 * K>& x, Worst& worst) {
  expect_fd<3 * K>(stacked<K>(f), stacked<K>(g), stacked<K>(h), x, worst);
}

// The auto-typed functions as plain functions (their names are overloaded).
double pt_f(const Vec<12>& x) { return point_triangle_squared_distance(x); }
Vec<12> pt_g(const Vec<12>& x) { return point_triangle_squared_distance_gradient(x); }
Mat<12> pt_h(const Vec<12>& x) { return point_triangle_squared_distance_hessian(x); }
double ee_f(const Vec<12>& x) { return edge_edge_squared_distance(x); }
Vec<12> ee_g(const Vec<12>& x) { return edge_edge_squared_distance_gradient(x); }
Mat<12> ee_h(const Vec<12>& x) { return edge_edge_squared_distance_hessian(x); }

// ---- configurations of a prescribed type (closest points and separation built to satisfy the
// optimality conditions strictly, so the type is known) ----

// Point at distance `dist` from a random triangle (all angles with sin^2 > 0.05), in the normal
// cone of the feature of `type`.
Vec<12> make_pt(std::mt19937& rng, PT type, double dist) {
  Vec3 t[3];
  const auto sin2 = [&](int i) {
    const Vec3 a = t[(i + 1) % 3] - t[i], b = t[(i + 2) % 3] - t[i];
    return a.cross(b).squaredNorm() / (a.squaredNorm() * b.squaredNorm());
  };
  do {
    for (Vec3& ti : t) ti = random_point(rng);
  } while (std::min({sin2(0), sin2(1), sin2(2)}) < 0.05);
  const Vec3 n = (t[1] - t[0]).cross(t[2] - t[0]).normalized();
  Vec3 m[3];  // outward in-plane normals of edges (t_i, t_i+1)
  for (int i = 0; i < 3; ++i) m[i] = (t[(i + 1) % 3] - t[i]).cross(n).normalized();
  const double phi = uniform(rng, -1.3, 1.3), side = uniform(rng, 0, 1) < 0.5 ? -1 : 1;
  const int k = static_cast<int>(type);
  Vec3 foot, dir;
  if (type == PT::P_T) {
    const double a = uniform(rng, 0.1, 0.8), b = uniform(rng, 0.1, 0.9 - a);
    foot = t[0] + a * (t[1] - t[0]) + b * (t[2] - t[0]);
    dir = side * n;
  } else if (k >= 3) {  // P_E(k-3)
    const int i = k - 3;
    foot = t[i] + uniform(rng, 0.1, 0.9) * (t[(i + 1) % 3] - t[i]);
    dir = std::cos(phi) * m[i] + std::sin(phi) * n;
  } else {  // P_Tk: between the outward normals of the two edges at t_k
    foot = t[k];
    const Vec3 w = uniform(rng, 0.1, 1) * m[(k + 2) % 3] + uniform(rng, 0.1, 1) * m[k];
    dir = std::cos(phi) * w.normalized() + std::sin(phi) * n;
  }
  return pack(foot + dist * dir, t[0], t[1], t[2]);
}

// Edges whose closest points are at distance `dist`; ka / kb = 0, 1: that endpoint of edge a / b
// is the closest point, 2: an interior point. sin2 > 0 sets sin^2 of the angle when both are
// interior (nearly parallel edges).
Vec<12> make_ee(std::mt19937& rng, int ka, int kb, double dist, double sin2 = -1) {
  const Vec3 d = random_unit(rng), P = random_point(rng), Q = P + dist * d;
  Vec3 a = random_unit(rng), b = random_unit(rng);
  a = (a - a.dot(d) * d).normalized();
  b = (b - b.dot(d) * d).normalized();
  if (sin2 > 0) b = std::sqrt(1 - sin2) * a + std::sqrt(sin2) * d.cross(a);
  // Optimality: (eb - ea).u <= 0 at s = 0, >= 0 at s = 1; (eb - ea).v >= 0 at t = 0, <= 0 at t = 1.
  const double tilt = uniform(rng, 0.2, 1);
  const Vec3 ua = ka == 2 ? a : (a + (ka ? tilt : -tilt) * d).normalized();
  const Vec3 vb = kb == 2 ? b : (b + (kb ? -tilt : tilt) * d).normalized();
  const Vec3 u = uniform(rng, 0.3, 1.5) * ua, v = uniform(rng, 0.3, 1.5) * vb;
  const double s = ka == 2 ? uniform(rng, 0.1, 0.9) : ka, t = kb == 2 ? uniform(rng, 0.1, 0.9) : kb;
  return pack(P - s * u, P + (1 - s) * u, Q - t * v, Q + (1 - t) * v);
}
EE ee_type(int ka, int kb) {
  const EE table[3][3] = {{EE::EA0_EB0, EE::EA0_EB1, EE::EA0_EB},
                          {EE::EA1_EB0, EE::EA1_EB1, EE::EA1_EB}, {EE::EA_EB0, EE::EA_EB1, EE::EA_EB}};
  return table[ka][kb];
}

// ---- brute force: f(q) = |c + q0 a + q1 b|^2 over the parameter simplex or unit square ----

// The minimum of a convex quadratic over a convex polygon is on a side or inside. Sides: golden
// section plus both ends. Inside: 41 x 41 grid, then pattern search (move while it improves, else
// halve the step, to 1e-15) along axes, diagonals and the quadratic's principal axes (these keep it
// converging for slivers / nearly parallel edges), rejecting points outside (sides cover those).
double brute_force(const Vec3& c, const Vec3& a, const Vec3& b, bool simplex) {
  const auto f = [&](const Vec2& q) { return (c + q[0] * a + q[1] * b).squaredNorm(); };
  const auto inside = [&](const Vec2& q) {
    return q.minCoeff() >= 0 && (simplex ? q.sum() <= 1 : q.maxCoeff() <= 1);
  };
  const std::vector<Vec2> corners = simplex ? std::vector<Vec2>{{0, 0}, {1, 0}, {0, 1}}
                                            : std::vector<Vec2>{{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < corners.size(); ++i) {
    const Vec2 q0 = corners[i], dq = corners[(i + 1) % corners.size()] - q0;
    const auto side = [&](double l) { return f(q0 + l * dq); };
    double lo = 0, hi = 1;
    for (int it = 0; it < 200; ++it) {  // golden section
      const double m1 = hi - 0.618034 * (hi - lo), m2 = lo + 0.618034 * (hi - lo);
      if (side(m1) < side(m2)) hi = m2; else lo = m1;
    }
    best = std::min({best, side(0), side(1), side(0.5 * (lo + hi))});
  }
  Vec2 at = corners[0];
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 40; ++j)
      if (inside(Vec2(i, j) / 40.0) && f(Vec2(i, j) / 40.0) < f(at)) at = Vec2(i, j) / 40.0;
  const double phi = 0.5 * std::atan2(2 * a.dot(b), a.squaredNorm() - b.squaredNorm());
  const Vec2 dirs[] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}, {std::cos(phi), std::sin(phi)},
                       {-std::sin(phi), std::cos(phi)}};
  for (double h = 1.0 / 40; h > 1e-15;) {
    const Vec2 start = at;
    for (const Vec2& d : dirs)
      for (const Vec2& q : {Vec2(at + h * d), Vec2(at - h * d)})
        if (inside(q) && f(q) < f(at)) at = q;
    if (at == start) h /= 2;
  }
  return std::min(best, f(at));
}
double brute_force_pt(const Vec<12>& x) {  // p - (t0 + a u + b v)
  return brute_force(blk(x, 1) - blk(x, 0), blk(x, 2) - blk(x, 1), blk(x, 3) - blk(x, 1), true);
}
double brute_force_ee(const Vec<12>& x) {  // (ea0 + s u) - (eb0 + t v)
  return brute_force(blk(x, 0) - blk(x, 2), blk(x, 1) - blk(x, 0), blk(x, 2) - blk(x, 3), false);
}

// Agreement with the brute force: 1e-9 relative, plus 1e-15 m^2 (round-off of O(1 m) coordinates).
// Near-degenerate inputs get 1e-8: there n = u x v is only accurate to ~ eps_mach / sin(angle)
// (backward error of the rounded differences u, v: the same formula in long double matches the
// brute force to 1e-13); measured worst 6e-10. A threshold raised to 1e-8 fails it (p-t: 3.8e-8).
bool agrees(double d, double ref, double rel = 1e-9) {
  return std::abs(d - ref) <= rel * ref + 1e-15;
}

// Near-degenerate inputs: sin^2 between the spanning vectors log-uniform in [1e-20, 1e-2] (both
// sides of kParallelSin2Threshold), parallel and anti-parallel; half placed at random, half with the
// closest point inside (sliver interior / both edge interiors) at 0.05-0.5 m.
Vec<12> nearly_parallel(std::mt19937& rng, bool triangle) {
  const double sin2 = std::pow(10.0, uniform(rng, -20, -2));
  const bool interior = uniform(rng, 0, 1) < 0.5, flip = uniform(rng, 0, 1) < 0.5;
  if (!triangle && interior) {
    const Vec<12> x = make_ee(rng, 2, 2, uniform(rng, 0.05, 0.5), sin2);
    return flip ? pack(blk(x, 0), blk(x, 1), blk(x, 3), blk(x, 2)) : x;
  }
  const Vec3 a = random_unit(rng), o = random_point(rng);
  const Vec3 b = std::sqrt(1 - sin2) * a + std::sqrt(sin2) * a.cross(random_unit(rng)).normalized();
  const double la = uniform(rng, 0.1, 1), lb = uniform(rng, 0.1, 1) * (flip ? -1 : 1);
  if (triangle && interior) {  // t2 nearly on the line t0 t1, on either side of t0
    const double s = uniform(rng, 0.05, 0.5), t = uniform(rng, 0.05, 0.45);
    const Vec3 p = o + s * la * a + t * lb * b + uniform(rng, 0.05, 0.5) * a.cross(b).normalized();
    return pack(p, o, o + la * a, o + lb * b);
  }
  const Vec3 p = o + uniform(rng, -1, 1) * a + 0.3 * random_point(rng);
  return triangle ? pack(p, o, o + la * a, o + lb * b) : pack(o, o + la * a, p, p + lb * b);
}

// 1000 random cases, then 300 near-degenerate ones, against the brute force; every type must occur
// among the random ones.
void expect_brute_force(std::mt19937& rng, bool triangle) {
  std::set<int> seen, seen_degenerate;
  double worst[2] = {0, 0};
  for (int k = 0; k < 1300; ++k) {
    const bool degenerate = k >= 1000;
    const Vec<12> x = degenerate ? nearly_parallel(rng, triangle) : random_config(rng);
    const double d = triangle ? pt_f(x) : ee_f(x), ref = triangle ? brute_force_pt(x) : brute_force_ee(x);
    const int type = triangle ? int(point_triangle_type(x)) : int(edge_edge_type(x));
    EXPECT_TRUE(agrees(d, ref, degenerate ? 1e-8 : 1e-9))
        << k << " " << (triangle ? to_string(PT(type)) : to_string(EE(type)));
    worst[degenerate] = std::max(worst[degenerate], std::abs(d - ref) / ref);
    (degenerate ? seen_degenerate : seen).insert(type);
  }
  EXPECT_EQ(seen.size(), triangle ? 7u : 9u);
  std::printf("  %s vs brute force: worst relative difference %.2e (random), %.2e (near-degenerate, "
              "%zu types)\n", triangle ? "point-triangle" : "edge-edge", worst[0], worst[1],
              seen_degenerate.size());
}

// ---- per-type functions ----

TEST(PerTypeDistance, GradientAndHessianMatchFiniteDifferencesOnRandomConfigurations) {
  std::mt19937 rng(11);
  Worst pp, pl, pp3, ll;
  for (int k = 0; k < 30; ++k) {
    const Vec<12> x = random_config(rng);
    expect_fd_per_type<2>(point_point_squared_distance, point_point_squared_distance_gradient,
                          point_point_squared_distance_hessian, x.head<6>(), pp);
    expect_fd_per_type<3>(point_line_squared_distance, point_line_squared_distance_gradient,
                          point_line_squared_distance_hessian, x.head<9>(), pl);
    expect_fd_per_type<4>(point_plane_squared_distance, point_plane_squared_distance_gradient,
                          point_plane_squared_distance_hessian, x, pp3);
    expect_fd_per_type<4>(line_line_squared_distance, line_line_squared_distance_gradient,
                          line_line_squared_distance_hessian, x, ll);
  }
  pp.print("point-point");
  pl.print("point-line");
  pp3.print("point-plane");
  ll.print("line-line");
}

// ---- classification and auto-typed functions ----

// Configurations built to land in each type, at distances 0.05-0.5 m and at 1e-8 m (which
// includes a point 1e-8 m from an edge line, P_E*). Same tolerances at 1e-8 m, but FD steps scaled
// to the distance: the gradient is O(d) while central differences err by O(h^2) with O(1) third
// derivatives, so h << d is needed.
const std::vector<double> kTinySteps = {1e-8, 1e-9, 1e-10, 1e-11};

TEST(Distances, EveryTypeIsClassifiedAndMatchesFiniteDifferencesIncludingAt1e8m) {
  std::mt19937 rng(21);
  Worst w[2][2];  // [edge-edge][tiny]
  for (int tiny : {0, 1})
    for (int i = 0; i < 16; ++i)  // 7 point-triangle types, then edge-edge (ka, kb) = (j / 3, j % 3)
      for (int k = 0; k < (tiny ? 5 : 20); ++k) {
        const bool ee = i >= 7;
        const int j = i - 7;
        const double dist = tiny ? 1e-8 : uniform(rng, 0.05, 0.5);
        const Vec<12> x = ee ? make_ee(rng, j / 3, j % 3, dist) : make_pt(rng, PT(i), dist);
        const char* type = ee ? to_string(ee_type(j / 3, j % 3)) : to_string(PT(i));
        ASSERT_STREQ(ee ? to_string(edge_edge_type(x)) : to_string(point_triangle_type(x)), type);
        EXPECT_NEAR(ee ? ee_f(x) : pt_f(x), dist * dist, tiny ? 1e-21 : 1e-13);
        expect_fd<12>(ee ? ee_f : pt_f, ee ? ee_g : pt_g, ee ? ee_h : pt_h, x, w[ee][tiny],
                      tiny ? kTinySteps : test::default_steps(), type);
      }
  w[0][0].print("point-triangle, auto-typed, 0.05-0.5 m");
  w[0][1].print("point-triangle, auto-typed, 1e-8 m");
  w[1][0].print("edge-edge, auto-typed, 0.05-0.5 m");
  w[1][1].print("edge-edge, auto-typed, 1e-8 m");
}

// Nearly parallel edges at angle theta, still line-line. Same tolerances, but the derivatives grow
// (|H| ~ 1/theta^2, third derivatives ~ 1/theta^3 measured): relative truncation error ~ h^2 /
// theta^3, so h ~ 1e-3 theta^1.5. The double value is only good to ~ eps_mach / theta (n = ea x eb
// cancels), too coarse at such steps, so the gradient check differences the formula in long double.
double line_line_long_double(const Vec<12>& y) {
  using V = Eigen::Matrix<long double, 3, 1>;
  V q[4];
  for (int i = 0; i < 4; ++i) q[i] = blk(y, i).cast<long double>();
  const V n = (q[1] - q[0]).cross(q[3] - q[2]);
  const long double a = n.dot(q[0] - q[2]);
  return static_cast<double>(a * a / n.squaredNorm());
}

TEST(EdgeEdgeDistance, NearlyParallelLineLineMatchesFiniteDifferencesWithAngleScaledSteps) {
  std::mt19937 rng(24);
  Worst w;
  for (double sin2 : {1e-4, 1e-6, 1e-8}) {
    const double h = 1e-3 * std::pow(sin2, 0.75);  // 1e-3 theta^1.5
    for (int k = 0; k < 20; ++k) {
      const Vec<12> x = make_ee(rng, 2, 2, 0.1, sin2);
      ASSERT_EQ(edge_edge_type(x), EE::EA_EB);
      expect_fd<12>(line_line_long_double, ee_g, ee_h, x, w, {h, h / 2, h / 4}, "nearly parallel");
    }
  }
  w.print("edge-edge, nearly parallel (sin^2 1e-4, 1e-6, 1e-8)");
}

// ---- brute force ----

TEST(Distances, Match1000BruteForceMinimisationsPerPrimitivePlusSliversAndNearlyParallelEdges) {
  std::mt19937 rng(31);
  expect_brute_force(rng, true);
  expect_brute_force(rng, false);
}

// ---- degenerate input ----

// Type as expected (or `alt`), distance as the brute force, derivatives finite.
void expect_ee(const Vec<12>& x, EE type, EE alt) {
  const EE got = edge_edge_type(x);
  EXPECT_TRUE(got == type || got == alt) << to_string(got);
  EXPECT_TRUE(agrees(ee_f(x), brute_force_ee(x))) << ee_f(x);
  EXPECT_TRUE(ee_g(x).allFinite() && ee_h(x).allFinite());
}
void expect_pt(const Vec<12>& x, PT type) {
  EXPECT_EQ(point_triangle_type(x), type) << to_string(point_triangle_type(x));
  EXPECT_TRUE(agrees(pt_f(x), brute_force_pt(x))) << pt_f(x);
  EXPECT_TRUE(pt_g(x).allFinite() && pt_h(x).allFinite());
}

TEST(EdgeEdgeType, ParallelAndAntiParallelEdgesGetTheRightEndpointCase) {
  const Vec3 a0(0, 0, 0), a1(1, 0, 0);
  const auto ee = [&](const Vec3& b0, const Vec3& b1) { return pack(a0, a1, b0, b1); };
  expect_ee(ee(Vec3(1.5, 0.1, 0), Vec3(2.5, 0.1, 0)), EE::EA1_EB0, EE::EA1_EB0);  // disjoint
  expect_ee(ee(Vec3(2.5, 0.1, 0), Vec3(1.5, 0.1, 0)), EE::EA1_EB1, EE::EA1_EB1);  // anti-parallel
  expect_ee(ee(Vec3(-2, 0, 0.2), Vec3(-1, 0, 0.2)), EE::EA0_EB1, EE::EA0_EB1);    // other side
  expect_ee(ee(Vec3(1.5, 0.1, 1e-11), Vec3(2.5, 0.1, 0)), EE::EA1_EB0, EE::EA1_EB0);  // sin^2 1e-22
  // Overlapping: two endpoint cases at equal distance; round-off in the candidates picks one.
  expect_ee(ee(Vec3(0.3, 0.1, 0), Vec3(1.5, 0.1, 0)), EE::EA1_EB, EE::EA_EB0);
  expect_ee(ee(Vec3(1.5, 0.1, 0), Vec3(0.3, 0.1, 0)), EE::EA1_EB, EE::EA_EB1);    // anti-parallel
  expect_ee(ee(Vec3(0.2, 0, 0), Vec3(0.6, 0, 0)), EE::EA_EB0, EE::EA_EB0);        // collinear
  EXPECT_NEAR(ee_f(ee(Vec3(2.5, 0.1, 0), Vec3(1.5, 0.1, 0))), 0.26, 1e-15);
  EXPECT_NEAR(ee_f(ee(Vec3(1.5, 0.1, 0), Vec3(0.3, 0.1, 0))), 0.01, 1e-15);
  EXPECT_EQ(ee_f(ee(Vec3(0.2, 0, 0), Vec3(0.6, 0, 0))), 0.0);
}

TEST(DegenerateInput, ZeroLengthEdgesCoincidentPointsAndPointsOnEdgeLinesGiveFiniteExactResults) {
  const Vec3 o(0, 0, 0), ex(1, 0, 0), ey(0, 1, 0), m(0.5, 0.5, 0), far(2, 1, 0);
  expect_ee(pack(m, m, o, ex), EE::EA0_EB, EE::EA0_EB);            // edge a has zero length
  expect_ee(pack(m, m, far, far), EE::EA0_EB0, EE::EA0_EB0);       // both zero length
  expect_ee(pack(far, far, o, ex), EE::EA0_EB1, EE::EA0_EB1);
  expect_ee(pack(o, o, o, o), EE::EA0_EB0, EE::EA0_EB0);           // four coincident points
  expect_ee(pack(o, ex, Vec3(0.5, 0, 0), Vec3(0.5, 1, 1)), EE::EA_EB0, EE::EA_EB0);  // eb0 on a
  expect_pt(pack(Vec3(2, 0, 0), o, ex, ey), PT::P_T1);             // on edge 0's line, beyond t1
  expect_pt(pack(Vec3(0.5, 0, 0), o, ex, ey), PT::P_T);            // on edge 0 (counts as inside)
  expect_pt(pack(Vec3(0.5, 0.5, 1), o, o, ey), PT::P_E1);          // t0 == t1 (zero area)
  expect_pt(pack(Vec3(0.3, 1, 0), o, ex, Vec3(0.5, 0, 0)), PT::P_E0);  // collinear triangle
  expect_pt(pack(o, o, o, o), PT::P_T0);                           // all coincident
  expect_pt(pack(ey, o, o, o), PT::P_T0);
  EXPECT_EQ(pt_f(pack(Vec3(0.5, 0, 0), o, ex, ey)), 0.0);
}

// ---- continuity ----

// Walks straight paths between random configurations; wherever the type changes, bisects to the
// switch (1e-15 in path parameter) and requires the distance on both sides to agree.
template <class Type>
void check_paths(std::mt19937& rng, const std::function<Type(const Vec<12>&)>& type_of,
                 double (*dist)(const Vec<12>&), std::set<std::pair<Type, Type>>& switches) {
  for (int path = 0; path < 300; ++path) {
    const Vec<12> x0 = random_config(rng), dx = random_config(rng) - x0;
    const int n = 200;
    for (int k = 0; k < n; ++k) {
      double lo = double(k) / n, hi = double(k + 1) / n;
      const Type a = type_of(x0 + lo * dx);
      if (type_of(x0 + hi * dx) == a) continue;
      while (hi - lo > 1e-15) {
        const double mid = 0.5 * (lo + hi);
        (type_of(x0 + mid * dx) == a ? lo : hi) = mid;
      }
      const double dlo = dist(x0 + lo * dx), dhi = dist(x0 + hi * dx);
      const Type b = type_of(x0 + hi * dx);
      EXPECT_LE(std::abs(dlo - dhi), 1e-12 * std::max(1.0, dlo))
          << to_string(a) << " -> " << to_string(b);
      switches.insert({a, b});
    }
  }
}

TEST(Distances, ContinuousAcrossTypeBoundaries) {
  std::mt19937 rng(41);
  std::set<std::pair<PT, PT>> pt;
  std::set<std::pair<EE, EE>> ee;
  check_paths<PT>(rng, [](const Vec<12>& x) { return point_triangle_type(x); }, pt_f, pt);
  check_paths<EE>(rng, [](const Vec<12>& x) { return edge_edge_type(x); }, ee_f, ee);
  EXPECT_GE(pt.size(), 18u);  // P_T <-> 3 edges, each edge <-> its 2 vertices, both ways
  EXPECT_GE(ee.size(), 20u);
  std::printf("  distinct type switches crossed: %zu point-triangle, %zu edge-edge\n", pt.size(),
              ee.size());
}

// The one documented jump: overlapping nearly parallel edges switch from line-line to an endpoint
// case at the parallel threshold; here by (0.4 sin)^2 = 0.16 * 1e-14 m^2 (|ea|^2 = 1 m^2).
TEST(EdgeEdgeDistance, JumpAtParallelThresholdIsBelowThresholdTimesLengthSquared) {
  Vec<12> x[2];  // edge b turned by asin(sqrt(sin2)) about its midpoint, above / below threshold
  for (int i = 0; i < 2; ++i) {
    const double sin2 = (i ? 0.99 : 1.01) * kParallelSin2Threshold;
    const Vec3 mid(0.5, 0, 0.01), dir(std::sqrt(1 - sin2), std::sqrt(sin2), 0);
    x[i] = pack(Vec3(0, 0, 0), Vec3(1, 0, 0), mid - 0.4 * dir, mid + 0.4 * dir);
  }
  EXPECT_EQ(edge_edge_type(x[0]), EE::EA_EB);
  EXPECT_NE(edge_edge_type(x[1]), EE::EA_EB);
  const double jump = ee_f(x[1]) - ee_f(x[0]);
  EXPECT_TRUE(jump > 0 && jump <= kParallelSin2Threshold) << jump;
  std::printf("  jump at the parallel threshold: %.3e m^2 (distance 0.01 m)\n", jump);
}

// ---- invariance ----

TEST(Distances, RigidMotionLeavesDistancesAndTypesUnchangedAndRotatesGradients) {
  std::mt19937 rng(51);
  std::normal_distribution<double> nd(0, 1);
  for (int k = 0; k < 500; ++k) {
    const Eigen::Quaterniond q(nd(rng), nd(rng), nd(rng), nd(rng));
    const Mat3 R = q.normalized().toRotationMatrix();
    const Vec3 t = 10 * random_point(rng);  // up to 10 m away
    const Vec<12> x = random_config(rng);
    const auto move = [&](int i) -> Vec3 { return R * blk(x, i) + t; };
    const Vec<12> y = pack(move(0), move(1), move(2), move(3));
    EXPECT_EQ(point_triangle_type(x), point_triangle_type(y));
    EXPECT_EQ(edge_edge_type(x), edge_edge_type(y));
    // Round-off of coordinates up to ~10 m: absolute 1e-13 m^2 on top of 1e-12 relative.
    EXPECT_NEAR(pt_f(y), pt_f(x), 1e-12 * pt_f(x) + 1e-13);
    EXPECT_NEAR(ee_f(y), ee_f(x), 1e-12 * ee_f(x) + 1e-13);
    const Vec<12> gp = pt_g(x), ge = ee_g(x), gpy = pt_g(y), gey = ee_g(y);
    for (int i = 0; i < 4; ++i) {
      EXPECT_LT((R * blk(gp, i) - blk(gpy, i)).norm(), 1e-10 * (1 + gp.norm()));
      EXPECT_LT((R * blk(ge, i) - blk(gey, i)).norm(), 1e-10 * (1 + ge.norm()));
    }
  }
}

}  // namespace
}  // namespace pd
