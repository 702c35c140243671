#pragma once
// Midedge-fit bending: a per-face shape operator in the spirit of the midedge formulations (Grinspun
// et al. 2006, "Computing discrete shape operators on general meshes"; libshell's
// MidedgeAverageFormulation), with the Kirchhoff plate's St.Venant-Kirchhoff bending density, whose
// midedge slopes come from a least-squares quadratic fit instead of the average of the two face
// normals, written in the dihedral angles of the surrounding hinges. It meets plate theory on any
// triangulation (the discrete hinge does not: see bending_hinge.h and the measurements below).
// Independent implementation; only the idea of a per-face midedge shape operator is libshell's.
//
// Energy per face f (J):
//   E_f = 1/2 (beta - beta_bar)^T C (beta - beta_bar),
//   beta = (b_11, b_22, b_12): the face's second fundamental form (1/m) in an orthonormal frame of
//   its rest plane (so the rest metric is the identity and M = b - b_bar), beta_bar the same on the
//   rest mesh (curved rest shells keep their shape at zero energy),
//   C = A D [[1, nu, 0], [nu, 1, 0], [0, 0, 2 (1 - nu)]] (A rest area, m^2; D = E t^3 / (12 (1 -
//   nu^2)), N m), i.e. E_f = A (D/2) [nu tr(M)^2 + (1 - nu) tr(M^2)], the plate density; on faces
//   with free boundary edges C is condensed (below).
//
// The shape operator, for small slopes. Green's formula over the triangle, int_T grad grad h dA =
// sum_e l_e g_e n_e^T (n_e outward unit edge normal, l_e edge length, g_e the gradient at the edge
// midpoint: exact for a quadratic height by the midpoint rule), with h the height over the face's
// plane. The face's own vertices have h = 0, so only each edge's normal slope s_e = g_e . n_e enters:
//   B = (1/A) sum_e l_e s_e n_e n_e^T.
// For an interior edge, s_e is the normal derivative at the edge midpoint of the least-squares
// quadratic through the edge's two triangles, their opposite vertices and the two further opposite
// vertices of the neighbour (up to 8 points, all unfolded isometrically into the face's rest plane):
//   s_e = sum_k w_ek h_k, weights from the rest geometry.
// Since the fit reproduces quadratics, B is exact for every quadratic height field on any mesh, and
// as both faces of an edge use the same fit for it, the face Hessians add up to a boundary integral:
// no oscillating height field can fake a mean curvature. The first property fails for the midedge
// average (its slope, the mean of the two face slopes, is exact only where the two triangles form a
// parallelogram), the second for a per-face 6-point quadratic fit; each costs up to 40 % on the
// meshes below. Near boundaries a fit may have fewer than 6 points, or points on a conic (two grid
// rows); the least-squares solution of least norm is used when the slope does not depend on its
// null space, else the edge falls back to the midedge average.
//
// Large deformations: heights from hinge angles. Each stencil vertex after the face's own hangs on
// one hinge (the edge it was unfolded across); folding the sheet rigidly about a hinge's line by its
// dihedral angle theta (physics/bending_hinge.h: positive away from the normals) lowers every point
// beyond it by its distance from that line times theta. To first order the heights are therefore
// linear in the nine hinge angles of the stencil, and
//   beta = sum_j c_j theta_j    (c_j in 1/m per rad, fixed at rest; beta_bar from the rest angles).
// Measuring the heights along the deformed face normal instead, h_k = n . (x_k - x0), gives the same
// small-slope energy, but a fold's h = d sin(theta) makes a crease's energy peak at 90 degrees and
// vanish when folded flat (an 8 x 8 sheet folded about a grid line: 3.1 J at 90 degrees, 0.001 J at
// 179); with the angles it grows like the hinge's (7.7 J at 90, 30.5 J at 179; the hinge: 9.9, 39.0).
// Rigid motions change no angle; curved rest shapes keep their shape at zero energy.
//
// Free boundaries. A boundary edge has no neighbour to fit; its slope s_e is left free, i.e. the
// face's energy is minimised over it: C becomes the Schur complement
//   C' = C - C G (G^T C G)^{-1} G^T C,  G's columns (l_e / A) (n_e n_e^T as beta),
// which is constant, so no extra unknowns appear. This is the free edge's natural condition (zero
// bending moment across it). Clamped edges are made by pinning two rows of vertices, as for hinges.
//
// Stencil (vertex order of the 36-entry element vectors): the face's vertices v0, v1, v2 (its
// order), then the opposite vertex across each edge that has one and the neighbours' further
// opposite vertices, in order of discovery; up to 12, unused slots repeat v0 and take no part.
// The term computes each hinge's angle, gradient and Hessian once per call and combines them per
// face; the element functions below compute one face alone (tests).
//
// Calibration against Kirchhoff plate theory: none needed, C is the plate's own. Measured by
// tests/physics/bending_plate_theory_test.cpp (static solves, deflection / plate theory), on the
// meshes rows, checkerboard, uniform, equilateral, Delaunay:
//   clamped strip, nu = 0:             0.9998 0.9996 0.9993 0.9939 0.9996
//     (hinge:                          1.0007 1.2136 1.2102 1.1080 1.1205)
//   simply supported plate, nu = 0.3:  1.0035 1.0023 1.0039 1.0035 1.0025
//     (hinge:                          0.5737 0.7458 0.5592 0.9916 0.7217)
//   clamped plate, nu = 0.3:           1.0039 1.0027 0.9997 1.0027 1.0034
//     (hinge:                          0.7417 0.9039 0.7339 0.9879 0.8624)
// Candidates measured on the way (same cases and meshes, linearised): the midedge average with
// boundary edge normal = face normal (libshell's MidedgeAverageFormulation) 0.96 - 1.00 (strip),
// 0.60 - 0.97 (simply supported), 0.77 - 1.02 (clamped); the same with free boundary slopes 0.96 -
// 1.00, 0.63 - 1.00, 0.77 - 1.02; a per-face 6-point quadratic fit 0.99 - 1.41, 1.00 - 1.74,
// 1.00 - 1.56 (soft checkerboard modes). The midedge average is exact where every hinge is a
// parallelogram (uniform grids, equilateral meshes) and too stiff elsewhere.
//
// Degenerate deformed triangles: a hinge with a (near-)zero-area wing has angle 0 and no gradient or
// Hessian (physics/bending_hinge.h), so a collapsed face keeps a finite energy and nothing is NaN.
#include <array>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"
#include "geometry/topology.h"
#include "physics/energy_term.h"
#include "physics/gradient_scatter_plan.h"

