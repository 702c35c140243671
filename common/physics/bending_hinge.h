#pragma once
// Discrete-hinge bending (Grinspun et al. 2003, "Discrete Shells"), with the closed-form gradient and
// Hessian of the dihedral angle in the spirit of Tamstorf & Grinspun 2013.
//
// Per interior edge (hinge) e, with rest quantities taken from the rest mesh (so a curved rest shell
// keeps its shape):
//   E_e = k * (theta - theta_bar)^2 * w,   w = |ebar|^2 / (Abar1 + Abar2)     (J)
// theta: signed dihedral angle (rad) of the deformed hinge, theta_bar: the same on the rest mesh,
// |ebar|: rest edge length (m), Abar1, Abar2: rest areas of the two triangles (m^2), so w is
// dimensionless and k (N m = J) is the stiffness.
//
// Vertex order (pd::Hinge): v0, v1 the edge; v2 opposite in the triangle (v0, v1, v2), which runs
// counter-clockwise seen from its normal; v3 opposite in the other triangle (v1, v0, v3). Stacked
// element vector x = (x_v0, x_v1, x_v2, x_v3), 12 entries, metres.
//
// Sign convention: with e = x1 - x0, n1 = e x (x2 - x0), n2 = (x3 - x0) x e (both face normals of a
// consistently oriented mesh),
//   theta = atan2( (n1 x n2) . e/|e| , n1 . n2 )  in (-pi, pi],
// the angle that turns n1 into n2 about e. theta = 0 when flat; theta > 0 when the hinge folds away
// from its normals (convex as seen from the normal side: every hinge of a sphere with outward normals),
// theta < 0 when it folds towards them. atan2 keeps full accuracy near 0 and near +-pi (unlike acos).
// The energy is valid while |theta| < pi: folding through pi means the triangles interpenetrate,
// which contact must prevent; across that branch cut theta jumps by 2 pi.
//
// Derivatives. With g2 = dtheta/dx2 = -|e| n1/|n1|^2 (the unit normal over the height of x2) and
// g3 = dtheta/dx3 = -|e| n2/|n2|^2, translation and rotation invariance fix the edge vertices:
//   g1 = -(a1 g2 + a2 g3), g0 = -((1 - a1) g2 + (1 - a2) g3),   a_i = (x_{i+1} - x0).e / |e|^2,
// the fractions along the edge at which the feet of x2 and x3 lie. The Hessian is obtained in closed
// form by differentiating these expressions in the relative coordinates (e, x2 - x0, x3 - x0); the
// derivation is in bending_hinge.cpp.
//
// Degenerate deformed triangles: when either wing has (near-)zero area (|n_i| <= 1e-12 |e|^2, which
// includes a zero-length edge) the normal, and so the angle, is undefined. dihedral_angle then
// returns 0, and its gradient and Hessian are zero, so the element adds a finite energy
// k w theta_bar^2 but no force and no stiffness until the triangle opens up again (membrane forces
// do that). Nothing returns NaN.
//
// Calibration of k against Kirchhoff plate theory. A plate with bending rigidity
// D = E t^3 / (12 (1 - nu^2)) bent into a cylinder of radius R stores (D/2) / R^2 per unit area.
// Locally the surface is z = 1/2 X^T S X (S = c c^T / R, c the curvature direction) and each
// triangle is the linear interpolant of z over its corners, so to leading order theta is the jump of
// the interpolant's slope across the edge. For the two triangles (e0, e1, p), (e0, e1, q) of a hinge
// of a regular mesh (a parallelogram, p + q = e0 + e1) the second difference of the quadratic gives
//   theta = |(p - e0)^T S (q - e0)| * |e| / (2 A).
// (The plausible shortcut "theta = normal curvature across the edge * centroid distance" is wrong
// by a factor that depends on the edge; it would give k = D.) On an equilateral mesh of edge a,
// p - e0 and q - e0 run along the two other edge directions j, m, so theta = (2 a / (sqrt(3) R))
// |cos phi_j cos phi_m| with phi_i the angle between c and edge direction i, and w = 2 / sqrt(3).
// With x_i = cos^2 phi_i, sum x_i = 3/2 and sum x_i^2 = 9/8 for any orientation, hence
// sum_{j<m} x_j x_m = 9/16. Each triangle owns half an edge of each direction:
//   E = (1/2) k (2/sqrt(3)) (4 a^2 / (3 R^2)) (9/16) = k (sqrt(3)/4) a^2 / R^2,
// against the continuum (D/2) (sqrt(3)/4) a^2 / R^2. Hence
//   k = D / 2  (hinge_stiffness), for every bending direction of an equilateral mesh.
// Tests (bulk of closed tubes, k = D/2): 0.99899 / 0.99975 / 0.99994 of the continuum with 30 / 60 /
// 120 cells around when the rows run around the tube (chord error, O((a/R)^2)), 1.000000 with the
// rows along the axis. Doubly curved, the same computation gives the density
// k [(kappa1 + kappa2)^2 - (8/3) kappa1 kappa2] (principal curvatures): the plate energy with
// nu = -1/3 in its Gaussian-curvature term, which matters at free boundaries: a strip with free
// long edges has rigidity 8/9 D and a clamped cantilever sags 1.08-1.11x plate theory.
//
// Right-triangle grids (squares of side h split by the diagonal (1,1)) are anisotropic. Bent along a
// grid line only the edges parallel to the axis fold (theta = h/R, w = 1, one per h^2; the other
// hinges have their four corners on two rulings of the cylinder and stay flat): E = k / R^2 per unit
// area, exactly the continuum value with k = D/2 (test: 1.000000). Bent with the axis across the
// split diagonals, horizontal, vertical and diagonal edges all fold and the grid is 3x too stiff
// (test: 2.998); with the axis along the diagonals only those fold and it is exact (test: 1.000000).
// In general its energy density is k [(S11 + S12)^2 + (S22 + S12)^2 + 4 S12^2] (S in grid axes),
// against (D/2) (S11 + S22)^2 for a cylinder. That density drops to 0.8 k S11^2 at
// S12 = -S11/5, S22 = S11/5, so where free edges let it (strips, cantilevers) a grid with uniform or
// checkerboard diagonals relaxes into twist and transverse curvature and sags up to 1.25x plate
// theory, without converging under refinement. Diagonals alternating row by row
// (GridDiagonals::Rows) suppress that relaxation: a clamped strip then sags within 0.1% of plate
// theory (tests/progressive/level_stepper_test.cpp).
// Prefer near-equilateral meshes for direction-independent bending of surfaces, row-alternating
// grids for strips bent along the grid.
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"
#include "geometry/topology.h"
#include "physics/energy_term.h"
#include "physics/gradient_scatter_plan.h"
#include "util/state_key.h"

