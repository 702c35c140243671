#pragma once
// Neo-Hookean membrane (in-plane stretching) energy of a thin shell, in the formulation of libshell's
// NeoHookeanMaterial (github.com/evouga/libshell: energy in src/MaterialModel/NeoHookeanMaterial.cpp,
// stretchingEnergy(); density in include/libshell/NeoHookeanMaterial.h; the (E, nu) -> Lamé map in
// example/main.cpp, lameParameters()). Independent implementation with its own derivation.
//
// Per triangle, with rest vertices X0, X1, X2 and deformed vertices x0, x1, x2 (metres):
//   E = [X1 - X0, X2 - X0], e = [x1 - x0, x2 - x0]            (3x2 edge matrices, m)
//   abar = E^T E, a = e^T e                                      (first fundamental forms, m^2)
//   M = abar^{-1} a                                              (dimensionless; = F^T F in a rest frame)
//   W(M) = mu/2 (tr M - 2 - ln det M) + lambda/8 (ln det M)^2    (Pa = J/m^3)
//        = mu/2 (tr M - 2 - 2 ln J) + lambda/2 (ln J)^2,  J = sqrt(det M) = deformed area / rest area
//   energy = thickness * restArea * W                            (J)
// libshell writes the same thing as thickness * sqrt(det abar)/4 * [beta (tr M - 2 - 2 lnJ) + alpha lnJ^2]
// with alpha = lambda, beta = mu; sqrt(det abar) = 2 * restArea makes the two identical.
//
// Lamé constants (libshell's 2D / plane-stress ones, NOT the 3D lambda = E nu / ((1+nu)(1-2nu))):
//   mu     = E / (2 (1 + nu))          (Pa)
//   lambda = E nu / (1 - nu^2)         (Pa)
// With these, the small-strain limit W ~ mu |eps|^2 + lambda/2 (tr eps)^2 is the plane-stress law with
// Young's modulus E and Poisson ratio nu (uniaxial tension: sigma = E eps, lateral strain -nu eps).
// Valid for -1 < nu < 1 (nu = 0.5 is fine in 2D).
//
// Derivatives (closed form, derived in the .cpp): gradient in N, Hessian in N/m.
//
// Degenerate deformed triangles: det a = |e1 x e2|^2 >= 0, and ln det M is undefined at det a = 0
// (collinear or coincident vertices). The energy is +infinity there (and tends to +infinity as a
// triangle collapses, so it acts as a barrier): value() returns +infinity and the line search rejects
// the step. Gradient and Hessian are undefined there and return NaN entries; the solver never asks for
// them at such a point because the energy there is infinite.
// Note: a 3D membrane cannot detect an "inverted" triangle. The first fundamental form does not see
// orientation, so a triangle mirrored through its plane (normal flipped) has det a > 0 and exactly
// the energy of the unmirrored one. Only collapse to zero area is excluded.
#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"
#include "physics/energy_term.h"
#include "physics/gradient_scatter_plan.h"
#include "util/state_key.h"

namespace pd {

// Rest data of one triangle, precomputed once.
struct MembraneRest {
  Eigen::Matrix2d abar;      // rest first fundamental form, m^2 (symmetric)
  Eigen::Matrix2d abar_inv;  // its inverse, 1/m^2
  double area;               // rest area, m^2
};

// Rest data from rest vertices X0, X1, X2 (metres). Throws std::invalid_argument if the rest triangle
// has zero area (or non-finite coordinates): its metric has no inverse.
MembraneRest membrane_rest(const Vec3& X0, const Vec3& X1, const Vec3& X2);

struct MembraneMaterialParams {
  double mu;         // second Lamé constant (shear modulus), Pa
  double lambda;     // 2D (plane-stress) first Lamé constant, Pa
  double thickness;  // shell thickness, m
  // youngs: Young's modulus E in Pa (>= 0); poisson: nu in (-1, 1); thickness in m (> 0).
  // mu = E / (2 (1 + nu)), lambda = E nu / (1 - nu^2). Throws std::invalid_argument out of range.
  static MembraneMaterialParams from(double youngs, double poisson, double thickness);
};

// Element functions. x = (x0, x1, x2) stacked: x[3*v + k] = coordinate k of local vertex v, metres.
// Energy in J; +infinity if the deformed triangle is degenerate (see above).
double neo_hookean_membrane_energy(const Vec<9>& x, const MembraneRest& rest,
                                   const MembraneMaterialParams& params);
// d energy / d x, N, same ordering as x. NaN entries if the deformed triangle is degenerate.
Vec<9> neo_hookean_membrane_gradient(const Vec<9>& x, const MembraneRest& rest,
                                     const MembraneMaterialParams& params);
// d^2 energy / d x^2, N/m, rows/cols ordered as x. Exact (not projected; can be indefinite, e.g. under
// compression). NaN entries if the deformed triangle is degenerate.
Mat<9> neo_hookean_membrane_hessian(const Vec<9>& x, const MembraneRest& rest,
                                    const MembraneMaterialParams& params);

// The membrane energy summed over a set of triangles.
class NeoHookeanMembrane : public EnergyTerm {
 public:
  // faces: global vertex indices (into the stacked x, x[3*i + k]); rest: global rest positions, one row
  // per vertex, metres (rows not used by `faces` are ignored). Rest data is computed here once.
  // Throws std::invalid_argument for an index outside `rest` or a zero-area rest triangle.
  NeoHookeanMembrane(const Faces& faces, const Positions& rest, const MembraneMaterialParams& params);

  std::string name() const override { return "membrane"; }

  // Sum of element energies, J; +infinity as soon as one deformed triangle is degenerate.
  double value(const Eigen::VectorXd& x) const override;
  // grad += d value / d x (N).
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  // Adds each element Hessian (N/m), projected per element with project_hessian<9>.
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                   HessianAssembly& hessian) const override;
  bool may_limit_step() const override { return false; }  // max_step is always 1

  int num_faces() const { return static_cast<int>(faces_.size()); }
  const MembraneMaterialParams& params() const { return params_; }

 private:
  void check_size(const Eigen::VectorXd& x) const;
  Vec<9> gather(const Eigen::VectorXd& x, int face) const;

  std::vector<std::array<int, 3>> faces_;
  std::vector<MembraneRest> rest_;
  MembraneMaterialParams params_;
  int min_dofs_ = 0;  // 3 * (largest vertex index + 1): x must be at least this long
  GradientScatterPlan scatter_;  // the faces' gradient slots per vertex, for the parallel scatter
  // Each face's stress S (1/m^2) at value()'s last x, reused by add_gradient at the same x
  // (util/state_key.h); NaN for a degenerate face.
  mutable std::vector<Eigen::Matrix2d> stress_;
  mutable double total_ = 0.0;  // the faces' energy sum (J) at that x, reused by value() there
  mutable StateKey stress_key_;
};

}  // namespace pd
