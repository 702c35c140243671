#pragma once
// Contact with an analytic ground half-space, as one term of the incremental potential:
//   E_g(x) = kappa * sum_{v in vertices} b(d_v(x)^2; dhat, offset),   d_v = n . x_v - height   (m)
// with b the offset log barrier of barrier.h, the same function and the same kappa (J/m^4) as the
// mesh-mesh contact term (BarrierPotential), so one adaptive stiffness serves both.
//
// The ground is the plane {p : n . p = height} with unit normal n; the side n . p > height is free
// space. d_v is the signed distance of vertex v from the plane, and d_v^2 is its squared
// point-plane distance while d_v > 0. A vertex is
//   active      when its gap d_v - offset is in (0, dhat): energy > 0;
//   inactive    when the gap is >= dhat: no energy, no derivatives;
//   infeasible  when the gap is <= 0 (d_v <= offset, including every vertex below the plane, whose
//               d_v^2 alone would look far away): value +inf, gradient and Hessian non-finite.
// max_step keeps every line-search iterate feasible, so the solver never evaluates there; a scene
// whose start state has infeasible vertices is reported by vertices_below() before simulating.
//
// Why analytic rather than a ground mesh in BarrierPotential: a plane needs no broad phase, no
// triangle discretisation (a coarse ground mesh has edges the cloth can catch on), and its exact
// Hessian is a rank-one 3x3 block per vertex.
//
// Variables: stacked positions x (size 3n, x[3i + k] = coordinate k of vertex i, metres); vertex
// ids are global over the scene's objects.
#include <vector>

#include "geometry/mesh.h"
#include "physics/contact/barrier_potential.h"
#include "physics/contact/friction_contact.h"
#include "physics/energy_term.h"

namespace pd {

class GroundBarrier : public EnergyTerm, public FrictionSource {
 public:
  // vertices: global ids of the vertices that collide with the ground (sorted and de-duplicated
  // here, so a vertex listed twice counts once). normal: any non-zero finite vector, normalised
  // here. height: n . p of the plane's points, m (with the normalised n). settings: dhat > 0,
  // offset >= 0, kappa >= 0, ccd_ratio (clamped to [0.01, 0.99] as in ACCD). mu >= 0: Coulomb
  // coefficient between these vertices and the ground. Throws std::invalid_argument otherwise (and
  // for a negative vertex id or a non-finite height).
  GroundBarrier(std::vector<int> vertices, const Vec3& normal, double height,
                const ContactSettings& settings, double mu);

  std::string name() const override { return "ground"; }
  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  // Exact per-vertex Hessian kappa (b''(d^2) 4 d^2 + 2 b'(d^2)) n n^T (3x3, positive semi-definite
  // on the active range), projected per vertex as asked.
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                   HessianAssembly& hessian) const override;
  // Largest alpha in [0, 1] such that every vertex keeps at least (1 - ccd_ratio) of its current gap
  // g = d - offset on x -> x + alpha dx (exact for a plane: the gap is linear in alpha, so a vertex
  // approaching at rate r = -n . dx > 0 limits alpha to ccd_ratio * g / r). 1 if no vertex approaches;
  // 0 if some vertex already has g <= 0 or x, dx are not finite (as ACCD: the caller must resolve
  // the overlap by other means).
  double max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const override;

  // FrictionSource: one contact per active vertex (gap in (0, dhat)), if mu > 0: vertices {v},
  // count 1, weights {1}, basis = two fixed orthonormal vectors perpendicular to n, normal force
  // lambda = -kappa b'(d^2) 2 d (N, >= 0: the magnitude of dE_g/dd). Infeasible vertices are skipped.
  void friction_contacts(const Eigen::VectorXd& x, std::vector<FrictionContact>& out) const override;

  // Statistics at x in the mesh barrier's struct, so that callers can merge the two: a vertex
  // against the plane is a point contact, so active_point_triangle counts the vertices with gap
  // d - offset in (0, dhat), and active_edge_edge is always 0. min_gap is the min over all the
  // ground's vertices (not only active ones) of d - offset, m: +inf if it has none, <= 0 if some
  // vertex is infeasible.
  ContactStats stats(const Eigen::VectorXd& x) const;

  // The energy's gradient without kappa (m^3), for initial_barrier_stiffness.
  Eigen::VectorXd unit_stiffness_gradient(const Eigen::VectorXd& x) const;

  // Vertices with d <= offset (at or within the offset of the plane, or below it) at x, ascending:
  // a start state with any of them cannot be simulated (the barrier is infinite there).
  std::vector<int> vertices_below(const Eigen::VectorXd& x) const;

  const ContactSettings& settings() const { return settings_; }
  void set_kappa(double kappa) { settings_.kappa = kappa; }
  const std::vector<int>& vertices() const { return vertices_; }
  const Vec3& normal() const { return normal_; }   // unit
  double height() const { return height_; }        // m
  double mu() const { return mu_; }
  // The tangent basis given to friction: orthonormal columns, both perpendicular to normal().
  const Eigen::Matrix<double, 3, 2>& tangent_basis() const { return tangents_; }

 private:
  // Signed distance d = n . x_v - height of vertex v, m. Throws std::out_of_range if x has no
  // vertex v.
  double signed_distance(const Eigen::VectorXd& x, int v) const;
  // Calls f(v, d) for every vertex with d < offset + dhat (active or infeasible).
  template <class F>
  void for_each_near_vertex(const Eigen::VectorXd& x, F&& f) const;

  std::vector<int> vertices_;
  Vec3 normal_;
  double height_;
  ContactSettings settings_;
  double mu_;
  Eigen::Matrix<double, 3, 2> tangents_;
};

}  // namespace pd
