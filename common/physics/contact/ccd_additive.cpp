#include "physics/contact/ccd_additive.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "physics/contact/distance.h"

namespace pd {

namespace {

using SquaredDistance = double (*)(const Vec<12>&);

// Gap d - xi (m) from the squared distance d2 (m^2), written as (d^2 - xi^2) / (d + xi) as C-IPC
// does: d^2 - xi^2 is the quantity the barrier sees, and the quotient is exact algebra, not an
// approximation. Non-positive when d <= xi (returned as d^2 - xi^2 to avoid 0/0 at d = xi = 0).
double gap_from_squared(double d2, double xi) {
  const double s = d2 - xi * xi;
  if (!(s > 0.0)) return s;
  return s / (std::sqrt(d2) + xi);
}

// ---- The squared distances ACCD steps with ----
// ACCD is only as conservative as its distance: an overestimate lets it step through contact.
// distance.h gives a nearly degenerate pair (sin^2 of the angle between the spanning vectors
// <= 1e-14) its boundary distance even when the interior minimiser lies inside, an overestimate by
// up to ~1e-7 of the edge length (measured: edges 1e-7 rad apart crossing at a 1e-9 m gap, closing
// at 1 m per unit t: ACCD on distance.h alone returned t = 1). Closed forms cannot fix this: the
// plane normal / common normal of a sliver or of nearly parallel edges carries a direction error
// ~ eps / sin, which times the O(length) offset along the primitive is again ~1e-7 m at sin 1e-9.
// So below sin^2 = kNearDegenerateSin2 ACCD also minimises the exact distance as a convex function
// of one parameter (golden section, robust point-segment distances inside) and uses the smaller of
// the two. Above it (angles > 1e-4 rad) the closed forms' parameter error ~ eps / sin^2 <= 1e-8
// moves the distance by at most ~1e-12 of the edge length, and distance.h is used alone. (The search
// costs ~2 us per evaluation against ~0.1 us, so it is kept to this narrow band.)
constexpr double kNearDegenerateSin2 = 1e-8;
constexpr int kGoldenSteps = 80;  // 0.618^80 ~ 2e-17: the parameter to double resolution

// Squared distance from p to the segment [a, b], m^2; robust for any length, including zero.
double point_segment_d2(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 e = b - a;
  const double l2 = e.squaredNorm();
  const double t = l2 > 0 ? std::clamp((p - a).dot(e) / l2, 0.0, 1.0) : 0.0;
  return (p - a - t * e).squaredNorm();
}

// min over s in [0, 1] of a convex f, including both ends.
template <class F> double golden_section_min(const F& f) {
  const double r = 0.5 * (std::sqrt(5.0) - 1.0);
  double a = 0.0, b = 1.0, c = b - r, d = r, fc = f(c), fd = f(d);
  for (int i = 0; i < kGoldenSteps; ++i) {
    if (fc < fd) { b = d; d = c; fd = fc; c = b - r * (b - a); fc = f(c); }
    else { a = c; c = d; fc = fd; d = a + r * (b - a); fd = f(d); }
  }
  return std::min({fc, fd, f(0.0), f(1.0)});
}

bool near_degenerate(const Vec3& u, const Vec3& v) {
  return u.cross(v).squaredNorm() < kNearDegenerateSin2 * u.squaredNorm() * v.squaredNorm();
}

double ccd_point_triangle_d2(const Vec<12>& x) {
  const double d2 = point_triangle_squared_distance(x);
  const Vec3 p = x.segment<3>(0), t0 = x.segment<3>(3);
  const Vec3 e1 = x.segment<3>(6) - t0, e2 = x.segment<3>(9) - t0;
  if (!near_degenerate(e1, e2)) return d2;
  // The triangle is the union over s of the segments [t0 + s e1, t0 + s e2], and the distance to
  // them is convex in s (a partial minimum of |p - y|^2 over a convex set in (s, y)).
  return std::min(d2, golden_section_min([&](double s) {
                    return point_segment_d2(p, t0 + s * e1, t0 + s * e2);
                  }));
}

double ccd_edge_edge_d2(const Vec<12>& x) {
  const double d2 = edge_edge_squared_distance(x);
  const Vec3 a0 = x.segment<3>(0), b0 = x.segment<3>(6), b1 = x.segment<3>(9);
  const Vec3 u = x.segment<3>(3) - a0;
  if (!near_degenerate(u, b1 - b0)) return d2;
  // s -> dist^2(a0 + s u, edge b) is convex (distance from a linearly moving point to a convex set).
  return std::min(d2, golden_section_min([&](double s) { return point_segment_d2(a0 + s * u, b0, b1); }));
}

// Subtract the mean of the four vertex displacements (a common translation, which changes no
// distance) so that l_p bounds only the relative motion.
Vec<12> centred(const Vec<12>& dx) {
  const Vec3 mean = 0.25 * (dx.segment<3>(0) + dx.segment<3>(3) + dx.segment<3>(6) + dx.segment<3>(9));
  Vec<12> out = dx;
  for (int v = 0; v < 4; ++v) out.segment<3>(3 * v) -= mean;
  return out;
}

// The loop of the header's pseudo-code, shared by both primitive pairs. `dx` is centred and `lp`
// bounds |dg/dt| (m per unit t).
double additive_ccd(const Vec<12>& x0, const Vec<12>& dx, double lp, SquaredDistance dist2,
                    double ratio, double xi, double t_max, int max_iterations, AccdInfo& info) {
  info = AccdInfo{};
  info.motion_bound = lp;
  const double eta = std::clamp(ratio, 0.001, 0.999);
  const double g0 = gap_from_squared(dist2(x0), xi);
  info.initial_gap = g0;
  info.returned_gap = g0;

  // Already at or within the thickness (or NaN input): no motion is certified.
  if (!(g0 > 0.0)) {
    info.outcome = std::isnan(g0) ? AccdOutcome::NumericalStall : AccdOutcome::StartedWithinThickness;
    return 0.0;
  }
  if (!(t_max > 0.0)) {  // nothing to search (also catches NaN t_max)
    info.outcome = AccdOutcome::NoContactBeforeTMax;
    return std::max(t_max, 0.0);
  }
  if (!std::isfinite(lp)) {  // overflowed or NaN displacement: cannot bound the motion
    info.outcome = AccdOutcome::NumericalStall;
    return 0.0;
  }
  if (lp == 0.0) {  // no relative motion: every distance is constant
    info.outcome = AccdOutcome::NoContactBeforeTMax;
    return t_max;
  }

  const double target = (1.0 - eta) * g0;  // gap margin kept at the returned time, m
  double t = 0.0;
  double g = g0;
  for (int it = 1; it <= max_iterations; ++it) {
    // A step of eta * g / lp is certified: the gap cannot close faster than lp per unit t.
    double t_next = t + eta * g / lp;
    const bool last = t_next >= t_max;
    if (last) t_next = t_max;
    if (!(t_next > t)) {  // the step vanished below the resolution of t
      info.outcome = AccdOutcome::NumericalStall;
      info.returned_gap = g;
      return t;
    }
    // Evaluate at x0 + t dx directly rather than accumulating x, so rounding does not drift.
    const double g_next = gap_from_squared(dist2(x0 + t_next * dx), xi);
    info.iterations = it;
    if (!std::isfinite(g_next)) {
      info.outcome = AccdOutcome::NumericalStall;
      info.returned_gap = g;
      return t;
    }
    // The first step is always taken (it is certified and guarantees progress); afterwards stop
    // before the gap falls below the margin. g_next <= 0 can only come from rounding at a gap
    // comparable to the distance's round-off, and is caught here too.
    if ((t > 0.0 || g_next <= 0.0) && g_next < target) {
      info.outcome = AccdOutcome::StoppedAtGapMargin;
      info.returned_gap = g;
      return t;
    }
    t = t_next;
    g = g_next;
    if (last) {
      info.outcome = AccdOutcome::NoContactBeforeTMax;
      info.returned_gap = g;
      return t_max;
    }
  }
  // Guard: every step taken so far was certified, so the time reached is still safe.
  info.outcome = AccdOutcome::IterationLimit;
  info.returned_gap = g;
  return t;
}

}  // namespace

double point_triangle_accd(const Vec<12>& x0, const Vec<12>& dx, double ratio, double thickness,
                           double t_max, AccdInfo* info, int max_iterations) {
  const Vec<12> u = centred(dx);
  const double lp = u.segment<3>(0).norm() +
                    std::max({u.segment<3>(3).norm(), u.segment<3>(6).norm(), u.segment<3>(9).norm()});
  AccdInfo local;
  return additive_ccd(x0, u, lp, &ccd_point_triangle_d2, ratio, thickness, t_max,
                      max_iterations, info ? *info : local);
}

double edge_edge_accd(const Vec<12>& x0, const Vec<12>& dx, double ratio, double thickness,
                      double t_max, AccdInfo* info, int max_iterations) {
  const Vec<12> u = centred(dx);
  const double lp = std::max(u.segment<3>(0).norm(), u.segment<3>(3).norm()) +
                    std::max(u.segment<3>(6).norm(), u.segment<3>(9).norm());
  AccdInfo local;
  return additive_ccd(x0, u, lp, &ccd_edge_edge_d2, ratio, thickness, t_max,
                      max_iterations, info ? *info : local);
}

}  // namespace pd
