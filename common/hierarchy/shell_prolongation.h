#pragma once
// Shell prolongation P(x) = U x + a(x) from a coarse mesh to a fine mesh (PSQ, Zhang et al. 2023,
// section 4.3, eqs. 4-9 and footnote 2).
//
// Why: the progressive solver steps a coarse level but evaluates the finest level's elasticity on the
// prolonged shape. Barycentric interpolation alone (U x, "intrinsic prolongation") does not give back
// the fine rest shape (a fine vertex is not on the coarse surface) and so puts ghost forces on an
// undeformed shell and misses curved rest shapes. PSQ adds to every fine vertex a stored rest offset
// that rides on its coarse triangle: the out-of-plane part along the triangle's deformed normal, the
// in-plane part rotated by the rotation factor of the triangle's deformation gradient. At the coarse
// rest shape the offsets are the stored rest differences, so P(Vc) = Xf exactly.
//
// The same class serves the per-level operator P_{l+1}^l (eq. 7) and the direct operator P^l to the
// finest level (eq. 9): only the locations differ (per-level: on the next coarser mesh; direct: the
// composed location of every finest vertex on level l's mesh). Computing the locations (intrinsic
// self-parameterization through the recorded collapses) is the decimation stage's job; here they are
// input.
//
// Conventions (geometry/mesh.h): positions in metres as (n, 3) rows; stacked vectors x[3*i + k].
//   U is (nf x nc) and acts on each coordinate alike: P(X) = U X + A(X) row-wise, X (nc, 3),
//   A(X) (nf, 3) with row i = a_i(X). In stacked form the linear part is U (x) I3 (Kronecker).
//
// Per fine vertex i located in coarse face f = (v0, v1, v2) with barycentric weights w:
//   rest:      vbar_i = sum_k w_k Xbar_vk,  d_i = Xf_i - vbar_i                         (m)
//              ebar = unit(Xbar_v1 - Xbar_v0), nbar = unit((Xbar_v1 - Xbar_v0) x (Xbar_v2 - Xbar_v0))
//              d_i = nbar gamma_i + [ebar, nbar x ebar] t_i   ->  gamma_i (m), t_i (2-vector, m)
//   deformed:  a_i(x) = n_f(x) gamma_i + R_f(x) t_i,  n_f = unit((x1 - x0) x (x2 - x0))
//              F_f = [x1 - x0, x2 - x0] Bbar_f^{-1}  (3x2, dimensionless)
//              Bbar_f = the rest edges in the rest frame [ebar, nbar x ebar] =
//                       [[|e1|, e1.e2/|e1|], [0, |e1 x e2|/|e1|]]   (m; e1, e2 rest edges)
//              R_f = the polar rotation factor of F_f: the 3x2 matrix with orthonormal columns closest
//                    to F_f, R = U_svd [I2; 0] V_svd^T = F (F^T F)^{-1/2} (same thing when rank F = 2).
// At rest F = [ebar, nbar x ebar], so R t = [ebar, nbar x ebar] t and n = nbar: a_i(Xbar) = d_i.
// Under a rigid motion x -> Q x + c (det Q = +1) n -> Q n, F -> Q F, R -> Q R, so P(Q X + c) =
// Q P(X) + c. A reflection flips n relative to Q n: P is not reflection-equivariant (nor need it be).
//
// Degenerate deformed triangles. n and R need a deformed coarse triangle with non-zero area. A face
// is degenerate when |(x1 - x0) x (x2 - x0)| <= kDegenerateSin * |x1 - x0| |x2 - x0| (sine of the
// angle between its edges, so scale-free; also any non-finite coordinate). apply(), offsets() and
// jacobian() then throw DegenerateProlongationTriangle naming the coarse face: no NaN and no silent
// fall-back (a fall-back would make P discontinuous there). Only faces that contain a fine vertex are
// examined. A solver that tries such a state in a line search can catch it and reject the step, as
// the membrane energy's +infinity does for the same collapse.
//
// The progressive solver's gradients use jacobian(), the exact derivative of the full nonlinear P
// (progressive/prolonged_term.h says why); restrict_gradient and apply_frozen serve PSQ's frozen
// offsets (grad = U^T g_fine), kept selectable to measure what freezing drops.
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "geometry/mesh.h"

