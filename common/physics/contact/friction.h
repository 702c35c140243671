#pragma once
// IPC's lagged, smoothed Coulomb friction as one term of the incremental potential (Li et al. 2020,
// "Incremental Potential Contact: Intersection- and Inversion-free, Large-Deformation Dynamics",
// Sec. 5 "Friction"; the same construction is used by codimensional IPC).
//
// Lagging. Coulomb friction is not the gradient of any potential: its magnitude mu * lambda depends
// on the normal force and its direction on the tangent plane, both of which follow x. IPC freezes,
// at the start of each time step (begin_step), per active contact (friction_contact.h):
//   lambda  normal force magnitude, N
//   T       3x2 orthonormal tangent basis
//   w_k     signed barycentric weights of the closest points (sum_k w_k = 0)
// and the start-of-step positions x^t. With these fixed, the relative tangential displacement of a
// contact over the step
//   u(x) = T^T sum_k w_k (x_k - x_k^t)                  (m, 2-vector)
// is linear in x, and the friction force is minus the gradient of the dissipative potential below.
// The Newton iterations of one step therefore minimise a true function of x; the lag changes the
// friction force by O(h) within a step (IPC re-lags it once per step, as here; IPC's optional extra
// "lagging iterations" are not done).
//
// Smoothing. The static/dynamic transition |u| -> mu lambda u/|u| is discontinuous at u = 0. IPC
// replaces it by a C^1 force (C^2 energy) that ramps up over tangential speeds below eps_v, i.e.
// over displacements below eps_u = eps_v * h (m). With y = |u| (m):
//   f0(y) = -y^3 / (3 eps_u^2) + y^2 / eps_u + eps_u / 3     for y < eps_u      (m)
//         =  y                                               for y >= eps_u
//   f1(y) = f0'(y) = -y^2 / eps_u^2 + 2 y / eps_u  (y < eps_u),  1 (y >= eps_u)   (dimensionless)
// f0 and f1 are continuous at eps_u (f0 = eps_u, f1 = 1, f0'' = 0 on both sides).
// Per contact the energy is
//   D(x) = mu * lambda * f0(|u(x)|)                           (J = N * m)
// and the term is the sum over contacts. Derivatives (chain rule through the linear map u(x)):
//   dD/du   = mu lambda f1(y)/y u                               (N)
//   d2D/du2 = mu lambda [ f1(y)/y I + (f1/y)'(y) / y * u u^T ]  (N/m), 2x2
//   d/dx_k  = w_k T dD/du;  d2D/dx_k dx_l = w_k w_l T (d2D/du2) T^T
// with f1(y)/y -> 2/eps_u as y -> 0 and (f1/y)'/y * u u^T -> 0 (no division by |u| at u = 0).
// The constant eps_u/3 of f0 makes D continuous; it has no gradient.
//
// Variables: the stacked positions x of the whole scene (x[3i + k], global vertex indices), metres.
// A contact's stencil (its `count` vertices, 1..4) is ordered as FrictionContact::vertices; its
// element gradient and Hessian are in that vertex order, xyz per vertex.
#include <string>
#include <vector>

#include <Eigen/Core>

#include "physics/contact/friction_contact.h"
#include "physics/energy_term.h"

namespace pd {

// The smoothing functions above; y = |u| >= 0 and eps_u > 0 in metres.
double friction_f0(double y, double eps_u);         // m
double friction_f1(double y, double eps_u);         // dimensionless
double friction_f1_over_y(double y, double eps_u);  // f1(y)/y, 1/m; 2/eps_u at y = 0

class FrictionTerm : public EnergyTerm {
 public:
  // eps_v: tangential speed (m/s) below which friction is smoothed (IPC's epsilon_v); must be > 0
  // and finite, else std::invalid_argument.
  explicit FrictionTerm(double eps_v);

  // Adds a source of contacts (the mesh barrier, the ground). Non-owning: the source must outlive
  // this term. Null throws std::invalid_argument.
  void add_source(const FrictionSource* source);

  std::string name() const override { return "friction"; }

  // Value (J), gradient (N) and Hessian (N/m) of sum_c D_c at x, with the contacts, bases, normal
  // forces and x^t lagged by the last begin_step(). Before the first begin_step there are no
  // contacts and all three are zero.
  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                   HessianAssembly& hessian) const override;

  // Lags the step: x^t = *step.x, h = step.h (> 0, and step.x non-null, else
  // std::invalid_argument), and the contacts every source reports at x^t.
  void begin_step(const StepStart& step) override;

  // The contacts lagged by the last begin_step (for statistics and tests).
  const std::vector<FrictionContact>& contacts() const { return contacts_; }
  double eps_v() const { return eps_v_; }
  // eps_u = eps_v * h of the current step, m (0 before the first begin_step).
  double eps_u() const { return eps_v_ * h_; }

  // The largest change, over the lagged contacts, that a displacement p (stacked like x, m) makes
  // to a contact's relative tangential displacement: max_c |T^T sum_k w_k p_k|, m (0 without
  // contacts). Newton's friction stopping test (solver/newton.h) divides it by h.
  double max_tangential_step(const Eigen::VectorXd& p) const;

 private:
  // u of contact c at x (m).
  Eigen::Vector2d tangential_displacement(const FrictionContact& c, const Eigen::VectorXd& x) const;
  template <int N>
  void add_contact_hessian(const FrictionContact& c, const Eigen::Matrix2d& H_u,
                           HessianAssembly& hessian) const;

  double eps_v_;
  double h_ = 0.0;                      // s
  Eigen::VectorXd x_start_;             // x^t, m
  std::vector<const FrictionSource*> sources_;
  std::vector<FrictionContact> contacts_;
};

}  // namespace pd
