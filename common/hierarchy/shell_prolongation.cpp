#include "hierarchy/shell_prolongation.h"

#include <algorithm>
#include <cfloat>  // DBL_EPSILON
#include <cmath>
#include <utility>

#include <Eigen/Geometry>  // cross products
#include <Eigen/LU>        // 2x2 determinant

#include "util/parallel.h"

namespace pd {

// ---- Derivation of the Jacobian -------------------------------------------------------------------
//
// Fine vertex i in coarse face (x0, x1, x2) with weights w: P_i = sum_k w_k x_k + n gamma + R t.
// The linear part gives w_k I3 per face vertex. The offset depends on the face only through the
// deformed edges D1 = x1 - x0, D2 = x2 - x0, so da/dx1 = da/dD1, da/dx2 = da/dD2 and
// da/dx0 = -(da/dD1 + da/dD2) (the offset is translation invariant).
//
// Normal. c = D1 x D2, n = c / |c|:  dn = (I - n n^T) / |c| dc,  dc = dD1 x D2 + D1 x dD2
//   = -[D2]x dD1 + [D1]x dD2   ([v]x the cross-product matrix), so
//   dn/dD1 = -(I - n n^T) [D2]x / |c|,   dn/dD2 = (I - n n^T) [D1]x / |c|.
//
// Rotation. F = D Binv (D = [D1, D2], Binv = Bbar^{-1}) has the polar decomposition F = R S, R 3x2
// with R^T R = I2 and S = (F^T F)^{1/2} symmetric positive definite. [R, n] is an orthonormal basis of
// R^3 (the columns of R span the deformed triangle's plane and r1 x r2 = +n, since r1 x r2 =
// det(S^{-1}) det(Binv) (D1 x D2) with both determinants > 0), so any dR = R A + n b^T with
// A = R^T dR and b^T = n^T dR. Differentiating R^T R = I2 gives A^T = -A, i.e. A = w J with
// J = [[0, -1], [1, 0]]. Differentiating F = R S:
//   dF = dR S + R dS.
//   R^T dF = A S + dS; its antisymmetric part (dS is symmetric) is A S + S A = w (J S + S J)
//     = w tr(S) J (an identity for symmetric 2x2 S), so
//     w = (r2 . dF1 - r1 . dF2) / tr S                     (dF1, dF2 the columns of dF).
//   n^T dF = b^T S (n^T R = 0), so b^T = n^T dF S^{-1}.
// Hence dR t = w R J t + n (n^T dF S^{-1} t). With dF = dD Binv:
//   dF1 = Binv00 dD1 + Binv10 dD2,  dF2 = Binv01 dD1 + Binv11 dD2, so
//   w = g1 . dD1 + g2 . dD2,  g1 = (Binv00 r2 - Binv01 r1) / tr S,  g2 = (Binv10 r2 - Binv11 r1) / tr S;
//   n^T dF S^{-1} t = n . (p1 dD1 + p2 dD2),  p = Binv S^{-1} t.
// With m = R J t (= n x R t):
//   da/dDk = gamma dn/dDk + m gk^T + pk n n^T          (k = 1, 2; 3x3, dimensionless).
// tr S > 0 and S invertible whenever the face is non-degenerate, which is checked first.
//
// Closed-form 2x2 square root (used for S). For symmetric positive definite C with s = sqrt(det C),
// tau = sqrt(tr C + 2 s): (C + s I)^2 = C^2 + 2 s C + s^2 I = (tr C + 2 s) C by Cayley-Hamilton
// (C^2 = tr C C - det C I), so S = (C + s I) / tau. Then tr S = tau, det S = s and
// S^{-1} = adj(C + s I) / (s tau). For C = F^T F, det C = |F1 x F2|^2; s is taken as |F1 x F2| rather
// than sqrt(det C) to avoid the cancellation in det C for thin triangles.

namespace {

using Mat32 = Eigen::Matrix<double, 3, 2>;

// |a x b| > kDegenerateSin |a| |b| (false for NaN): the two edges span a plane.
bool spans_plane(const Vec3& a, const Vec3& b, const Vec3& c) {
  return c.norm() > kDegenerateSin * a.norm() * b.norm();
}

struct PolarParts {
  Mat32 R;               // rotation factor
  Eigen::Matrix2d Sinv;  // S^{-1}
  double trS;            // tr S
};

// Polar factor of F from its column cross product norm s = |F1 x F2| (> 0).
PolarParts polar_parts(const Mat32& F, double s) {
  const Eigen::Matrix2d C = F.transpose() * F;
  const double tau = std::sqrt(C.trace() + 2.0 * s);
  Eigen::Matrix2d CsI = C;
  CsI.diagonal().array() += s;
  Eigen::Matrix2d adj;
  adj << CsI(1, 1), -CsI(0, 1), -CsI(1, 0), CsI(0, 0);
  PolarParts p;
  p.Sinv = adj / (s * tau);
  p.trS = tau;
  p.R = F * p.Sinv;
  return p;
}

// Everything about one deformed coarse face that the offsets and their derivatives need.
struct DeformedFace {
  Vec3 D1, D2;  // deformed edges x1 - x0, x2 - x0, m
  Vec3 n;       // unit normal
  double cnorm; // |D1 x D2|, m^2
  PolarParts polar;
};

DeformedFace deform_face(const Positions& X, const Faces& faces, int f, const Eigen::Matrix2d& Binv) {
  DeformedFace d;
  const Vec3 x0 = X.row(faces(f, 0)).transpose();
  d.D1 = X.row(faces(f, 1)).transpose() - x0;
  d.D2 = X.row(faces(f, 2)).transpose() - x0;
  const Vec3 c = d.D1.cross(d.D2);
  if (!spans_plane(d.D1, d.D2, c) || !x0.allFinite())
    throw DegenerateProlongationTriangle(
        f, "shell prolongation: deformed coarse face " + std::to_string(f) +
               " is degenerate (zero area or non-finite), its normal and rotation are undefined");
  d.cnorm = c.norm();
  d.n = c / d.cnorm;
  Mat32 D;
  D << d.D1, d.D2;
  const Mat32 F = D * Binv;
  // |F1 x F2| = det(Binv) |D1 x D2| (Binv upper triangular with a positive diagonal).
  d.polar = polar_parts(F, Binv.determinant() * d.cnorm);
  return d;
}

}  // namespace

Mat32 polar_rotation_3x2(const Mat32& F) {
  const Vec3 F1 = F.col(0), F2 = F.col(1);
  const Vec3 c = F1.cross(F2);
  if (!spans_plane(F1, F2, c) || !F.allFinite())
    throw std::domain_error("polar_rotation_3x2: F has rank < 2 or non-finite entries");
  return polar_parts(F, c.norm()).R;
}

ShellProlongation::ShellProlongation(const Positions& coarse_rest, const Faces& coarse_faces,
                                     const Positions& fine_rest,
                                     const std::vector<SurfaceLocation>& locations)
    : num_coarse_(static_cast<int>(coarse_rest.rows())), coarse_faces_(coarse_faces), locations_(locations) {
  const int nf = static_cast<int>(fine_rest.rows());
  const int mc = static_cast<int>(coarse_faces.rows());
  if (static_cast<int>(locations.size()) != nf)
    throw std::invalid_argument("shell prolongation: " + std::to_string(locations.size()) +
                                " locations for " + std::to_string(nf) + " fine vertices");
  for (int f = 0; f < mc; ++f)
    for (int k = 0; k < 3; ++k)
      if (coarse_faces(f, k) < 0 || coarse_faces(f, k) >= num_coarse_)
        throw std::invalid_argument("shell prolongation: coarse face " + std::to_string(f) +
                                    " has a vertex index outside the coarse rest positions");

  // Rest frames of the faces that carry fine vertices.
  std::vector<char> used(mc, 0);
  for (int i = 0; i < nf; ++i) {
    const int f = locations_[i].face;
    if (f < 0 || f >= mc)
      throw std::invalid_argument("shell prolongation: fine vertex " + std::to_string(i) +
                                  " is located in coarse face " + std::to_string(f) + ", out of range");
    used[f] = 1;
  }
  struct RestFrame { Vec3 ebar, nbar, bbar2; };  // [ebar, bbar2 = nbar x ebar] spans the rest plane
  std::vector<RestFrame> frames(mc);
  bbar_inv_.assign(mc, Eigen::Matrix2d::Identity());
  rest_frames_.assign(mc, Mat3::Identity());
  for (int f = 0; f < mc; ++f) {
    if (!used[f]) continue;
    used_faces_.push_back(f);
    const Vec3 X0 = coarse_rest.row(coarse_faces(f, 0)).transpose();
    const Vec3 e1 = coarse_rest.row(coarse_faces(f, 1)).transpose() - X0;
    const Vec3 e2 = coarse_rest.row(coarse_faces(f, 2)).transpose() - X0;
    const Vec3 c = e1.cross(e2);
    if (!spans_plane(e1, e2, c) || !X0.allFinite())
      throw std::invalid_argument("shell prolongation: rest coarse face " + std::to_string(f) +
                                  " has zero area (or non-finite positions)");
    RestFrame& fr = frames[f];
    fr.ebar = e1.normalized();
    fr.nbar = c.normalized();
    fr.bbar2 = fr.nbar.cross(fr.ebar);
    rest_frames_[f] << fr.ebar, fr.bbar2, fr.nbar;
    // Bbar = [[|e1|, e1.e2/|e1|], [0, |e1 x e2|/|e1|]] (the rest edges in the rest frame), inverted
    // in closed form (upper triangular).
    const double b00 = e1.norm(), b01 = e1.dot(e2) / b00, b11 = c.norm() / b00;
    Eigen::Matrix2d inv;
    inv << 1.0 / b00, -b01 / (b00 * b11), 0.0, 1.0 / b11;
    bbar_inv_[f] = inv;
  }

  // Weights, U, and the rest offsets.
  gamma_.resize(nf);
  t_.resize(nf);
  std::vector<Eigen::Triplet<double>> trip, trip3;
  trip.reserve(3 * nf);
  trip3.reserve(9 * nf);
  constexpr double kBaryTol = 1e-9;
  for (int i = 0; i < nf; ++i) {
    SurfaceLocation& loc = locations_[i];
    const double sum = loc.bary.sum();
    if (!loc.bary.allFinite() || loc.bary.minCoeff() < -kBaryTol || std::abs(sum - 1.0) > kBaryTol)
      throw std::invalid_argument("shell prolongation: fine vertex " + std::to_string(i) +
                                  " has barycentric weights that are not >= 0 summing to 1");
    const Vec3 xf = fine_rest.row(i).transpose();
    if (!xf.allFinite())
      throw std::invalid_argument("shell prolongation: fine rest vertex " + std::to_string(i) +
                                  " is not finite");
    // Weights in [-1e-9, 0) are round-off of a point on an edge: clamp them so U stays a convex
    // combination (non-negative entries), then renormalise. The rest offset below is taken against
    // these final weights, so rest recovery stays exact.
    // Renormalise only when a weight was clamped or the sum is off 1 by more than 4 DBL_EPSILON.
    // Why: dividing weights that are already normalised by their rounded sum is not the identity in
    // floating point (that sum can be 1 +- an ulp; about 4% of the rows of a decimated hierarchy),
    // so feeding locations() back would change those rows of U by an ulp and a stored hierarchy
    // (common/store/hierarchy_store.cpp) could not rebuild bit-identical operators. Weights that
    // came out of a division by their (rounded) sum have a rounded sum within about 2.5 eps of 1
    // (one rounding per division and per addition; 2 eps the worst seen over 2M random triples), so
    // 4 eps accepts every normalised triple with a margin, while dividing by a sum that close to 1
    // would only move the weights by a few ulps. With this, re-feeding locations() is the identity.
    const bool clamped = (loc.bary.array() < 0.0).any();
    if (clamped) loc.bary = loc.bary.cwiseMax(0.0);
    if (clamped || std::abs(loc.bary.sum() - 1.0) > 4.0 * DBL_EPSILON) loc.bary /= loc.bary.sum();
    Vec3 vbar = Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      const int v = coarse_faces(loc.face, k);
      const double w = loc.bary[k];
      vbar += w * coarse_rest.row(v).transpose();
      if (w == 0.0) continue;
      trip.emplace_back(i, v, w);
      for (int a = 0; a < 3; ++a) trip3.emplace_back(3 * i + a, 3 * v + a, w);
    }
    const RestFrame& fr = frames[loc.face];
    const Vec3 d = xf - vbar;
    gamma_[i] = fr.nbar.dot(d);
    t_[i] = Eigen::Vector2d(fr.ebar.dot(d), fr.bbar2.dot(d));
  }
  U_.resize(nf, num_coarse_);
  U_.setFromTriplets(trip.begin(), trip.end());
  U_stacked_.resize(3 * nf, 3 * num_coarse_);
  U_stacked_.setFromTriplets(trip3.begin(), trip3.end());
}

