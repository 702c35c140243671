#pragma once
// What IPC's lagged friction needs from one contact, independent of the contact's geometry (a
// point-triangle or edge-edge pair of the mesh barrier, a vertex on the analytic ground, ...).
//
// Lagging (IPC, Li et al. 2020, Sec. 5): at the start of a time step, each active contact fixes its
// normal force magnitude lambda, its tangent basis T and the barycentric weights w of its closest
// points. During the step, the contact's relative tangential displacement is
//   u(x) = T^T sum_k w_k (x_k - x_k^t)      (m, 2-vector; x^t = positions at the start of the step)
// with the weights signed so that a rigid translation of the whole stencil gives u = 0
// (sum_k w_k = 0): e.g. point-triangle w = (1, -b0, -b1, -b2), edge-edge
// w = (1 - a, a, -(1 - b), -b), vertex-on-ground w = (1).
#include <array>
#include <vector>

#include <Eigen/Core>

namespace pd {

struct FrictionContact {
  std::array<int, 4> vertices{{-1, -1, -1, -1}};  // global vertex indices; the first `count` are used
  int count = 0;                                  // stencil size, 1..4
  std::array<double, 4> weights{{0, 0, 0, 0}};    // w_k, dimensionless (see above)
  Eigen::Matrix<double, 3, 2> basis = Eigen::Matrix<double, 3, 2>::Zero();  // T: orthonormal columns
                                                                            // spanning the tangent plane
  double normal_force = 0.0;  // lambda >= 0, N: kappa * |d barrier / d distance| at the step start
                              // (times the edge-edge mollifier, so it is the force the pair exerts)
  double mu = 0.0;            // Coulomb coefficient of this contact's pair of objects, >= 0
};

// Something that can report its active contacts for friction (the mesh barrier, the ground).
class FrictionSource {
 public:
  virtual ~FrictionSource() = default;
  // Appends the contacts active at positions x (stacked, m) whose friction coefficient is > 0.
  virtual void friction_contacts(const Eigen::VectorXd& x, std::vector<FrictionContact>& out) const = 0;
};

}  // namespace pd
