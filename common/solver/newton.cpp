#include "solver/newton.h"

#include <chrono>
#include <cmath>

namespace pd {

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
}  // namespace

NewtonReport newton_minimize(const IncrementalPotential& ip, Eigen::VectorXd& x,
                             const NewtonSettings& s, HessianAssembly& hessian, CholmodSolver& solver) {
  NewtonReport r;
  double energy = ip.value(x);
  // Assembles the Hessian at x with element projection `p` and factorizes it (a diagonal shift
  // where indefinite only if `shift`); times go into the report.
  const auto assemble_and_factorize = [&](HessianProjection p, bool shift) {
    const auto t0 = Clock::now();
    ip.hessian(x, p, hessian);
    bool pattern_changed = false;
    const auto& H = hessian.finish(&pattern_changed);
    r.assemble_seconds += since(t0);
    const bool ok = solver.factorize(H, pattern_changed, shift);
    r.analyse_seconds += solver.analyse_seconds();
    r.factorize_seconds += solver.factorize_seconds();
    return ok;
  };
  // ExactFirst: an iterate tries the exact Hessian first, unshifted, and is reassembled clamped only
  // if that fails (keeping the clamp for the rest of the step after one failure measured 1.3x more
  // finest-level iterations on drape-gear). After a capped step (max_step < 1: CCD, the strain
  // limit or the ground kept the step short of the full Newton step) the next iterate is clamped
  // without trying: far from the minimiser the exact Hessian, even when positive definite, can
  // point into contact, and Newton then crawls at capped steps (self-fold: one step ran out of its
  // 200 iterations). Steps shortened by the line search alone do not count: the flag has many, and
  // clamping after them cost 1.75x the time (docs/performance.md, "Which Hessian projection").
  const bool exact_first = s.projection == HessianProjection::ExactFirst;
  bool try_exact = exact_first;
  for (r.iterations = 0; r.iterations < s.max_iterations;) {
    auto t0 = Clock::now();
    const Eigen::VectorXd g = ip.gradient(x);
    r.assemble_seconds += since(t0);
    r.gradient_norms.push_back(g.norm());

    bool factorized;
    if (!exact_first) {
      factorized = assemble_and_factorize(s.projection, true);
    } else if (try_exact && assemble_and_factorize(HessianProjection::None, false)) {
      factorized = true;
      ++r.exact_hessians;
    } else {
      if (try_exact) ++r.projection_fallbacks;
      factorized = assemble_and_factorize(HessianProjection::Clamp, true);
    }
    if (!factorized) {
      r.stop_reason = "factorization_failed";
      return r;
    }
    t0 = Clock::now();
    const Eigen::VectorXd p = -solver.solve(g);
    r.solve_seconds += since(t0);
    ++r.iterations;

    const double measure = p.lpNorm<Eigen::Infinity>() / s.h;
    r.step_measures.push_back(measure);
    bool small = measure < s.step_tolerance;
    if (small && s.tangential_step) {
      const double tangential = s.tangential_step(p) / s.h;
      r.tangential_measures.push_back(tangential);
      small = tangential < s.tangential_tolerance;
    }
    if (small) {
      r.converged = true;
      r.stop_reason = "converged";
      r.gradient_norms.push_back(g.norm());
      return r;
    }

    // Backtracking: start from the largest admissible step (contact CCD caps it), halve until the
    // potential strictly decreases (plain decrease, as in IPC). Accepting equal values would let
    // Newton wander at round-off level forever once the tolerance is below what the potential can
    // resolve; with strict decrease that case ends as "no_descent".
    t0 = Clock::now();
    double alpha = ip.max_step(x, p);
    try_exact = exact_first && alpha == 1.0;
    Eigen::VectorXd trial = x + alpha * p;
    double trial_energy = ip.value(trial);
    int cuts = 0;
    while (!(std::isfinite(trial_energy) && trial_energy < energy) && cuts < s.max_line_search_cuts) {
      alpha *= 0.5;
      ++cuts;
      trial = x + alpha * p;
      trial_energy = ip.value(trial);
    }
    r.line_search_cuts += cuts;
    r.line_search_seconds += since(t0);
    if (!(std::isfinite(trial_energy) && trial_energy < energy)) {
      r.stop_reason = "no_descent";
      r.gradient_norms.push_back(g.norm());
      return r;
    }
    x = std::move(trial);
    energy = trial_energy;
    if (s.after_iteration && s.after_iteration(x)) energy = ip.value(x);
  }
  r.stop_reason = "max_iterations";
  r.gradient_norms.push_back(ip.gradient(x).norm());
  return r;
}

}  // namespace pd