void ShellProlongation::check_coarse_size(const Positions& Xc, const char* what) const {
  if (Xc.rows() != num_coarse_)
    throw std::invalid_argument(std::string("shell prolongation: ") + what + ": " +
                                std::to_string(Xc.rows()) + " coarse positions for " +
                                std::to_string(num_coarse_) + " coarse vertices");
}

Positions ShellProlongation::apply_linear(const Positions& Xc) const {
  check_coarse_size(Xc, "apply_linear");
  Positions out = U_ * Xc;
  return out;
}

Positions ShellProlongation::offsets(const Positions& Xc) const {
  check_coarse_size(Xc, "offsets");
  // n and R once per used face, then a_i = n gamma_i + R t_i per fine vertex.
  std::vector<Vec3> n(coarse_faces_.rows());
  std::vector<Mat32> R(coarse_faces_.rows());
  for (int f : used_faces_) {
    const DeformedFace d = deform_face(Xc, coarse_faces_, f, bbar_inv_[f]);
    n[f] = d.n;
    R[f] = d.polar.R;
  }
  Positions A(num_fine(), 3);
  for (int i = 0; i < num_fine(); ++i) {
    const int f = locations_[i].face;
    A.row(i) = (n[f] * gamma_[i] + R[f] * t_[i]).transpose();
  }
  return A;
}