namespace pd {

// Rest data of one hinge.
struct HingeRest {
  double theta_bar;  // rest dihedral angle, rad
  double weight;     // |ebar|^2 / (Abar1 + Abar2), dimensionless
};

// X: rest positions (x_v0, x_v1, x_v2, x_v3) stacked, m. Meaningful only for non-degenerate rest
// triangles (validate_mesh guarantees them; HingeBending rejects the others).
HingeRest hinge_rest(const Vec<12>& X);

// Signed dihedral angle (rad) and its derivatives with respect to x (rad/m, rad/m^2).
double dihedral_angle(const Vec<12>& x);
Vec<12> dihedral_angle_gradient(const Vec<12>& x);
Mat<12> dihedral_angle_hessian(const Vec<12>& x);

// Element energy (J), gradient (N) and exact, unprojected Hessian (N/m), stiffness k in N m.
double hinge_bending_energy(const Vec<12>& x, const HingeRest& rest, double k);
Vec<12> hinge_bending_gradient(const Vec<12>& x, const HingeRest& rest, double k);
Mat<12> hinge_bending_hessian(const Vec<12>& x, const HingeRest& rest, double k);

// Hinge stiffness k (N m) from the plate bending rigidity D (N m): k = D / 2 (derivation above).
double hinge_stiffness(double bending_rigidity);

// The bending energy of a set of hinges (one per interior edge of every simulated shell).
class HingeBending : public EnergyTerm {
 public:
  // hinges: global vertex indices (pd::Hinge order); rest: global rest positions (n, 3), m;
  // bending_rigidity: D in N m. Throws std::invalid_argument for an index outside rest or a hinge
  // whose rest triangles have zero area (validate_mesh rejects such meshes earlier).
  HingeBending(const std::vector<Hinge>& hinges, const Positions& rest, double bending_rigidity);

  std::string name() const override { return "bending"; }

  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  // Each 12 x 12 hinge block is projected with project_hessian<12> before assembly.
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                   HessianAssembly& hessian) const override;
  bool may_limit_step() const override { return false; }  // max_step is always 1

  double stiffness() const { return k_; }
  const std::vector<HingeRest>& rest() const { return rest_; }

 private:
  Vec<12> gather(const Eigen::VectorXd& x, const Hinge& h) const;

  std::vector<Hinge> hinges_;
  std::vector<HingeRest> rest_;  // one per hinge, same order
  double k_;                     // N m
  GradientScatterPlan scatter_;  // the hinges' gradient slots per vertex, for the parallel scatter
  // The angles (rad) of value()'s last x, reused by add_gradient at the same x (util/state_key.h),
  // and their energy sum, reused by value() there.
  mutable std::vector<double> angles_;
  mutable double total_ = 0.0;  // their energy sum (J)
  mutable StateKey angles_key_;
};

}  // namespace pd
