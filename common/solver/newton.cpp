#include "solver/newton.h"

#include <chrono>
#include <cmath>
#include <limits>

#include "solver/exact_curvature_step.h"

namespace pd {

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Saddle escape (ExactFirst): consecutive clamped iterates whose step measure grew before an
// extension is tried, and the longest extension, as a multiple of the Newton step (tried 2x, 4x, 8x).
// One growth alone also happens near convergence (basket's direct run: 7.1e-4 -> 8.1e-4 m/s, and an
// extension there sent one step from 11 to 34 iterations); two in a row is the escape pattern
// (drape-gear: 1.2x-1.4x per iterate for ten iterates). 64x instead of 8x changed nothing measurable
// (docs/performance.md, "Leaving a saddle").
constexpr int kGrowthsBeforeExtension = 2;
constexpr double kMaxExtension = 8.0;

// Model Hessians (model_curvature_iterations): a probe that finds the true curvature along the model
// step within this factor of the model's blames the failed step on the potential's nonlinearity
// farther along it, not on the model. On flag-large's preview every probed step measured 0.8-1.25
// (the coarse stand-in is right there, its cuts come from the flapping); on spin-sphere's, 80% of the
// cut steps measured above 2 (lagged Gauss-Newton blocks of a cloth winding onto a sphere).
constexpr double kModelCurvatureBand = 1.5;

// A stand-in Hessian about to give way to the costlier lagged Galerkin one (EnergyTerm::
// stand_in_hessian_ends) is kept for the rest of the step when the true curvature along its step is
// within this factor of its own. Tighter than kModelCurvatureBand: a stand-in too stiff along some
// directions hides it along its step (its step is short there), so only a close match keeps it.
// 30-frame previews, one thread (docs/performance.md, "Keeping the stand-in Hessian"): flag-large's probes
// measured 1.00-1.08 on all but two steps; with 1.2 instead of 1.1 ball-drop took 260 Newton
// iterations instead of 236, with 1.5 289.
constexpr double kStandInBand = 1.1;

bool within(double ratio, double band) { return std::isfinite(ratio) && ratio <= band && ratio >= 1.0 / band; }

// Extends an accepted full step x + p to x + alpha p, alpha = 2, 4, ... up to kMaxExtension, while
// the CCD bound admits it and the potential keeps strictly decreasing; `trial` and `trial_energy`
// hold the accepted point. Returns whether it extended.
bool extend_step(const IncrementalPotential& ip, const Eigen::VectorXd& x, const Eigen::VectorXd& p,
                 Eigen::VectorXd& trial, double& trial_energy, double& alpha) {
  // One CCD pass over the longest extension: any shorter one along the same line is admissible.
  const double bound = kMaxExtension * ip.max_step(x, kMaxExtension * p);
  bool extended = false;
  while (2.0 * alpha <= bound) {
    Eigen::VectorXd further = x + (2.0 * alpha) * p;
    const double e = ip.value(further);
    if (!(std::isfinite(e) && e < trial_energy)) break;
    alpha *= 2.0;
    trial = std::move(further);
    trial_energy = e;
    extended = true;
  }
  return extended;
}

// A trial point of the line search: x + alpha p and its potential.
struct Trial {
  double alpha = 0.0;
  Eigen::VectorXd x;
  double energy = 0.0;
};

// The line search's first trial: the largest admissible step along p (CCD and the other step
// bounds cap it).
Trial first_trial(const IncrementalPotential& ip, const Eigen::VectorXd& x, const Eigen::VectorXd& p) {
  Trial t;
  t.alpha = ip.max_step(x, p);
  t.x = x + t.alpha * p;
  t.energy = ip.value(t.x);
  return t;
}

// Model Hessians (NewtonSettings::model_curvature_iterations): the model step p refined by conjugate
// gradients on the potential's own Hessian, whose products are differences of gradients at x (g =
// its gradient), preconditioned by the model's factorization in `solver`.
ExactCurvatureStep refine_on_true_curvature(const IncrementalPotential& ip, const Eigen::VectorXd& x,
                                            const Eigen::VectorXd& g, const Eigen::VectorXd& p,
                                            const CholmodSolver& solver, const NewtonSettings& s, NewtonReport& r) {
  const HessianProduct product = [&](const Eigen::VectorXd& d, Eigen::VectorXd& out) {
    return ip.hessian_product(x, g, d, out);
  };
  ExactCurvatureStep refined =
      exact_curvature_step(product, solver, g, p, s.model_curvature_iterations, s.model_curvature_tolerance);
  r.exact_curvature_iterations += refined.iterations;
  return refined;
}

// The true curvature along the model step p = -C^{-1} g at x against the model's: p^T H p over
// p^T C p = -g^T p, with H p one difference of gradients (the same ratio as the refinement's first
// iteration, without its solve). NaN when the product fails.
double model_curvature_ratio(const IncrementalPotential& ip, const Eigen::VectorXd& x, const Eigen::VectorXd& g,
                             const Eigen::VectorXd& p, NewtonReport& r) {
  ++r.curvature_probes;
  Eigen::VectorXd Hp;
  if (!ip.hessian_product(x, g, p, Hp)) return std::numeric_limits<double>::quiet_NaN();
  const double curvature = p.dot(Hp);
  if (curvature > 0.0) ++r.exact_curvature_iterations;  // counted as that first iteration was
  return curvature / (-g).dot(p);
}

// The stopping test on the step p: its measure ||p||_inf / h below the step tolerance and, with
// friction, the contacts' tangential step below theirs (recorded in r).
bool step_converged(const Eigen::VectorXd& p, double measure, const NewtonSettings& s, NewtonReport& r) {
  if (!(measure < s.step_tolerance)) return false;
  if (!s.tangential_step) return true;
  const double tangential = s.tangential_step(p) / s.h;
  r.tangential_measures.push_back(tangential);
  return tangential < s.tangential_tolerance;
}

// Assembles the Hessian at x with element projection `p` and factorizes it (a diagonal shift where
// indefinite only if `shift`); times go into the report. `assembled` points to the matrix (lower
// triangle, held by `hessian` until its next assembly).
bool assemble_and_factorize(const IncrementalPotential& ip, const Eigen::VectorXd& x, HessianProjection p, bool shift,
                            HessianAssembly& hessian, CholmodSolver& solver, NewtonReport& r,
                            const CholmodSolver::SparseMatrix** assembled = nullptr) {
  const auto t0 = Clock::now();
  ip.hessian(x, p, hessian);
  bool pattern_changed = false;
  const auto& H = hessian.finish(&pattern_changed);
  if (assembled) *assembled = &H;
  r.assemble_seconds += since(t0);
  const bool ok = solver.factorize(H, pattern_changed, shift);
  r.analyse_seconds += solver.analyse_seconds();
  r.factorize_seconds += solver.factorize_seconds();
  return ok;
}

// What an iterate's Hessian turned out to be.
struct IterateHessian {
  bool factorized = false;
  bool clamped = false;     // ExactFirst only: the clamped one is factorized
  bool have_exact = false;  // `exact` holds this iterate's exact Hessian, which was indefinite
};

// The iterate's Hessian at x, assembled and factorized by the projection policy. ExactFirst: the
// exact Hessian first (when `try_exact`), unshifted, reassembled clamped only if CHOLMOD finds it
// indefinite (keeping the clamp for the rest of the step after one failure measured 1.3x more
// finest-level iterations on drape-gear); with `keep_exact` the indefinite exact matrix is copied into
// `exact` for the step's refinement (the clamped reassembly overwrites `hessian`).
IterateHessian assemble_iterate_hessian(const IncrementalPotential& ip, const Eigen::VectorXd& x,
                                        const NewtonSettings& s, bool try_exact, bool keep_exact,
                                        HessianAssembly& hessian, CholmodSolver& solver,
                                        CholmodSolver::SparseMatrix& exact, NewtonReport& r) {
  IterateHessian out;
  if (s.projection != HessianProjection::ExactFirst) {
    out.factorized = assemble_and_factorize(ip, x, s.projection, true, hessian, solver, r);
    return out;
  }
  const CholmodSolver::SparseMatrix* assembled = nullptr;
  if (try_exact && assemble_and_factorize(ip, x, HessianProjection::None, false, hessian, solver, r, &assembled)) {
    out.factorized = true;
    ++r.exact_hessians;
    return out;
  }
  if (try_exact) {
    ++r.projection_fallbacks;
    if (keep_exact) {
      exact = *assembled;
      out.have_exact = true;
    }
  }
  out.clamped = true;
  out.factorized = assemble_and_factorize(ip, x, HessianProjection::Clamp, true, hessian, solver, r);
  return out;
}

}  // namespace