std::vector<Mat3> ShellProlongation::vertex_rotations(const Positions& Xc) const {
  return vertex_maps(Xc, false);
}

std::vector<Mat3> ShellProlongation::vertex_deformations(const Positions& Xc) const {
  return vertex_maps(Xc, true);
}

std::vector<Mat3> ShellProlongation::vertex_maps(const Positions& Xc, bool stretch) const {
  check_coarse_size(Xc, "vertex_rotations");
  std::vector<Mat3> Q(coarse_faces_.rows(), Mat3::Identity());
  for (int f : used_faces_) {
    const DeformedFace d = deform_face(Xc, coarse_faces_, f, bbar_inv_[f]);
    Mat32 in_plane = d.polar.R;
    if (stretch) {
      Mat32 D;
      D << d.D1, d.D2;
      in_plane = D * bbar_inv_[f];  // F: rest-frame coordinates -> deformed vectors
    }
    Mat3 deformed;
    deformed << in_plane, d.n;
    Q[f] = deformed * rest_frames_[f].transpose();
  }
  std::vector<Mat3> out(num_fine());
  for (int i = 0; i < num_fine(); ++i) out[i] = Q[locations_[i].face];
  return out;
}

Positions ShellProlongation::apply(const Positions& Xc) const {
  Positions out = offsets(Xc);
  out += U_ * Xc;
  return out;
}

