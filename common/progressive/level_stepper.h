#pragma once
// Implicit-Euler time stepping of one level (PD eq. 3): each step minimises
//   1/(2h^2) ||x - (x_t + h v_t)||_M^2 + E(x)
// with projected Newton, and reports what each frame cost and where its energy went.
#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "progressive/scene_system.h"
#include "solver/cholmod_solver.h"
#include "solver/newton.h"

namespace pd {

// A step ended in a state no shot can reach: a non-finite position or velocity, a vertex beyond
// kDivergedDistance from the origin or faster than kDivergedSpeed. what() names the frame, the
// object, the vertex and the value; the step's frame is not stored (the run stops with the frames
// before it). The bounds sit 100x beyond the scene format's own limits (docs/scene-format.md: a
// 20 km scene, speeds up to 1000 m/s), so no scene the format accepts reaches them by its motion.
class StateDiverged : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
constexpr double kDivergedDistance = 1e6;  // m, any coordinate
constexpr double kDivergedSpeed = 1e5;     // m/s, any vertex

// Statistics of one stored frame; frame 0 carries the initial state's energies and zero iterations.
struct FrameRecord {
  int frame = 0;
  double time = 0.0;                   // s
  Eigen::VectorXd x;                   // stacked positions, m
  NewtonReport newton;                 // empty for frame 0
  double seconds = 0.0;                // wall time of the step
  double kinetic_energy = 0.0;         // J
  std::vector<std::pair<std::string, double>> energies;  // potential terms (not inertia), J
  std::vector<std::pair<std::string, double>> contact;   // ContactControl::stats at x
  int pin_rounds = 0;                  // solves that moved blocked pins (0 = none, -1 = blocked)
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> center_of_mass;
};

// What a progressive step changes from a plain implicit Euler step (PD Algorithm 1).
struct StepInput {
  // The inertia target xhat (m, 3n): the momentum prolonged from the level below (PD eq. 5).
  // Null: the level's own x + h v.
  const Eigen::VectorXd* inertia_target = nullptr;
  // Newton's first iterate (m, 3n; must be intersection-free and within the strain limits): a
  // vertical warm start (safe upsampling of the level below). Null: x, the horizontal warm start.
  const Eigen::VectorXd* warm_start = nullptr;
};

class LevelStepper {
 public:
  LevelStepper(SceneSystem& system, const SolverSettings& settings, double h);

  // Frame 0: the initial state.
  FrameRecord initial_frame() const;
  // Advances from (x, v) at frame `frame` to frame + 1, updating x and v (v = (x_new - x) / h).
  // Throws StateDiverged when the new state is out of bounds (above).
  FrameRecord step(int frame, Eigen::VectorXd& x, Eigen::VectorXd& v, const StepInput& input = {});

 private:
  FrameRecord record(int frame, const Eigen::VectorXd& x, const Eigen::VectorXd& v) const;
  void check_state(int frame, const Eigen::VectorXd& x, const Eigen::VectorXd& v) const;
  // Moves the pinned vertices to where their scripts put them at the end of the step without ever
  // passing through contact; returns the number of augmented-Lagrangian solves it needed (0 when
  // the straight move was collision-free), or -1 if the pins could not reach their targets.
  int move_pins(double t_end, Eigen::VectorXd& x, const NewtonSettings& ns, NewtonReport& report);

  SceneSystem& sys_;
  SolverSettings settings_;
  double h_;
  HessianAssembly hessian_;
  CholmodSolver solver_;
};

}  // namespace pd
