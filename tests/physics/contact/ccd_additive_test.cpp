// Tests of additive CCD (physics/contact/ccd_additive.h): the returned time never passes the first
// time the gap d - thickness reaches zero, it is not uselessly small, and every query terminates.
#include "physics/contact/ccd_additive.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace pd {
namespace {

enum class Prim { PT, EE };

// ---- Reference squared distances, independent of distance.h and of ccd_additive.cpp's own
// near-degenerate search: closed-form minimisation over the sub-simplices, with no parallel
// threshold, in quad precision (__float128; long double where that is missing) whenever the
// triangle or edge pair is within sin^2 < 1e-4 of degenerate, where double closed forms lose
// ~eps / sin^2 of their accuracy. Points x0 + t dx are formed in the same precision. ----
#if defined(__SIZEOF_FLOAT128__)
using Quad = __float128;
#else
using Quad = long double;  // IEEE quad on aarch64; only 80 bits on other x86 compilers
#endif

template <class T> struct V3 {
  T x, y, z;
  V3 operator+(const V3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  V3 operator-(const V3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  V3 operator*(T s) const { return {x * s, y * s, z * s}; }
  T dot(const V3& o) const { return x * o.x + y * o.y + z * o.z; }
  V3 cross(const V3& o) const { return {y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x}; }
};

template <class T> T ref_point_segment2(const V3<T>& p, const V3<T>& a, const V3<T>& b) {
  const V3<T> e = b - a;
  const T l2 = e.dot(e);
  T t = l2 > 0 ? (p - a).dot(e) / l2 : T(0);
  t = t < 0 ? T(0) : (t > 1 ? T(1) : t);
  const V3<T> r = p - a - e * t;
  return r.dot(r);
}

template <class T> double ref_dist2_in(Prim prim, const Vec<12>& x0, const Vec<12>& dx, double t) {
  V3<T> v[4];
  for (int i = 0; i < 4; ++i) {
    auto at = [&](int k) { return T(x0[3 * i + k]) + T(t) * T(dx[3 * i + k]); };
    v[i] = {at(0), at(1), at(2)};
  }
  const V3<T>&a = v[0], &b = v[1], &c = v[2], &d = v[3];
  T best;
  if (prim == Prim::PT) {  // a = p, (b, c, d) = triangle
    best = std::min(
        {ref_point_segment2(a, b, c), ref_point_segment2(a, c, d), ref_point_segment2(a, d, b)});
    const V3<T> n = (c - b).cross(d - b);
    const T nn = n.dot(n);
    if (nn > 0 && (c - b).cross(a - b).dot(n) >= 0 && (d - c).cross(a - c).dot(n) >= 0 &&
        (b - d).cross(a - d).dot(n) >= 0) {
      const T h = (a - b).dot(n);
      best = std::min(best, h * h / nn);
    }
  } else {
    best = std::min({ref_point_segment2(a, c, d), ref_point_segment2(b, c, d),
                     ref_point_segment2(c, a, b), ref_point_segment2(d, a, b)});
    const V3<T> u = b - a, w = a - c, vv = d - c;
    const T A = u.dot(u), B = u.dot(vv), C = vv.dot(vv), D = u.dot(w), E = vv.dot(w);
    const T den = A * C - B * B;
    if (den > 0) {  // interior-interior minimum of the two lines
      const T s = (B * E - C * D) / den, r = (A * E - B * D) / den;
      if (s > 0 && s < 1 && r > 0 && r < 1) {
        const V3<T> g = w + u * s - vv * r;
        best = std::min(best, g.dot(g));
      }
    }
  }
  return static_cast<double>(best);
}

// Squared distance at x0 + t dx (m^2).
double ref_dist2(Prim prim, const Vec<12>& x0, const Vec<12>& dx, double t) {
  const Vec<12> x = x0 + t * dx;
  const bool pt = prim == Prim::PT;  // spanning vectors: t1 - t0 and t2 - t0, or the two edges
  const Vec3 u = x.segment<3>(pt ? 6 : 3) - x.segment<3>(pt ? 3 : 0);
  const Vec3 v = x.segment<3>(9) - x.segment<3>(pt ? 3 : 6);
  const bool degenerate = u.cross(v).squaredNorm() < 1e-4 * u.squaredNorm() * v.squaredNorm();
  return degenerate ? ref_dist2_in<Quad>(prim, x0, dx, t) : ref_dist2_in<double>(prim, x0, dx, t);
}

double accd(Prim prim, const Vec<12>& x0, const Vec<12>& dx, double ratio, double xi, double t_max,
            AccdInfo* info) {
  return prim == Prim::PT ? point_triangle_accd(x0, dx, ratio, xi, t_max, info)
                          : edge_edge_accd(x0, dx, ratio, xi, t_max, info);
}

// ---- Reference time of impact: sampling on a grid, then recursive bisection certified by a
// Lipschitz bound. With L = 2 max_i ||dx_i|| >= |dg/dt| (no centring: a cruder bound than ACCD's,
// on purpose), g >= (g(a) + g(b))/2 - L (b - a)/2 on [a, b]; intervals where that is positive hold
// no contact, the others are split until their width is below `tol`, whose left end is returned
// (earlier than the true time by at most tol, or a gap within L tol ~ 1e-15 m of zero: a stricter
// reference). An evaluation budget bounds the work; exhausting it also returns the left end and is
// reported as uncertain (only when the gap hovers near zero for a long stretch). ----
struct ReferenceToi {
  Prim prim;
  Vec<12> x0, dx;
  double xi, L, tol = 1e-15;
  long evals = 0, budget = 4000000;
  bool uncertain = false;  // the budget ran out before the first contact was isolated
  double gap(double t) { ++evals; return std::sqrt(ref_dist2(prim, x0, dx, t)) - xi; }
  double first_root(double a, double b, double ga, double gb) {  // -1: certified contact-free
    if (ga <= 0) return a;
    if (0.5 * (ga + gb) > 0.5 * L * (b - a)) return -1;
    if (evals > budget) uncertain = true;
    if (b - a < tol || uncertain) return a;
    const double m = 0.5 * (a + b), gm = gap(m);
    const double r = first_root(a, m, ga, gm);
    return r >= 0 ? r : first_root(m, b, gm, gb);
  }
  // First t in [0, t_max] with gap <= 0, or t_max when there is none.
  double toi(double t_max, int grid = 256) {
    L = 0;
    for (int v = 0; v < 4; ++v) L = std::max(L, 2.0 * dx.segment<3>(3 * v).norm());
    double a = 0, ga = gap(0);
    for (int i = 1; i <= grid; ++i) {
      const double b = t_max * i / grid, gb = gap(b);
      const double r = first_root(a, b, ga, gb);
      if (r >= 0) return r;
      a = b;
      ga = gb;
    }
    return t_max;
  }
};

// ---- Random configurations (fixed seeds). Four families per primitive: aimed to cross, fully
// random, slow/glancing (mostly tangential motion), and near-degenerate; thickness 0 to 0.1 m. ----
struct Case { Vec<12> x0, dx; double xi; };

Vec3 urand3(std::mt19937_64& rng, double lo, double hi) {
  std::uniform_real_distribution<double> U(lo, hi);
  return Vec3(U(rng), U(rng), U(rng));
}

// Family 3, near-degenerate: nearly parallel edges, or a sliver triangle (angle 1e-11..1e-3 rad,
// across distance.h's parallel threshold 1e-7 and ccd_additive.cpp's 1e-4), crossed through its
// interior from a gap of 1e-9..1e-4 m.
Case near_degenerate_case(Prim prim, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(0.0, 1.0);
  Case c;
  c.xi = U(rng) < 0.5 ? 0.0 : 1e-3 * U(rng);
  const double angle = std::pow(10.0, -11 + 8 * U(rng)), gap = std::pow(10.0, -9 + 5 * U(rng));
  const Vec3 e1 = urand3(rng, -1, 1).normalized();
  const Vec3 e2 = e1.cross(urand3(rng, -1, 1)).normalized(), n = e1.cross(e2);
  const Vec3 o = urand3(rng, -1, 1);
  const double len = 0.5 + U(rng);
  const Vec3 a0 = o, a1 = o + len * e1, b_dir = len * (std::cos(angle) * e1 + std::sin(angle) * e2);
  const double f = 0.2 + 0.6 * U(rng);  // where along the first edge the crossing happens
  const Vec3 move = -(0.5 + 0.5 * U(rng)) * n + 0.3 * U(rng) * e1;
  if (prim == Prim::PT) {  // sliver (a0, a1, a0 + b_dir), apex at a random vertex; p above it
    const Vec3 inside = a0 + f * (0.7 * (a1 - a0) + 0.3 * b_dir), t[3] = {a0, a1, a0 + b_dir};
    const int r = static_cast<int>(3 * U(rng)) % 3;
    c.x0 << inside + (c.xi + gap) * n, t[r], t[(r + 1) % 3], t[(r + 2) % 3];
    c.dx << move, Vec3::Zero(), Vec3::Zero(), Vec3::Zero();
  } else {  // edge b nearly parallel to edge a, crossing it (in projection) at f
    const Vec3 b0 = a0 + f * (a1 - a0) - 0.5 * b_dir + (c.xi + gap) * n;
    c.x0 << a0, a1, b0, b0 + b_dir;
    c.dx << Vec3::Zero(), Vec3::Zero(), move, move;
  }
  return c;
}

Case random_case(Prim prim, std::mt19937_64& rng, int family) {
  if (family == 3) return near_degenerate_case(prim, rng);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  Case c;
  const double pick = U(rng);
  c.xi = pick < 0.3 ? 0.0 : (pick < 0.7 ? 0.01 * U(rng) : 0.1 * U(rng));
  for (;;) {
    Vec3 v[4], d[4];
    for (int i = 0; i < 4; ++i) { v[i] = urand3(rng, -1, 1); d[i] = 0.3 * urand3(rng, -1, 1); }
    // v[1..3]: the triangle, or v[0..1] / v[2..3]: the two edges. n: the direction to cross.
    Vec3 n, centre;
    if (prim == Prim::PT) {
      n = (v[2] - v[1]).cross(v[3] - v[1]);
      if (n.norm() < 0.4) continue;  // keep triangles away from degenerate
      const double w1 = U(rng), w2 = U(rng) * (1 - w1);
      centre = v[1] + w1 * (v[2] - v[1]) + w2 * (v[3] - v[1]);
    } else {
      n = (v[1] - v[0]).cross(urand3(rng, -1, 1));
      if (n.norm() < 0.1 || (v[1] - v[0]).norm() < 0.3) continue;
      centre = v[0] + U(rng) * (v[1] - v[0]);
    }
    n.normalize();
    const Vec3 tangent = n.cross(urand3(rng, -1, 1));
    if (family == 0) {  // aimed: the moving primitive starts above and ends below
      const double h0 = 0.02 + 0.8 * U(rng), h1 = U(rng);
      const Vec3 start = centre + h0 * n + 0.2 * urand3(rng, -1, 1);
      const Vec3 end = centre - h1 * n + 0.2 * urand3(rng, -1, 1);
      const Vec3 move = end - start;
      const Vec3 half = 0.3 * (1 + U(rng)) * tangent.normalized();
      if (prim == Prim::PT) { v[0] = start; d[0] = move; }
      else { v[2] = start - half; v[3] = start + half; d[2] = move + 0.1 * urand3(rng, -1, 1); }
      if (prim == Prim::EE) d[3] = move;
    } else if (family == 1) {  // fully random, larger motion
      for (int i = 0; i < 4; ++i) d[i] = urand3(rng, -1, 1);
    } else {  // glancing: small normal approach, large tangential motion
      const double h0 = 0.005 + 0.1 * U(rng);
      const Vec3 move = tangent * (1 + U(rng)) - (0.2 * U(rng)) * n;
      const Vec3 dir = 0.5 * (v[1] - v[0]).normalized().cross(n);
      if (prim == Prim::PT) { v[0] = centre + h0 * n; d[0] = move; }
      else { v[2] = centre + h0 * n - dir; v[3] = centre + h0 * n + dir; d[2] = d[3] = move; }
    }
    for (int i = 0; i < 4; ++i) { c.x0.segment<3>(3 * i) = v[i]; c.dx.segment<3>(3 * i) = d[i]; }
    if (std::sqrt(ref_dist2(prim, c.x0, c.dx, 0.0)) - c.xi > 1e-6) return c;  // outside xi
  }
}

double percentile(std::vector<double> v, double q) {  // nearest rank; NaN when empty
  std::sort(v.begin(), v.end());
  return v.empty() ? NAN : v[static_cast<size_t>(q * (v.size() - 1) + 0.5)];
}

void run_random_suite(Prim prim, double ratio, int cases, unsigned seed, bool check_tightness) {
  std::mt19937_64 rng(seed);
  std::vector<double> q;  // t_accd / t_true over cases with contact before t_max
  int free_full = 0, uncertain = 0, max_it = 0;
  long sum_it = 0;
  for (int k = 0; k < cases; ++k) {
    const Case c = random_case(prim, rng, k % 4);
    AccdInfo info;
    const double t = accd(prim, c.x0, c.dx, ratio, c.xi, 1.0, &info);
    ReferenceToi ref{prim, c.x0, c.dx, c.xi, 0.0};
    const double t_true = ref.toi(1.0);
    uncertain += ref.uncertain;
    ASSERT_GE(t, 0.0);
    ASSERT_LE(t, t_true) << "case " << k << " outcome " << static_cast<int>(info.outcome);
    ASSERT_LT(info.iterations, kAccdDefaultMaxIterations) << "case " << k;
    // The header's termination bound: steps after the first are >= eta (1 - eta) g(0) / l_p.
    EXPECT_LE(info.iterations,
              2 + info.motion_bound / (ratio * (1 - ratio) * info.initial_gap)) << "case " << k;
    // The returned configuration keeps the promised margin of the initial gap, up to the rounding
    // of d - xi = (d^2 - xi^2) / (d + xi) near the thickness (~eps |x|^2 / xi ~ 1e-13 m here).
    const double g_ret = std::sqrt(ref_dist2(prim, c.x0, c.dx, t)) - c.xi;
    EXPECT_GT(g_ret, 0.0) << "case " << k;
    if (info.outcome == AccdOutcome::StoppedAtGapMargin) {
      EXPECT_GE(g_ret, (1 - ratio) * info.initial_gap - 1e-12) << "case " << k;
    }
    max_it = std::max(max_it, info.iterations);
    sum_it += info.iterations;
    if (t_true < 1.0) q.push_back(t / t_true);
    else free_full += (t == 1.0);
  }
  const double frac_half = std::count_if(q.begin(), q.end(), [](double r) { return r > 0.5; }) /
                           static_cast<double>(std::max<size_t>(q.size(), 1));
  std::printf("%s ratio %.2f: %d cases, %d with contact; t/t_true min %.3f p1 %.3f p5 %.3f "
              "p50 %.3f max %.3f, >0.5 in %.1f%%; no-contact cases returning t_max %d/%d; "
              "iterations mean %.1f max %d; uncertain references %d\n",
              prim == Prim::PT ? "PT" : "EE", ratio, cases, int(q.size()), percentile(q, 0),
              percentile(q, 0.01), percentile(q, 0.05), percentile(q, 0.5), percentile(q, 1),
              100 * frac_half, free_full, cases - int(q.size()), double(sum_it) / cases, max_it,
              uncertain);
  EXPECT_GT(int(q.size()), cases / 4);  // the suite really exercises impacts
  EXPECT_EQ(uncertain, 0);
  if (check_tightness) {
    EXPECT_GT(frac_half, 0.9);
    EXPECT_GT(percentile(q, 0.5), 0.8);
  }
}

TEST(AdditiveCcd, PointTriangleConservativeAndTightOnRandomSuite) {
  run_random_suite(Prim::PT, 0.9, 3000, 12345u, true);
}
TEST(AdditiveCcd, EdgeEdgeConservativeAndTightOnRandomSuite) {
  run_random_suite(Prim::EE, 0.9, 3000, 67890u, true);
}
TEST(AdditiveCcd, ConservativeForOtherRatios) {
  for (double ratio : {0.5, 0.99}) {
    run_random_suite(Prim::PT, ratio, 600, 111u, false);
    run_random_suite(Prim::EE, ratio, 600, 222u, false);
  }
}

// ---- Adversarial and edge cases. Each returns in [0, t_max], never past the reference time,
// and terminates within the guard; expected outcomes are stated per case. ----
Vec<12> stack(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (Vec<12>() << a, b, c, d).finished();
}
// Unit right triangle in the z = 0 plane; edge a along x from 0 to 1.
const Vec3 kT0(0, 0, 0), kT1(1, 0, 0), kT2(0, 1, 0), kZero(0, 0, 0);
Vec<12> tri_with(const Vec3& p) { return stack(p, kT0, kT1, kT2); }
Vec<12> move_p(double x, double y, double z) { return stack(Vec3(x, y, z), kZero, kZero, kZero); }
Vec<12> move_b(double x, double y, double z) { return stack(kZero, kZero, {x, y, z}, {x, y, z}); }

// expected_toi >= 0: the true time known analytically, checked against the reference. Cases whose
// gap stays ~1e-9 for the whole step would need ~1e9 reference evaluations; they pass
// use_reference = false and are checked against the analytic time only.
AccdInfo check_case(const char* name, Prim prim, const Vec<12>& x0, const Vec<12>& dx, double xi,
                    double expected_toi = -1, bool use_reference = true) {
  AccdInfo info;
  const double t = accd(prim, x0, dx, 0.9, xi, 1.0, &info);
  const double t_true = use_reference ? ReferenceToi{prim, x0, dx, xi, 0.0}.toi(1.0) : expected_toi;
  std::printf("%-36s t %-12.6g t_true %-12.6g iterations %5d  outcome %d\n", name, t, t_true,
              info.iterations, static_cast<int>(info.outcome));
  EXPECT_GE(t, 0.0) << name;
  EXPECT_LE(t, t_true) << name;
  EXPECT_LE(info.iterations, kAccdDefaultMaxIterations) << name;
  EXPECT_GT(std::sqrt(ref_dist2(prim, x0, dx, t)) - xi, 0.0) << name;
  if (expected_toi >= 0) {
    EXPECT_NEAR(t_true, expected_toi, 1e-14 + 1e-6 * expected_toi) << name;
  }
  return info;
}

TEST(AdditiveCcdEdgeCases, GrazingMotionTouchingOrMissingByAHair) {
  // A point skimming past vertex t1 = (1, 0, 0) along x = 1 + xi - 1e-12, z = 0: its distance
  // sqrt((xi - 1e-12)^2 + y^2) grazes the thickness at y = 0 (t = 0.5), tangentially. The 1e-12 m
  // overlap puts the touch beyond rounding doubt and moves the true time by ~4.5e-8.
  const double xi = 1e-3, x_touch = 1 + xi - 1e-12;
  AccdInfo a = check_case("PT grazing touch at t=0.5", Prim::PT, tri_with(Vec3(x_touch, -0.5, 0)),
                          move_p(0, 1, 0), xi, 0.5);
  EXPECT_EQ(a.outcome, AccdOutcome::StoppedAtGapMargin);
  // The same path missing by 1e-8 m: no contact, but ACCD stops once the gap falls below its
  // margin 0.1 g(0) (at y ~ -0.05), after two evaluations.
  a = check_case("PT grazing miss by 1e-8", Prim::PT, tri_with(Vec3(1 + xi + 1e-8, -0.5, 0)),
                 move_p(0, 1, 0), xi, 1.0);
  EXPECT_EQ(a.outcome, AccdOutcome::StoppedAtGapMargin);
  // Edge b (along z) sweeping past the end of edge a, grazing it the same way at t = 0.5.
  const Vec<12> e0 = stack(kT0, kT1, Vec3(x_touch, -0.5, -1), Vec3(x_touch, -0.5, 1));
  a = check_case("EE grazing touch at t=0.5", Prim::EE, e0, move_b(0, 1, 0), xi, 0.5);
  EXPECT_EQ(a.outcome, AccdOutcome::StoppedAtGapMargin);
}

TEST(AdditiveCcdEdgeCases, ParallelEdgesSlidingAlongEachOther) {
  const double xi = 1e-3;
  // Gap 1e-3: the gap never changes, so ACCD walks in steps of 0.9 gap / l_p up to t_max.
  Vec<12> e0 = stack(kT0, kT1, Vec3(-0.5, 0, xi + 1e-3), Vec3(0.5, 0, xi + 1e-3));
  AccdInfo a = check_case("EE parallel sliding, gap 1e-3", Prim::EE, e0, move_b(2, 0, 0), xi, 1.0);
  EXPECT_EQ(a.outcome, AccdOutcome::NoContactBeforeTMax);
  EXPECT_LT(a.iterations, kAccdDefaultMaxIterations);
  // Gap 1e-9: steps of ~5e-10 in t; the guard stops the walk and returns the (tiny, safe) time
  // reached so far.
  e0 = stack(kT0, kT1, Vec3(-0.5, 0, xi + 1e-9), Vec3(0.5, 0, xi + 1e-9));
  a = check_case("EE parallel sliding, gap 1e-9", Prim::EE, e0, move_b(2, 0, 0), xi, 1.0, false);
  EXPECT_EQ(a.outcome, AccdOutcome::IterationLimit);
  EXPECT_EQ(a.iterations, kAccdDefaultMaxIterations);
  // Parallel edges approaching each other: contact when the gap closes, t = 0.5.
  e0 = stack(kT0, kT1, Vec3(0.2, 0, xi + 0.1), Vec3(0.8, 0, xi + 0.1));
  check_case("EE parallel approaching", Prim::EE, e0, move_b(0.1, 0, -0.2), xi, 0.5);
}

TEST(AdditiveCcdEdgeCases, PointMovingParallelToTrianglePlaneAtTinyDistance) {
  // The gap never changes, so ACCD needs l_p / (0.9 gap) ~ 6e5 (gap 1e-6) or more evaluations: the
  // guard ends each walk, returning the time reached so far (documented fallback).
  const double xi = 1e-3;
  const Vec<12> dx = move_p(0.5, 0.2, 0);
  AccdInfo a = check_case("PT parallel to plane, gap 1e-6", Prim::PT,
                          tri_with(Vec3(0.1, 0.1, xi + 1e-6)), dx, xi, 1.0);
  EXPECT_EQ(a.outcome, AccdOutcome::IterationLimit);
  a = check_case("PT parallel to plane, gap 1e-9", Prim::PT,
                 tri_with(Vec3(0.1, 0.1, xi + 1e-9)), dx, xi, 1.0, false);
  EXPECT_EQ(a.outcome, AccdOutcome::IterationLimit);
  a = check_case("PT parallel, xi 0, gap 1e-12", Prim::PT, tri_with(Vec3(0.1, 0.1, 1e-12)), dx, 0.0,
                 1.0, false);
  EXPECT_EQ(a.outcome, AccdOutcome::IterationLimit);
}

TEST(AdditiveCcdEdgeCases, NearlyTouchingStart) {
  const double xi = 1e-3;
  const Vec<12> x0 = tri_with(Vec3(0.2, 0.2, xi + 1e-9));
  check_case("PT gap 1e-9 moving in", Prim::PT, x0, move_p(0, 0, -1), xi, 1e-9);
  // Moving straight out: the steps grow geometrically (x1.9), reaching t_max in a few dozen.
  const AccdInfo a = check_case("PT gap 1e-9 moving out", Prim::PT, x0, move_p(0, 0, 1), xi, 1.0);
  EXPECT_EQ(a.outcome, AccdOutcome::NoContactBeforeTMax);
  EXPECT_LT(a.iterations, 60);
  const Vec<12> e0 = stack(kT0, kT1, Vec3(0.5, -0.5, xi + 1e-9), Vec3(0.5, 0.5, xi + 1e-9));
  check_case("EE gap 1e-9 closing", Prim::EE, e0, move_b(0, 0, -1), xi, 1e-9);
}

TEST(AdditiveCcdEdgeCases, NearlyParallelEdgesAndSliverTrianglesAtTinyGaps) {
  // Below distance.h's parallel threshold (sin^2 <= 1e-14) its distance is the boundary one, up to
  // ~angle * length too large; ACCD must still see the interior distance and stop in time.
  char name[96];
  for (double xi : {0.0, 1e-3}) {
    for (double angle : {1e-6, 1e-7, 1e-8, 1e-10}) {
      for (double gap : {1e-8, 1e-9}) {
        const double h = xi + gap;
        std::snprintf(name, sizeof name, "EE angle %.0e gap %.0e xi %.0e", angle, gap, xi);
        const Vec<12> e0 = stack(kT0, kT1, Vec3(0, -angle / 2, h), Vec3(1, angle / 2, h));
        check_case(name, Prim::EE, e0, move_b(0, 0, -1), xi, gap);
        std::snprintf(name, sizeof name, "PT sliver %.0e gap %.0e xi %.0e", angle, gap, xi);
        const Vec<12> x0 = stack(Vec3(0.9, 0.45 * angle, h), kT0, kT1, Vec3(1, angle, 0));
        check_case(name, Prim::PT, x0, move_p(0, 0, -1), xi, gap);
      }
    }
  }
}

TEST(AdditiveCcdEdgeCases, ZeroDisplacementReturnsTMaxWithoutIterating) {
  for (Prim prim : {Prim::PT, Prim::EE}) {
    const Vec<12> x0 = tri_with(Vec3(0.2, 0.2, 0.01));
    AccdInfo info;
    EXPECT_EQ(accd(prim, x0, Vec<12>::Zero(), 0.9, 1e-3, 1.0, &info), 1.0);
    EXPECT_EQ(info.iterations, 0);
    EXPECT_EQ(info.outcome, AccdOutcome::NoContactBeforeTMax);
    // A pure common translation is no relative motion either.
    const Vec3 c(5, -3, 7);
    EXPECT_EQ(accd(prim, x0, stack(c, c, c, c), 0.9, 1e-3, 0.7, &info), 0.7);
    EXPECT_EQ(info.iterations, 0);
  }
}

TEST(AdditiveCcdEdgeCases, HugeDisplacement) {
  const double xi = 1e-3;
  // From 1 m above to 1e6 m below: contact at t = (1 - xi) / 1e6.
  const Vec<12> x0 = tri_with(Vec3(0.2, 0.2, 1));
  check_case("PT huge displacement through", Prim::PT, x0, move_p(0, 0, -1e6), xi, (1 - xi) / 1e6);
  const AccdInfo a = check_case("PT huge displacement away", Prim::PT, x0, move_p(3e5, 1e5, 1e6),
                                xi, 1.0);
  EXPECT_EQ(a.outcome, AccdOutcome::NoContactBeforeTMax);
  check_case("PT huge tangential sweep", Prim::PT, x0, move_p(1e6, -1e6, 0), xi);
  const Vec<12> e0 = stack(kT0, kT1, Vec3(0.5, -0.5, 1), Vec3(0.5, 0.5, 1));
  check_case("EE huge displacement through", Prim::EE, e0, move_b(0, 0, -1e6), xi, (1 - xi) / 1e6);
}

TEST(AdditiveCcdEdgeCases, AlreadyWithinThicknessReturnsZero) {
  // Documented: a start at or within the thickness certifies no motion at all, whichever way the
  // primitives move; 0 is returned. (Unsigned distances cannot tell a point that has already passed
  // through and out of the thickness layer: that is a collision missed earlier, not seen here.)
  const double xi = 1.0 / 1024;  // exactly representable, so d = xi below is exact, not rounded
  for (double z : {0.5 * xi, xi, 0.0, -0.5 * xi}) {  // inside, exactly at, on the plane, below it
    AccdInfo info;
    const Vec<12> x0 = tri_with(Vec3(0.2, 0.2, z));
    EXPECT_EQ(point_triangle_accd(x0, move_p(0, 0, 1), 0.9, xi, 1.0, &info), 0.0) << z;
    EXPECT_EQ(info.outcome, AccdOutcome::StartedWithinThickness) << z;
    EXPECT_EQ(info.iterations, 0);
  }
  AccdInfo info;  // crossing edges touching, xi = 0, moving apart
  const Vec<12> e0 = stack(kT0, kT1, Vec3(0.5, -0.5, 0), Vec3(0.5, 0.5, 0));
  EXPECT_EQ(edge_edge_accd(e0, move_b(0, 0, 1), 0.9, 0.0, 1.0, &info), 0.0);
  EXPECT_EQ(info.outcome, AccdOutcome::StartedWithinThickness);
}

TEST(AdditiveCcdEdgeCases, HeadOnApproachReturnsRatioTimesTrueTime) {
  // A point falling straight onto a resting triangle: l_p equals the real closing speed, so one
  // certified step covers `ratio` of the way and the next would cross the margin.
  const Vec<12> x0 = tri_with(Vec3(0.2, 0.2, 0.5)), dx = move_p(0, 0, -1);
  for (double ratio : {0.5, 0.9, 0.99}) {
    AccdInfo info;
    EXPECT_NEAR(point_triangle_accd(x0, dx, ratio, 0.0, 1.0, &info), ratio * 0.5, 1e-12) << ratio;
    EXPECT_EQ(info.iterations, 2);
  }
  // t_max bounds the answer: t_max = 0.1 is returned when contact is at 0.5; t_max = 0 gives 0.
  EXPECT_EQ(point_triangle_accd(x0, dx, 0.9, 0.0, 0.1), 0.1);
  EXPECT_EQ(point_triangle_accd(x0, dx, 0.9, 0.0, 0.0), 0.0);
}

TEST(AdditiveCcdEdgeCases, NonFiniteInputReturnsZero) {
  const Vec<12> x0 = tri_with(Vec3(0.2, 0.2, 0.5));
  Vec<12> dx = Vec<12>::Zero();
  dx[2] = NAN;
  AccdInfo info;
  EXPECT_EQ(point_triangle_accd(x0, dx, 0.9, 0.0, 1.0, &info), 0.0);
  EXPECT_EQ(info.outcome, AccdOutcome::NumericalStall);
  dx[2] = 1e308;
  dx[5] = -1e308;  // l_p overflows to infinity
  EXPECT_EQ(point_triangle_accd(x0, dx, 0.9, 0.0, 1.0, &info), 0.0);
  EXPECT_EQ(info.outcome, AccdOutcome::NumericalStall);
}

}  // namespace
}  // namespace pd