namespace pd {

// Where a fine vertex sits on the coarse mesh: a face of the coarse mesh (0-based) and barycentric
// weights for its three vertices (in the face's vertex order), summing to 1, each >= -tiny.
struct SurfaceLocation {
  int face = -1;
  Eigen::Vector3d bary = Eigen::Vector3d::Zero();
};

// Thrown when a deformed coarse face that carries fine vertices has (numerically) zero area.
class DegenerateProlongationTriangle : public std::domain_error {
 public:
  DegenerateProlongationTriangle(int face, const std::string& what)
      : std::domain_error(what), face_(face) {}
  int face() const { return face_; }  // coarse face index
 private:
  int face_;
};

// Threshold on sin(angle between the deformed edges) below which a deformed triangle is degenerate.
inline constexpr double kDegenerateSin = 1e-12;

// Polar rotation factor of a 3x2 matrix F of rank 2: R = F (F^T F)^{-1/2}, the 3x2 matrix with
// orthonormal columns nearest to F (Frobenius), equal to U_svd [I2; 0] V_svd^T. The 2x2 inverse square
// root is in closed form: with C = F^T F, s = sqrt(det C), tau = sqrt(tr C + 2 s),
// sqrt(C) = (C + s I) / tau. Throws std::domain_error if F has rank < 2 (sin of the angle between its
// columns <= kDegenerateSin) or non-finite entries.
Eigen::Matrix<double, 3, 2> polar_rotation_3x2(const Eigen::Matrix<double, 3, 2>& F);

class ShellProlongation {
 public:
  // coarse_rest: Vc (nc, 3) m; coarse_faces: Fc (mc, 3) 0-based; fine_rest: Xf (nf, 3) m;
  // locations: one per fine vertex (size nf). Barycentric weights in [-1e-9, 0) are set to 0, and
  // the weights are divided by their sum (which must be within 1e-9 of 1) when a weight was clamped
  // or the sum is off 1 by more than 4 eps, so every row of U is a convex combination summing to 1
  // and locations() given back to the constructor rebuild the same operator bit for bit; zero
  // weights are not stored. Throws std::invalid_argument (naming the fine vertex or coarse face) for a size mismatch,
  // a face index out of range, a face vertex index out of range, non-finite or out-of-range weights
  // (< -1e-9, or a sum off 1 by more than 1e-9), or a containing rest face with zero area.
  ShellProlongation(const Positions& coarse_rest, const Faces& coarse_faces, const Positions& fine_rest,
                    const std::vector<SurfaceLocation>& locations);

  int num_coarse() const { return num_coarse_; }
  int num_fine() const { return static_cast<int>(locations_.size()); }

  // U (nf x nc): row i holds the barycentric weights of fine vertex i (<= 3 non-zeros, sum 1).
  const Eigen::SparseMatrix<double>& U() const { return U_; }
  // U (x) I3 (3nf x 3nc) in the stacked layout: the Jacobian of the frozen-offset prolongation.
  const Eigen::SparseMatrix<double>& U_stacked() const { return U_stacked_; }

  // The locations as used (weights clamped and normalised as described at the constructor).
  const std::vector<SurfaceLocation>& locations() const { return locations_; }
  // Stored rest offsets per fine vertex: gamma (m, along the rest normal) and t (m, in the rest frame
  // [ebar, nbar x ebar] of the containing coarse triangle).
  const std::vector<double>& normal_offsets() const { return gamma_; }
  const std::vector<Eigen::Vector2d>& tangent_offsets() const { return t_; }

