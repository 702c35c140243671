#include "progressive/level_stepper.h"

#include <chrono>

#include "physics/inertia.h"

namespace pd {

LevelStepper::LevelStepper(SceneSystem& system, const SolverSettings& settings, double h)
    : sys_(system), settings_(settings), h_(h) {}

FrameRecord LevelStepper::record(int frame, const Eigen::VectorXd& x, const Eigen::VectorXd& v) const {
  FrameRecord r;
  r.frame = frame;
  r.time = frame * h_;
  r.x = x;
  r.kinetic_energy = kinetic_energy(sys_.masses, v);
  r.energies = sys_.ip.term_values(x, "inertia");
  r.center_of_mass = centers_of_mass(sys_, x);
  return r;
}

FrameRecord LevelStepper::initial_frame() const { return record(0, sys_.x0, sys_.v0); }

FrameRecord LevelStepper::step(int frame, Eigen::VectorXd& x, Eigen::VectorXd& v) {
  const auto t0 = std::chrono::steady_clock::now();
  const double t_end = (frame + 1) * h_;
  const Eigen::VectorXd x_start = x, v_start = v;
  // Pinned vertices jump to where their script puts them at the end of the step; Newton keeps them
  // there (fixed dofs) and solves for the rest.
  for (const auto& pin : sys_.pins) x.segment<3>(3 * pin.vertex) = pin_position(sys_, pin, t_end);

  StepStart start;
  start.time_end = t_end;
  start.h = h_;
  start.x = &x_start;
  start.v = &v_start;
  sys_.ip.begin_step(start);

  NewtonSettings ns;
  ns.h = h_;
  ns.step_tolerance = settings_.tolerance * sys_.bbox_diagonal;
  ns.max_iterations = settings_.max_newton_iterations;
  ns.projection = settings_.projection;
  NewtonReport report = newton_minimize(sys_.ip, x, ns, hessian_, solver_);
  v = (x - x_start) / h_;

  FrameRecord r = record(frame + 1, x, v);
  r.newton = std::move(report);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace pd