Positions ShellProlongation::apply_frozen(const Positions& Xc, const Positions& frozen_offsets) const {
  check_coarse_size(Xc, "apply_frozen");
  if (frozen_offsets.rows() != num_fine())
    throw std::invalid_argument("shell prolongation: apply_frozen: " +
                                std::to_string(frozen_offsets.rows()) + " offsets for " +
                                std::to_string(num_fine()) + " fine vertices");
  Positions out = U_ * Xc;
  out += frozen_offsets;
  return out;
}

Eigen::VectorXd ShellProlongation::restrict_gradient(const Eigen::VectorXd& g_fine) const {
  if (g_fine.size() != 3 * num_fine())
    throw std::invalid_argument("shell prolongation: restrict_gradient: gradient of size " +
                                std::to_string(g_fine.size()) + ", expected " +
                                std::to_string(3 * num_fine()));
  const Positions Gc = U_.transpose() * as_rows(g_fine);
  return stacked(Gc);
}

ShellProlongation::JacobianPlan ShellProlongation::jacobian_plan() const {
  // Column 3v + b holds, for each fine vertex i whose face has corner v (i ascending), rows 3i..3i+2:
  // 3 c_v entries, c_v the number of such fine vertices. Columns in order, so column 3v + b starts
  // at 9 s_v + 3 c_v b, s_v = sum of c_u over u < v.
  const int nf = num_fine();
  std::vector<int> count(static_cast<size_t>(num_coarse_), 0);
  for (int i = 0; i < nf; ++i)
    for (int k = 0; k < 3; ++k) ++count[static_cast<size_t>(coarse_faces_(locations_[i].face, k))];
  JacobianPlan plan;
  plan.J.resize(3 * nf, 3 * num_coarse_);
  plan.J.resizeNonZeros(27 * nf);
  int* outer = plan.J.outerIndexPtr();
  outer[0] = 0;
  for (int c = 0; c < 3 * num_coarse_; ++c) outer[c + 1] = outer[c] + 3 * count[static_cast<size_t>(c / 3)];
  std::vector<int> rank(static_cast<size_t>(num_coarse_), 0);  // fine vertices of column v placed so far
  plan.first.resize(3 * static_cast<size_t>(nf));
  int* inner = plan.J.innerIndexPtr();
  for (int i = 0; i < nf; ++i)
    for (int k = 0; k < 3; ++k) {
      const int v = coarse_faces_(locations_[i].face, k);
      const int first = outer[3 * v] + 3 * rank[static_cast<size_t>(v)]++;
      plan.first[3 * static_cast<size_t>(i) + k] = first;
      const int length = outer[3 * v + 1] - outer[3 * v];
      for (int b = 0; b < 3; ++b)
        for (int a = 0; a < 3; ++a) inner[first + b * length + a] = 3 * i + a;
    }
  std::fill(plan.J.valuePtr(), plan.J.valuePtr() + plan.J.nonZeros(), 0.0);
  return plan;
}

