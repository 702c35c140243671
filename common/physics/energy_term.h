#pragma once
// One term of the incremental potential (inertia, membrane, bending, gravity, wind, pressure and,
// later, contact barriers and friction). The time step minimises the sum of the terms a scene
// declares; a term that the scene does not declare is never constructed and costs nothing.
//
// Every member takes the stacked positions x (size 3n, metres, x[3i+k] = coordinate k of vertex i,
// vertex indices global over all objects of the scene).
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "physics/hessian_assembly.h"
#include "physics/hessian_projection.h"

namespace pd {

// What a term may lag over one time step (wind drag coefficients now, friction bases later).
struct StepStart {
  double time_end = 0.0;                 // time at the end of the step being solved, s
  double h = 0.0;                        // time step, s
  const Eigen::VectorXd* x = nullptr;    // positions at the start of the step, m
  const Eigen::VectorXd* v = nullptr;    // velocities at the start of the step, m/s
};

class EnergyTerm {
 public:
  virtual ~EnergyTerm() = default;

  // Short name used as the stats key in the frame file ("membrane", "bending", "gravity", ...).
  virtual std::string name() const = 0;

  virtual double value(const Eigen::VectorXd& x) const = 0;
  // The value split by stats key: a term that sums several energies (the prolonged shell terms of
  // a coarse level) reports each under its own name; every other term is one (name(), value(x)).
  virtual std::vector<std::pair<std::string, double>> named_values(const Eigen::VectorXd& x) const {
    return {{name(), value(x)}};
  }
  // grad += d value / d x.
  virtual void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const = 0;
  // The same at a point x within a tiny distance of `reference` (a finite-difference neighbour:
  // IncrementalPotential::hessian_product), for a term that can reuse work done for `reference`
  // without changing the result beyond what the difference resolves: the contact barrier keeps
  // reference's broad-phase pairs. Default: add_gradient(x, grad).
  virtual void add_gradient_near(const Eigen::VectorXd& /*reference*/, const Eigen::VectorXd& x,
                                 Eigen::VectorXd& grad) const {
    add_gradient(x, grad);
  }
  // Adds the Hessian, element by element, each element projected as `projection` says.
  virtual void add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                           HessianAssembly& hessian) const = 0;

  // Called once before the Newton iterations of each step.
  virtual void begin_step(const StepStart& /*step*/) {}

  // A term whose Hessian is a cheap stand-in for a step's first assemblies and a costlier model
  // after them (the coarse-first prolonged term): true when its next add_hessian would leave the
  // stand-in. The solver may then probe the stand-in and keep it for the rest of the step
  // (keep_stand_in_hessian(true)), or let it go at the next assembly (false, also after a keep).
  // Both are const because they steer per-step bookkeeping, like the lagged counts, not the
  // energy. Default: no stand-in phase.
  virtual bool stand_in_hessian_ends() const { return false; }
  virtual void keep_stand_in_hessian(bool /*keep*/) const {}

  // Largest alpha in (0, 1] such that x + alpha * dx stays admissible for this term (contact CCD,
  // strain limits, inverted volumes). Terms without such a constraint return 1.
  virtual double max_step(const Eigen::VectorXd& /*x*/, const Eigen::VectorXd& /*dx*/) const { return 1.0; }
  // False only for a term whose max_step is 1 whatever x and dx are, so a wrapper that must first
  // map dx elsewhere (the prolonged terms' J dx) can skip that work. True is always safe.
  virtual bool may_limit_step() const { return true; }
};

}  // namespace pd