  // Full prolongation U Xc + a(Xc), Xc (nc, 3) m -> (nf, 3) m. Throws DegenerateProlongationTriangle.
  Positions apply(const Positions& Xc) const;
  // Intrinsic (linear) part U Xc.
  Positions apply_linear(const Positions& Xc) const;
  // The offsets a(Xc), (nf, 3) m. Throws DegenerateProlongationTriangle.
  Positions offsets(const Positions& Xc) const;
  // Per fine vertex i, the rotation Q_i = [R_f, n_f] [ebar, nbar x ebar, nbar]^T of its coarse face f
  // at Xc: it carries the rest frame to the deformed one, so a_i(Xc) = Q_i d_i with d_i the rest
  // offset (det Q_i = +1; identity at the rest shape). Safe upsampling uses it to carry rest-space
  // displacements near vertex i into the deformed shape. Throws DegenerateProlongationTriangle.
  std::vector<Mat3> vertex_rotations(const Positions& Xc) const;
  // The same with the in-plane stretch kept: A_i = [F_f, n_f] [ebar, nbar x ebar, nbar]^T, F_f the
  // coarse face's deformation gradient (3x2). Carries rest displacements tangent to the surface as
  // the surface is stretched (identity at rest). Throws DegenerateProlongationTriangle.
  std::vector<Mat3> vertex_deformations(const Positions& Xc) const;
  // Frozen-offset prolongation U Xc + frozen_offsets (frozen_offsets (nf, 3) m, e.g. offsets(Xc0)).
  Positions apply_frozen(const Positions& Xc, const Positions& frozen_offsets) const;

  // Frozen-offset chain rule: U^T g per coordinate. g_fine stacked (3nf), e.g. a fine energy gradient
  // in N; returns the stacked (3nc) coarse gradient.
  Eigen::VectorXd restrict_gradient(const Eigen::VectorXd& g_fine) const;

  // Exact Jacobian dP/dx of the full nonlinear P at Xc: (3nf x 3nc), stacked layout (row 3i + a,
  // column 3v + b), dimensionless. Derivation in the .cpp. Throws DegenerateProlongationTriangle.
  // Its pattern depends only on the locations: 27 stored entries per fine vertex (3 x 3 for each
  // vertex of its coarse face, zeros kept), rows ascending within each column.
  Eigen::SparseMatrix<double> jacobian(const Positions& Xc) const;

  // Where jacobian() writes: the pattern (values zero until filled) and, per fine vertex i and face
  // corner k (index 3i + k), the value index of the entry (row 3i, column 3v_k). The entry (3i + a,
  // 3v_k + b) then sits b column lengths further plus a. A Newton solve asks for J at every iterate;
  // with a plan it is written in place, on the element threads, instead of sorted from triplets.
  struct JacobianPlan {
    Eigen::SparseMatrix<double> J;
    std::vector<int> first;
  };
  JacobianPlan jacobian_plan() const;
  // Writes jacobian(Xc)'s values into plan.J (the same matrix bit for bit, no allocation); the
  // plan must come from this operator's jacobian_plan() (std::invalid_argument otherwise). Throws
  // DegenerateProlongationTriangle as jacobian() does (plan.J's values are then unspecified).
  void jacobian(const Positions& Xc, JacobianPlan& plan) const;

 private:
  void check_coarse_size(const Positions& Xc, const char* what) const;
  std::vector<Mat3> vertex_maps(const Positions& Xc, bool stretch) const;

  int num_coarse_ = 0;
  Faces coarse_faces_;
  std::vector<SurfaceLocation> locations_;  // weights normalised to sum 1
  std::vector<double> gamma_;
  std::vector<Eigen::Vector2d> t_;
  std::vector<int> used_faces_;                 // coarse faces containing at least one fine vertex
  std::vector<Eigen::Matrix2d> bbar_inv_;       // per coarse face (identity for unused faces), 1/m
  std::vector<Mat3> rest_frames_;               // per coarse face: columns ebar, nbar x ebar, nbar
  Eigen::SparseMatrix<double> U_;
  Eigen::SparseMatrix<double> U_stacked_;
};

}  // namespace pd
