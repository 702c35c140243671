#include "progressive/level_stepper.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

#include "physics/contact/friction.h"
#include "physics/inertia.h"
#include "physics/pin_target.h"
#include "progressive/prolonged_term.h"

namespace pd {

namespace {

// Augmented-Lagrangian rounds a step may spend moving blocked pins before it gives up.
constexpr int kMaxPinRounds = 32;
// Initial pull stiffness in units of a free vertex's inertia stiffness (mass / h^2).
constexpr double kPinPullScale = 1e4;
// Newton's velocity tolerance with friction, as a fraction of the friction's eps_v.
constexpr double kFrictionToleranceFraction = 0.1;
// Conjugate-gradient refinement of clamped steps on the exact Hessian (solver/exact_curvature_step.h):
// at most 30 iterations, down to NewtonSettings' default tolerance (1e-3 of the preconditioned
// residual). Most refinements stop after 1-2 iterations; 10 / 1e-2 and 100 / 1e-4 gave the same
// Newton iteration counts on drape-gear and spin-sphere within the spread that any change of the
// steps brings (docs/performance.md, "The exact curvature behind a clamped step").
constexpr int kExactCurvatureIterations = 30;
// A coarse level's model Hessian: conjugate-gradient iterations on the true curvature for a step the
// model got wrong (solver/newton.h), down to 1e-1 of the preconditioned residual. Each costs a
// gradient, so the tolerance is loose. spin-sphere's preview, 30 frames, probing every cut: 10 / 1e-1,
// 20 / 1e-1, 10 / 0.3, 5 / 1e-1 and 10 / 3e-2 took 483, 486, 497, 505 and 470 Newton iterations and
// times within the machine's spread (docs/performance.md, "A model Hessian that knows when it is
// wrong").
constexpr int kModelCurvatureIterations = 10;
constexpr double kModelCurvatureTolerance = 0.1;

void accumulate(NewtonReport& total, const NewtonReport& part) {
  total.iterations += part.iterations;
  total.line_search_cuts += part.line_search_cuts;
  total.exact_hessians += part.exact_hessians;
  total.projection_fallbacks += part.projection_fallbacks;
  total.extended_steps += part.extended_steps;
  total.exact_curvature_iterations += part.exact_curvature_iterations;
  total.curvature_probes += part.curvature_probes;
  total.assemble_seconds += part.assemble_seconds;
  total.analyse_seconds += part.analyse_seconds;
  total.factorize_seconds += part.factorize_seconds;
  total.solve_seconds += part.solve_seconds;
  total.line_search_seconds += part.line_search_seconds;
}

}  // namespace

LevelStepper::LevelStepper(SceneSystem& system, const SolverSettings& settings, double h)
    : sys_(system), settings_(settings), h_(h) {}

FrameRecord LevelStepper::record(int frame, const Eigen::VectorXd& x, const Eigen::VectorXd& v) const {
  FrameRecord r;
  r.frame = frame;
  r.time = frame * h_;
  r.x = x;
  r.kinetic_energy = kinetic_energy(sys_.masses, v);
  r.energies = sys_.ip.term_values(x, "inertia");
  r.contact = sys_.contact.stats(x);
  r.center_of_mass = centers_of_mass(sys_, x);
  return r;
}

FrameRecord LevelStepper::initial_frame() const { return record(0, sys_.x0, sys_.v0); }

// Scripted pins (and moving obstacles) must not jump through free vertices. When the straight move
// to their targets would cross contact (the potential's CCD caps it), the pins become unknowns
// pulled toward their targets by an augmented-Lagrangian term (physics/pin_target.h, IPC's kinematic
// targets), so the solve moves pins and cloth together and every iterate stays intersection-free.
// Once the rest of the way is collision-free, the pins are placed exactly and fixed again.
int LevelStepper::move_pins(double t_end, Eigen::VectorXd& x, const NewtonSettings& ns, NewtonReport& report) {
  if (sys_.scripts.empty()) return 0;
  Eigen::VectorXd target = x;
  for (const auto& pin : sys_.pins) target.segment<3>(3 * pin.vertex) = pin_position(sys_, pin, t_end);
  const Eigen::VectorXd d = target - x;
  if (d.isZero(0.0)) return 0;
  if (sys_.ip.max_step(x, d) >= 1.0) {
    x = target;
    return 0;
  }
  // Nothing free to make room (a scene of obstacles only): the pins are blocked.
  if (!(sys_.average_free_mass > 0)) return -1;
  PinTargetTerm& pull = *sys_.pin_target;
  const std::vector<char> fixed = sys_.ip.fixed_dofs();
  std::vector<char> free_scripted = fixed;
  for (const auto& pin : sys_.pins)
    if (pin.script >= 0) free_scripted[3 * pin.vertex] = free_scripted[3 * pin.vertex + 1] = free_scripted[3 * pin.vertex + 2] = 0;
  sys_.ip.set_fixed_dofs(free_scripted);
  // Stiff against the inertia of a free vertex (mass / h^2), so the pins lead and the cloth follows.
  pull.activate(target, kPinPullScale * sys_.average_free_mass / (h_ * h_));
  int rounds = -1;
  double previous = pull.max_distance(x);
  for (int round = 1; round <= kMaxPinRounds; ++round) {
    accumulate(report, newton_minimize(sys_.ip, x, ns, hessian_, solver_));
    Eigen::VectorXd rest = Eigen::VectorXd::Zero(x.size());
    for (int v : pull.vertices()) rest.segment<3>(3 * v) = target.segment<3>(3 * v) - x.segment<3>(3 * v);
    if (sys_.ip.max_step(x, rest) >= 1.0) {
      x += rest;
      rounds = round;
      break;
    }
    // IPC's rule: update the multipliers while the pins close in, stiffen the pull when they stall.
    const double distance = pull.max_distance(x);
    if (distance < 0.5 * previous) {
      pull.update_multipliers(x);
    } else {
      pull.set_stiffness(2.0 * pull.stiffness());
    }
    previous = distance;
  }
  pull.deactivate();
  sys_.ip.set_fixed_dofs(fixed);
  return rounds;
}

void LevelStepper::check_state(int frame, const Eigen::VectorXd& x, const Eigen::VectorXd& v) const {
  const auto fail = [&](Eigen::Index vertex, const std::string& what) {
    const auto& off = sys_.object_offsets;
    std::size_t k = 0;
    while (k + 1 < off.size() && off[k + 1] <= vertex) ++k;
    const std::string object = k < sys_.object_names.size() ? sys_.object_names[k] : "?";
    throw StateDiverged("frame " + std::to_string(frame) + ": the simulation diverged: object '" + object +
                        "' vertex " + std::to_string(vertex - (k < off.size() ? off[k] : 0)) + ": " + what);
  };
  char text[160];
  for (Eigen::Index i = 0; i < x.size() / 3; ++i) {
    const Vec3 p = x.segment<3>(3 * i), u = v.segment<3>(3 * i);
    if (!p.allFinite() || !u.allFinite()) fail(i, "position or velocity is not finite");
    if (p.cwiseAbs().maxCoeff() > kDivergedDistance) {
      std::snprintf(text, sizeof text, "a coordinate of %.3g m, beyond %.0g m", p.cwiseAbs().maxCoeff(), kDivergedDistance);
      fail(i, text);
    }
    if (u.norm() > kDivergedSpeed) {
      std::snprintf(text, sizeof text, "a speed of %.3g m/s, beyond %.0g m/s", u.norm(), kDivergedSpeed);
      fail(i, text);
    }
  }
}

FrameRecord LevelStepper::step(int frame, Eigen::VectorXd& x, Eigen::VectorXd& v, const StepInput& input) {
  const auto t0 = std::chrono::steady_clock::now();
  const double t_end = (frame + 1) * h_;
  const Eigen::VectorXd x_start = x, v_start = v;

  StepStart start;
  start.time_end = t_end;
  start.h = h_;
  start.x = &x_start;
  start.v = &v_start;
  if (input.warm_start) x = *input.warm_start;
  // With frozen offsets (progressive/prolonged_term.h), a coarse level's prolonged elasticity takes
  // them from Newton's current iterate: first from the start, then after every accepted iterate
  // (a no-op with the exact gradient, the default).
  if (sys_.prolongation) sys_.prolongation->refresh(x);
  sys_.ip.begin_step(start);
  if (input.inertia_target) sys_.inertia->set_predicted_positions(*input.inertia_target);
  sys_.contact.begin_step(sys_.ip, start);

  NewtonSettings ns;
  ns.h = h_;
  ns.step_tolerance = settings_.tolerance * sys_.bbox_diagonal;
  // With friction the stopping test must resolve tangential speeds below eps_v: a first Newton step
  // from rest lies inside the static-friction cone (|u| < eps_v h), so a looser test would accept
  // it and a sheet that should slide would stay put (measured on a 35 degree slope, mu = 0.5, in a
  // 1.8 m scene: tolerance * bbox = 1.8e-3 m/s against a first step of 7e-4 m/s). Contacts: only
  // the contacts' tangential steps are held to that; Uniform: every vertex's step.
  if (const FrictionTerm* friction = sys_.contact.friction) {
    const double tight = kFrictionToleranceFraction * friction->eps_v();
    if (settings_.friction_stopping == FrictionStopping::Uniform) {
      ns.step_tolerance = std::min(ns.step_tolerance, tight);
    } else {
      ns.tangential_step = [friction](const Eigen::VectorXd& p) { return friction->max_tangential_step(p); };
      ns.tangential_tolerance = tight;
    }
  }
  ns.max_iterations = settings_.max_newton_iterations;
  ns.projection = settings_.projection;
  // Only where the assembled Hessian is the potential's own: a coarse level's prolonged blocks are
  // lagged, and refining the clamped step on them cost spin-sphere's preview 17% more iterations.
  // Elsewhere the assembled Hessian is a model (prolonged blocks), checked against the true curvature
  // where a step fails: spin-sphere's lagged Gauss-Newton blocks underestimated it 2-10x along the
  // steps the line search cut.
  if (!sys_.prolongation) {
    ns.exact_curvature_iterations = kExactCurvatureIterations;
  } else {
    ns.model_curvature_iterations = kModelCurvatureIterations;
    ns.model_curvature_tolerance = kModelCurvatureTolerance;
  }
  const bool barrier = sys_.contact.has_barrier();
  if (barrier || sys_.prolongation)
    ns.after_iteration = [this, barrier](const Eigen::VectorXd& xi) {
      const bool kappa_changed = barrier && sys_.contact.after_iteration(xi);
      const bool offsets_changed = sys_.prolongation && sys_.prolongation->refresh(xi);
      return kappa_changed || offsets_changed;
    };

  // Pinned vertices go to where their scripts put them at the end of the step; Newton then keeps
  // them there (fixed dofs) and solves for the rest.
  NewtonReport pins_report;
  const int pin_rounds = move_pins(t_end, x, ns, pins_report);
  NewtonReport report;
  if (pin_rounds >= 0) {
    report = newton_minimize(sys_.ip, x, ns, hessian_, solver_);
  } else {
    report.stop_reason = "pins_blocked";
  }
  accumulate(report, pins_report);
  v = (x - x_start) / h_;
  check_state(frame + 1, x, v);

  FrameRecord r = record(frame + 1, x, v);
  r.newton = std::move(report);
  r.pin_rounds = pin_rounds;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace pd