NewtonReport newton_minimize(const IncrementalPotential& ip, Eigen::VectorXd& x,
                             const NewtonSettings& s, HessianAssembly& hessian, CholmodSolver& solver) {
  NewtonReport r;
  double energy = ip.value(x);
  // ExactFirst (assemble_iterate_hessian): whether the next iterate tries the exact Hessian. After a
  // capped step (max_step < 1: CCD, the strain limit or the ground kept the step short of the full
  // Newton step) it is clamped without trying: far from the minimiser the exact Hessian, even when
  // positive definite, can point into contact, and Newton then crawls at capped steps (self-fold: one
  // step ran out of its 200 iterations). Steps shortened by the line search alone do not count: the
  // flag has many, and clamping after them cost 1.75x the time (docs/performance.md, "Which Hessian
  // projection").
  const bool exact_first = s.projection == HessianProjection::ExactFirst;
  bool try_exact = exact_first;
  // A clamped iterate of ExactFirst sits where the exact Hessian is indefinite. When the full,
  // uncapped clamped steps keep growing, Newton is leaving a saddle (a compressed sheet buckling):
  // along the negative-curvature direction the clamped model's curvature is too high, each step
  // only multiplies the distance from the saddle by 1 + |lambda| / c, and the escape takes tens of
  // iterations (drape-gear's finest refinement: 16 in one step). Such a step is then extended
  // (2x, 4x, up to kMaxExtension, within the CCD bound) while the potential keeps decreasing.
  bool last_clamped = false;
  int clamped_growths = 0;  // consecutive clamped iterates whose step measure grew
  // The exact Hessian of an iterate that fell back to the clamped one, kept for its step's refinement
  // (the assembly's matrix is overwritten by the clamped reassembly).
  CholmodSolver::SparseMatrix exact;
  const bool refine_clamped = exact_first && s.exact_curvature_iterations > 0;
  // Model Hessians: what this solve's probe found. Wrong: every later iterate refines its step on the
  // true curvature before its line search. Right: no more probes in this solve; its later cuts are
  // taken to be the same nonlinearity (each probe costs a gradient: probing every cut of flag-large's
  // preview cost 4-7% of its time for nothing, while spin-sphere's preview, 30 frames, takes 527
  // Newton iterations this way against 483, still 0.7x the 783 without probes).
  enum class Model { Unprobed, Wrong, Right } model = Model::Unprobed;
  for (r.iterations = 0; r.iterations < s.max_iterations;) {
    auto t0 = Clock::now();
    const Eigen::VectorXd g = ip.gradient(x);
    r.assemble_seconds += since(t0);
    r.gradient_norms.push_back(g.norm());

    const IterateHessian h = assemble_iterate_hessian(ip, x, s, try_exact, refine_clamped, hessian, solver, exact, r);
    const bool clamped = h.clamped, have_exact = h.have_exact;
    if (!h.factorized) {
      r.stop_reason = "factorization_failed";
      return r;
    }
    t0 = Clock::now();
    Eigen::VectorXd p = -solver.solve(g);
    // Refined on the exact Hessian: a clamped step where the exact one was assembled, a model step
    // once a probe found the model wrong in this solve.
    const bool refine_model = !have_exact && model == Model::Wrong;
    if (have_exact) {
      ExactCurvatureStep refined = exact_curvature_step(exact, solver, g, p, s.exact_curvature_iterations,
                                                        s.exact_curvature_tolerance);
      p = std::move(refined.step);
      r.exact_curvature_iterations += refined.iterations;
    } else if (refine_model) {
      p = refine_on_true_curvature(ip, x, g, p, solver, s, r).step;
    }
    r.solve_seconds += since(t0);
    ++r.iterations;

    const double measure = p.lpNorm<Eigen::Infinity>() / s.h;
    const bool grew = last_clamped && clamped && measure > r.step_measures.back();
    clamped_growths = grew ? clamped_growths + 1 : 0;
    last_clamped = clamped;
    r.step_measures.push_back(measure);
    if (step_converged(p, measure, s, r)) {
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
    // A stand-in Hessian whose phase ends here stays for the rest of the step if it is right along
    // its step (kStandInBand); a later failed step is still probed, and a wrong verdict then lets it
    // go. Not once a probe found the model wrong: its steps are refined, and the Galerkin Hessian
    // takes over as without probes. After the stopping test, so a step that ends here pays nothing.
    if (s.model_curvature_iterations > 0 && !have_exact && model != Model::Wrong && ip.stand_in_hessian_ends())
      ip.keep_stand_in_hessian(within(model_curvature_ratio(ip, x, g, p, r), kStandInBand));
    Trial trial = first_trial(ip, x, p);
    const auto descends = [&] { return std::isfinite(trial.energy) && trial.energy < energy; };
    // A model Hessian's step that does not descend: probe the true curvature along it. Outside the
    // band the model is wrong here: take the refined step instead, and refine from now on.
    if (!descends() && s.model_curvature_iterations > 0 && model == Model::Unprobed && !have_exact) {
      ++r.curvature_probes;
      ExactCurvatureStep refined = refine_on_true_curvature(ip, x, g, p, solver, s, r);
      const double ratio = refined.first_curvature_ratio;
      if (std::isfinite(ratio) && !within(ratio, kModelCurvatureBand)) {
        model = Model::Wrong;
        ip.keep_stand_in_hessian(false);
        p = std::move(refined.step);
        trial = first_trial(ip, x, p);
      } else if (std::isfinite(ratio)) {
        model = Model::Right;
      }
    }
    try_exact = exact_first && trial.alpha == 1.0;
    int cuts = 0;
    while (!descends() && cuts < s.max_line_search_cuts) {
      trial.alpha *= 0.5;
      ++cuts;
      trial.x = x + trial.alpha * p;
      trial.energy = ip.value(trial.x);
    }
    // An extension only ever accepts a lower potential, so a step that descends still does after it.
    if (clamped_growths >= kGrowthsBeforeExtension && trial.alpha == 1.0 && cuts == 0 && descends() &&
        extend_step(ip, x, p, trial.x, trial.energy, trial.alpha))
      ++r.extended_steps;
    r.line_search_cuts += cuts;
    r.line_search_seconds += since(t0);
    if (!descends()) {
      r.stop_reason = "no_descent";
      r.gradient_norms.push_back(g.norm());
      return r;
    }
    x = std::move(trial.x);
    energy = trial.energy;
    if (s.after_iteration && s.after_iteration(x)) energy = ip.value(x);
  }
  r.stop_reason = "max_iterations";
  r.gradient_norms.push_back(ip.gradient(x).norm());
  return r;
}

}  // namespace pd
