#pragma once
// Additive continuous collision detection (ACCD; C-IPC, Li, Kaufman & Jiang 2021, Algorithm 1).
//
// The primitives move linearly, x(t) = x0 + t dx for t in [0, t_max] (t is the line-search step
// fraction, dimensionless; positions and displacements in metres). Contact means the distance
// between the primitives reaching `thickness` xi (m, the C-IPC offset: xi = 0 is plain IPC), so the
// quantity that must stay positive is the gap g(t) = d(t) - xi (m).
//
// Why it is conservative: subtracting the mean of the four displacements changes no distance (a
// common translation), and after that the gap cannot change faster than
//   l_p = ||dp|| + max_i ||dt_i||                          point-triangle (p, t0, t1, t2)
//   l_p = max(||dea0||, ||dea1||) + max(||deb0||, ||deb1||) edge-edge     (ea0, ea1, eb0, eb1)
// metres per unit t (every point of a primitive moves with a convex combination of its vertices'
// velocities, and a minimum of l_p-Lipschitz functions is l_p-Lipschitz). So from a time t with gap
// g, no contact can happen before t + g / l_p, and ACCD adds such safe steps:
//
//   eta = ratio in (0, 1), typically 0.9;  target = (1 - eta) * g(0)
//   t = 0;  repeat: t_next = min(t + eta * g(t) / l_p, t_max)
//                    if (t > 0 or g(t_next) <= 0) and g(t_next) < target:
//                      return t                                     (keep a gap margin)
//                    if t_next == t_max: return t_max               (no contact in [0, t_max])
//                    t = t_next
//
// C-IPC writes the algorithm with s = 1 - eta (first step (1 - s) g / l_p, stop below s g(0),
// s = 0.1, later steps 0.9 g / l_p); `ratio` here is eta, the fraction of the certified safe step
// that is taken, so ratio = 0.9 reproduces C-IPC. Stopping at a gap of (1 - eta) g(0) rather than
// at contact keeps the next Newton iteration away from the barrier's singularity, and the returned
// time is always one whose every step was certified (up to floating-point rounding in the distance,
// which the (1 - eta) slack absorbs; d - xi itself is resolved to ~eps |x|^2 / xi, ~1e-13 m for
// coordinates ~1 m and xi ~ 1e-3 m). The first step is kept even if it lands below the margin
// (C-IPC does so to guarantee progress) unless its gap evaluates to <= 0, which only rounding can do.
//
// Distance: distance.h's squared distances, except that for a nearly degenerate triangle or nearly
// parallel edge pair (sin^2 < 1e-8 between the spanning vectors) the smaller of that and an exact
// one-parameter convex minimisation is used, because distance.h deliberately overestimates such
// pairs (see ccd_additive.cpp), and an overestimated distance lets ACCD step through contact.
//
// `ratio`: C-IPC's Algorithm 1 uses s = 0.1 as "the fraction of the gap to keep"; read literally
// with ratio = s, steps would be (1 - ratio) = 10% of the safe step and the answer ~0.1 of the
// impact time. Here ratio is the fraction of each safe step taken (eta = 1 - s), so the common
// ratio = 0.9 gives C-IPC's behaviour and returned times typically 0.7-0.9 of the impact time.
//
// Termination: each step after the first is at least eta (1 - eta) g(0) / l_p, so the loop ends
// after at most about 1 + t_max l_p / (eta (1 - eta) g(0)) distance evaluations. That bound is huge
// when g(0) is tiny and the motion is large but tangential (sliding at a near-zero gap), so a guard
// of `max_iterations` evaluations stops the loop. Fallback on the guard (and on a step below the
// floating-point resolution of t, or a non-finite distance): return the time reached so far - the
// last certified one, so still safe, usually tiny (~max_iterations * eta * g / l_p), and 0 only if
// no step was taken. The caller's line search then simply takes that short step.
//
// Returned time in [0, t_max]:
//   t_max  no contact within [0, t_max] (also for zero relative motion);
//   0      the start is already at or within the thickness (d(x0) <= xi): any motion is refused and
//          the caller must resolve the overlap by other means; also for non-finite inputs;
//   else   a time whose gap is still >= (1 - ratio) g(0) (or the fallback above).
#include "geometry/mesh.h"

namespace pd {

// Why an ACCD query returned what it returned (for diagnostics and tests).
enum class AccdOutcome {
  NoContactBeforeTMax,       // returned t_max
  StoppedAtGapMargin,        // returned the last time whose gap was >= (1 - ratio) g(0)
  StartedWithinThickness,    // d(x0) <= thickness: returned 0
  IterationLimit,            // guard hit: returned the time reached so far
  NumericalStall,            // step below resolution of t, or non-finite values: time reached so far
};

struct AccdInfo {
  AccdOutcome outcome = AccdOutcome::NoContactBeforeTMax;
  int iterations = 0;        // distance evaluations after the initial one
  double initial_gap = 0.0;  // d(x0) - thickness, m
  double returned_gap = 0.0; // d - thickness at the returned time, m (as evaluated there)
  double motion_bound = 0.0; // l_p, m per unit t
};

constexpr int kAccdDefaultMaxIterations = 10000;

// x0, dx: (p, t0, t1, t2) start positions and displacements, m. ratio in (0, 1) (values outside are
// clamped to [0.001, 0.999]; safe upsampling uses 0.001 for PSQ's keep-ratio 0.999); thickness >= 0, m; t_max >= 0. info (optional) receives diagnostics.
double point_triangle_accd(const Vec<12>& x0, const Vec<12>& dx, double ratio, double thickness,
                           double t_max, AccdInfo* info = nullptr,
                           int max_iterations = kAccdDefaultMaxIterations);

// x0, dx: (ea0, ea1, eb0, eb1); otherwise as point_triangle_accd.
double edge_edge_accd(const Vec<12>& x0, const Vec<12>& dx, double ratio, double thickness,
                      double t_max, AccdInfo* info = nullptr,
                      int max_iterations = kAccdDefaultMaxIterations);

}  // namespace pd
