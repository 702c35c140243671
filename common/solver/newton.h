#pragma once
// Projected Newton with backtracking line search, minimising an incremental potential.
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "solver/cholmod_solver.h"
#include "solver/incremental_potential.h"

namespace pd {

struct NewtonSettings {
  double h = 0.0;                  // time step, s (the stopping test is a velocity)
  // Stop when ||p||_inf / h < step_tolerance, p the Newton step (m/s). The scene sets it to
  // tolerance * bounding-box diagonal, following IPC's scale-free measure.
  double step_tolerance = 0.0;
  // Friction's test, when set: converged also needs tangential_step(p) / h < tangential_tolerance
  // (m/s), tangential_step(p) the largest change (m) the step p makes to a friction contact's
  // tangential displacement. Inside the static cone a contact's Newton step is small because the
  // smoothed friction is stiff there, not because the step is converged; this resolves contacts
  // finely without holding the whole mesh to that precision.
  std::function<double(const Eigen::VectorXd&)> tangential_step;
  double tangential_tolerance = 0.0;
  int max_iterations = 200;
  int max_line_search_cuts = 40;   // halvings before the line search gives up (no descent)
  // Element Hessian projection. ExactFirst: at every iterate the exact Hessian, reassembled with
  // Clamp only when CHOLMOD finds the assembled system indefinite; an iterate after a capped step
  // (max_step < 1) is clamped without trying, and a full clamped step after two clamped iterates
  // whose steps grew is extended while the potential decreases (leaving a saddle); with
  // exact_curvature_iterations, the clamped step of an iterate whose exact Hessian was indefinite is
  // refined on the exact Hessian (below).
  // Clamping every indefinite element overestimates the curvature along buckling directions of a
  // compressed sheet, which the inertia term alone usually keeps positive; Newton then creeps
  // along them at a linear rate (docs/performance.md, "Which Hessian projection").
  HessianProjection projection = HessianProjection::Clamp;
  // ExactFirst only, and only where the assembled Hessian is the potential's true one (not a coarse
  // level's lagged prolonged blocks): an iterate whose exact Hessian was indefinite refines its
  // clamped step by up to this many conjugate-gradient iterations on the exact Hessian, preconditioned
  // by the clamped factorization (solver/exact_curvature_step.h); 0 keeps the clamped step. The
  // relative tolerance is on the preconditioned residual's norm.
  int exact_curvature_iterations = 0;
  double exact_curvature_tolerance = 1e-3;
  // Where the assembled Hessian is only a model of the potential's (a coarse level: the prolonged
  // elasticity's blocks are the coarse stand-in's or lagged Gauss-Newton ones): an iterate whose step
  // fails its first line-search trial probes the true curvature along it, by conjugate gradients on
  // products with the potential's Hessian (IncrementalPotential::hessian_product, differences of
  // gradients) preconditioned by the model's factorization, up to this many iterations. When the
  // true curvature along the model step is off the model's by more than 1.5x either way, the
  // refined step replaces it and every later iterate of the solve is refined the same way before its
  // line search; otherwise the step is cut as usual (the cause was nonlinearity farther along it) and
  // the solve probes no more. A term whose stand-in Hessian phase ends at the next assembly
  // (EnergyTerm::stand_in_hessian_ends) has it probed the same way, by one product: within 1.1x the
  // stand-in is kept for the rest of the step, and a later probe outside 1.5x lets it go (newton.cpp).
  // 0: off. The tolerance is on the preconditioned residual's norm, relative.
  int model_curvature_iterations = 0;
  double model_curvature_tolerance = 0.1;
  // Called with every accepted iterate; it may change the potential's parameters (IPC's adaptive
  // barrier stiffness) and returns true when it did, so that the potential is evaluated afresh
  // only then (a full evaluation per iteration would be wasted while nothing changes).
  std::function<bool(const Eigen::VectorXd&)> after_iteration;
};

struct NewtonReport {
  int iterations = 0;              // Newton systems solved
  int line_search_cuts = 0;        // halvings over all iterations
  // ExactFirst only: iterations solved with the exact Hessian, and iterations whose exact Hessian
  // was indefinite and was reassembled clamped (the rest followed a capped step and were clamped)
  int exact_hessians = 0;
  int projection_fallbacks = 0;
  // ExactFirst only: full steps extended (2x-8x) because the clamped steps before them kept growing,
  // the sign of Newton leaving a saddle (newton.cpp)
  int extended_steps = 0;
  // Conjugate-gradient iterations that refined steps on the exact Hessian: clamped steps
  // (exact_curvature_iterations) and model steps (model_curvature_iterations)
  int exact_curvature_iterations = 0;
  // Model Hessians: steps whose failed first trial had the true curvature probed, and stand-in
  // phases probed at their end
  int curvature_probes = 0;
  bool converged = false;
  // "converged" | "max_iterations" | "no_descent" | "factorization_failed", or "pins_blocked" (set
  // by the level stepper when scripted pins could not reach their targets)
  std::string stop_reason;
  std::vector<double> step_measures;   // ||p||_inf / h per iteration, m/s
  // tangential_step(p) / h of the iterations whose step measure passed, m/s (friction test only)
  std::vector<double> tangential_measures;
  std::vector<double> gradient_norms;  // ||grad||_2 at the start of each iteration, and at the end
  double assemble_seconds = 0.0, analyse_seconds = 0.0, factorize_seconds = 0.0, solve_seconds = 0.0,
         line_search_seconds = 0.0;
};

// Minimises ip starting from x (fixed dofs already at their targets; they are never changed).
// x must be admissible (finite potential).
NewtonReport newton_minimize(const IncrementalPotential& ip, Eigen::VectorXd& x,
                             const NewtonSettings& settings, HessianAssembly& hessian,
                             CholmodSolver& solver);

}  // namespace pd