namespace pd {

constexpr int kMidedgeFitStencil = 12;  // stencil vertices per face, at most

// Rest data of one face.
struct MidedgeFitRest {
  int count = 3;   // stencil vertices in use (3..12)
  int hinges = 0;  // count - 3: one per stencil vertex after the face's own
  // Hinge j (pd::Hinge order, as stencil slots): the edge that vertex j + 3 hangs on, the near
  // triangle's third vertex, the vertex j + 3.
  std::array<std::array<int, 4>, kMidedgeFitStencil - 3> hinge{};
  // beta = sum_j c.col(j) theta_j (1/m per rad).
  Eigen::Matrix<double, 3, kMidedgeFitStencil - 3> c = Eigen::Matrix<double, 3, kMidedgeFitStencil - 3>::Zero();
  Eigen::Matrix<double, kMidedgeFitStencil - 3, 1> theta_bar =
      Eigen::Matrix<double, kMidedgeFitStencil - 3, 1>::Zero();  // rest angles, rad
  Vec3 beta_bar = Vec3::Zero();  // rest beta, 1/m
  Mat3 C = Mat3::Zero();         // condensed plate matrix, N m * m^2 = J m^2
};

// One face's stencil (global vertex ids, order above) and rest data.
struct MidedgeFitElement {
  std::array<int, kMidedgeFitStencil> v;
  MidedgeFitRest rest;
  // Hinge j's number among the mesh's interior edges (first use in face order), -1 past rest.hinges;
  // every face lists a hinge's vertices in the order of its first use.
  std::array<int, kMidedgeFitStencil - 3> hinge_id{};
};

// The elements of every face. faces: global vertex ids, a consistently oriented manifold mesh (what
// validate_mesh guarantees); rest: global rest positions (n, 3), m; D: bending rigidity, N m;
// nu: Poisson ratio. Throws std::invalid_argument for an index outside rest, a zero-area rest face
// or a non-manifold or inconsistently oriented edge.
std::vector<MidedgeFitElement> midedge_fit_elements(const Faces& faces, const Positions& rest, double D, double nu);

// Element functions; x: the stencil positions stacked (36 entries, m; unused slots anything).
Vec3 midedge_fit_curvature(const Vec<36>& x, const MidedgeFitRest& rest);  // beta, 1/m
double midedge_fit_energy(const Vec<36>& x, const MidedgeFitRest& rest);    // J
Vec<36> midedge_fit_gradient(const Vec<36>& x, const MidedgeFitRest& rest); // N
Mat<36> midedge_fit_hessian(const Vec<36>& x, const MidedgeFitRest& rest);  // N/m, exact, unprojected

class MidedgeFitBending : public EnergyTerm {
 public:
  // faces: global vertex ids of one or more shells; rest: global rest positions, m; D in N m; nu.
  // Throws as midedge_fit_elements does.
  MidedgeFitBending(const Faces& faces, const Positions& rest, double bending_rigidity, double poisson_ratio);

  std::string name() const override { return "bending"; }

  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  // The Hessian is the sum of one positive semi-definite 36 x 36 block per face (Gb C Gb^T, Gb =
  // d beta / dx) and one 12 x 12 block per hinge (its angle Hessian times the summed factor
  // lambda . c of the faces using it), each projected with project_hessian<12> as the discrete
  // hinge's are; with HessianProjection::None the sum is the exact Hessian.
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                   HessianAssembly& hessian) const override;
  bool may_limit_step() const override { return false; }  // max_step is always 1

  const std::vector<MidedgeFitElement>& elements() const { return elements_; }

 private:
  Vec<12> hinge_at(const Eigen::VectorXd& x, int h) const;
  std::vector<double> angles(const Eigen::VectorXd& x) const;  // every hinge's, rad
  Vec3 dbeta(int e, const std::vector<double>& theta) const;    // beta - beta_bar of face e, 1/m
  std::vector<double> angle_factors(const std::vector<double>& theta) const;

  std::vector<MidedgeFitElement> elements_;
  std::vector<Hinge> hinges_;  // global vertex ids, numbered as MidedgeFitElement::hinge_id
  // The (face, local hinge) uses of hinge h: use_[use_begin_[h] .. use_begin_[h + 1]), faces ascending.
  std::vector<int> use_begin_;
  std::vector<std::pair<int, int>> use_;
  GradientScatterPlan hinge_scatter_;
};

}  // namespace pd