Eigen::SparseMatrix<double> ShellProlongation::jacobian(const Positions& Xc) const {
  JacobianPlan plan = jacobian_plan();
  jacobian(Xc, plan);
  return std::move(plan.J);
}

void ShellProlongation::jacobian(const Positions& Xc, JacobianPlan& plan) const {
  check_coarse_size(Xc, "jacobian");
  const int nf = num_fine();
  if (plan.J.rows() != 3 * nf || plan.J.cols() != 3 * num_coarse_ || plan.J.nonZeros() != 27 * nf ||
      !plan.J.isCompressed() || plan.first.size() != 3 * static_cast<size_t>(nf))
    throw std::invalid_argument("shell prolongation: jacobian: the plan was not made by this operator's jacobian_plan()");
  const int mc = static_cast<int>(coarse_faces_.rows());
  std::vector<DeformedFace> faces(mc);
  for (int f : used_faces_) faces[f] = deform_face(Xc, coarse_faces_, f, bbar_inv_[f]);
  // The normal's derivatives depend on the face alone: computed once per face, not once per fine
  // vertex on it (about 30 per face at a 64x vertex ratio).
  struct NormalDerivatives {
    Mat3 dn_dD1, dn_dD2, nnT;
  };
  std::vector<NormalDerivatives> normal(mc);
  parallel_for_index(static_cast<int>(used_faces_.size()), [&](int k) {
    const int f = used_faces_[static_cast<size_t>(k)];
    const DeformedFace& d = faces[f];
    const Mat3 Pn = (Mat3::Identity() - d.n * d.n.transpose()) / d.cnorm;
    normal[f].dn_dD1 = -Pn * cross_matrix(d.D2);
    normal[f].dn_dD2 = Pn * cross_matrix(d.D1);
    normal[f].nnT = d.n * d.n.transpose();
  }, 16);

  const int* outer = plan.J.outerIndexPtr();
  double* values = plan.J.valuePtr();
  parallel_for_index(nf, [&](int i) {
    const SurfaceLocation& loc = locations_[i];
    const DeformedFace& d = faces[loc.face];
    const NormalDerivatives& nd = normal[loc.face];
    const Eigen::Matrix2d& Binv = bbar_inv_[loc.face];
    const Mat32& R = d.polar.R;
    const Vec3 r1 = R.col(0), r2 = R.col(1);
    const Eigen::Vector2d& t = t_[i];
    const double gamma = gamma_[i];

    const Mat3& dn_dD1 = nd.dn_dD1;
    const Mat3& dn_dD2 = nd.dn_dD2;
    const Vec3 m = -t[1] * r1 + t[0] * r2;  // R J t
    const Vec3 g1 = (Binv(0, 0) * r2 - Binv(0, 1) * r1) / d.polar.trS;
    const Vec3 g2 = (Binv(1, 0) * r2 - Binv(1, 1) * r1) / d.polar.trS;
    const Eigen::Vector2d p = Binv * (d.polar.Sinv * t);
    const Mat3& nnT = nd.nnT;
    const Mat3 da_dD1 = gamma * dn_dD1 + m * g1.transpose() + p[0] * nnT;
    const Mat3 da_dD2 = gamma * dn_dD2 + m * g2.transpose() + p[1] * nnT;

    const Mat3 blocks[3] = {-(da_dD1 + da_dD2), da_dD1, da_dD2};
    for (int k = 0; k < 3; ++k) {
      const int v = coarse_faces_(loc.face, k);
      Mat3 B = blocks[k];
      B.diagonal().array() += loc.bary[k];
      const int first = plan.first[3 * static_cast<size_t>(i) + k];
      const int length = outer[3 * v + 1] - outer[3 * v];
      for (int b = 0; b < 3; ++b)
        for (int a = 0; a < 3; ++a) values[first + b * length + a] = B(a, b);
    }
  });
}

}  // namespace pd
