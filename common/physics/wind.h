#pragma once
// Wind: drag on each triangle from the normal component of its velocity relative to the air.
//
// Air velocity (m/s), evaluated at the end of the step being solved:
//   w(t) = air_velocity * (1 + gust_amplitude * sin(2 pi gust_frequency t)).
// Quadratic drag on triangle f (normal n, area A, centroid velocity v_c, u = n . (v_c - w), m/s):
//   force = -1/2 rho C_d A |u| u n   (N), split equally between its three vertices.
//
// Quadratic drag LINEARISED ABOUT THE START OF THE STEP. Exact quadratic drag is a velocity-dependent,
// non-conservative force: with n and A following x, its Jacobian is not symmetric, so it is not the
// gradient of any function of x and implicit Euler with it is a root-finding problem, not a
// minimisation (no energy for the line search, no symmetric Hessian for Cholesky). Lagging n, A and
// |u| from the start of the step (begin_step) gives, per triangle, the constant coefficient
//   c = 1/2 rho C_d A max(|u_start|, kMinRelativeSpeed)   (kg/s),
// and, with the implicit-Euler velocity v = (x - x_start) / h, the force -c (n . (v_c(x) - w)) n is
// linear in x and is minus the gradient of the convex quadratic
//   D(x) = h sum_f c_f / 2 (n_f . (v_c(x) - w))^2   (J).
// So the incremental potential stays a minimisation with a PSD drag Hessian. The lag changes the
// force by O(h) within a step, the same order as implicit Euler's own error.
// The floor kMinRelativeSpeed keeps a little linear drag on triangles that start the step moving
// edge-on through the air, so that drag is not switched off for a whole step by the lag alone.
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"
#include "physics/energy_term.h"
#include "scene/scene.h"

namespace pd {

class WindTerm : public EnergyTerm {
 public:
  // m/s. Below this normal relative speed the lagged coefficient uses this speed instead.
  static constexpr double kMinRelativeSpeed = 1e-3;

  // faces: triangles of every object the wind acts on, with global (scene-wide) vertex indices.
  WindTerm(const Faces& faces, const Wind& params);

  std::string name() const override { return "wind"; }

  // All three require begin_step() to have been called (std::logic_error otherwise): the potential
  // is defined by the lagged start-of-step quantities.
  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                   HessianAssembly& hessian) const override;

  // Computes the lagged normals, coefficients and air velocity for the step ending at step.time_end.
  // Throws std::invalid_argument for h <= 0, missing start state, or positions that do not hold
  // every face's vertices.
  void begin_step(const StepStart& step) override;
  // The frame statistics' value: value(x) once a step has begun; 0 before the first step (frame 0
  // of a run), where no drag potential is defined yet (it was NaN there until 2026-12-07).
  std::vector<std::pair<std::string, double>> named_values(const Eigen::VectorXd& x) const override;

  // w(t), m/s.
  Vec3 air_velocity(double t) const;

 private:
  // Per triangle, fixed over a step: u(x) = n . (x0 + x1 + x2) / (3 h) + offset is the normal
  // relative velocity at the end of the step (m/s).
  struct Lagged {
    Vec3 n = Vec3::Zero();  // unit normal at the start of the step
    double c = 0.0;         // drag coefficient, kg/s
    double offset = 0.0;    // -n . (x_start centroid) / h - n . w, m/s
  };
  double normal_speed(const Eigen::VectorXd& x, int f) const;
  // std::logic_error before the first begin_step, std::invalid_argument for an x short of the faces
  void check_state(const Eigen::VectorXd& x) const;

  Faces faces_;
  Wind params_;
  std::vector<Lagged> lagged_;  // one per face, sized once in the constructor
  Eigen::Index min_dofs_;       // 3 (largest vertex id of the faces + 1)
  double h_ = 0.0;              // s
};

}  // namespace pd
