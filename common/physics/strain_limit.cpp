#include "physics/strain_limit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

#include "physics/triangle_rest.h"

// Derivation (notation of the header).
//
// Barrier as a function of an eigenvalue lambda of C (sigma = sqrt(lambda), g = s - sigma,
// t = g / g_hat, b(g) = beta(t)):
//   psi(lambda)   = beta(t)
//   psi'(lambda)  = -beta'(t) / (2 g_hat sigma)                                  (dg/dlambda = -1/(2 sigma))
//   psi''(lambda) = beta''(t) / (4 g_hat^2 sigma^2) + beta'(t) / (4 g_hat sigma^3)  (d2g/dlambda2 = 1/(4 sigma^3))
//   beta'(t)  = -2 (t - 1) ln t - (t - 1)^2 / t
//   beta''(t) = -2 ln t - 4 (t - 1) / t + (t - 1)^2 / t^2
//
// Element energy E = k Phi(C), k = kappa_s A, Phi(C) = psi(lambda1) + psi(lambda2), C = F^T F.
// With the eigenpairs (lambda_i, v_i) of C (v1, v2 orthonormal in R^2):
//   dPhi/dC = S = psi'(lambda1) v1 v1^T + psi'(lambda2) v2 v2^T               (2x2)
//   d2Phi[dC, dC] = sum_i psi''(lambda_i) (v_i^T dC v_i)^2 + 2 D (v1^T dC v2)^2,
//   D = (psi'(lambda1) - psi'(lambda2)) / (lambda1 - lambda2)   (-> psi''(lambda) as they meet)
// (second variation of a spectral function of a symmetric matrix). With dC = dF^T F + F^T dF and
// u_i = F v_i:
//   dE = k tr(S dC) = 2 k <F S, dF>                        => dE/dF = 2 k F S      (3x2)
//   v_i^T dC v_i = 2 u_i . (dF v_i)                        => a_i = 2 [v_i0 u_i; v_i1 u_i]
//   v1^T dC v2  = u2 . (dF v1) + u1 . (dF v2)              => c = [v10 u2 + v20 u1; v11 u2 + v21 u1]
//   d2E/dF2 = k [ 2 S (x) I3 + psi''(lambda1) a1 a1^T + psi''(lambda2) a2 a2^T + 2 D c c^T ]   (6x6)
// in vec(F) = (F col 0, F col 1); the first term is tr(S d2C), d2C = 2 dF^T dF. At lambda1 == lambda2
// the last three terms are psi'' times the quadratic form |dC|_F^2 written in the basis (v1, v2), so
// the arbitrary choice of eigenvectors there does not matter.
// Finally F_j = (x1 - x0) B(0, j) + (x2 - x0) B(1, j), so dF_j/dx_v = T(v, j) I3 with
//   T = [ -(B00 + B10)  -(B01 + B11) ;  B00  B01 ;  B10  B11 ]      (rows v = 0, 1, 2; 1/m)
// and g_v = sum_j T(v, j) (dE/dF)_j, H_vw = sum_jl T(v, j) T(w, l) (d2E/dF2)_jl.

namespace pd {

namespace {

using Mat32 = Eigen::Matrix<double, 3, 2>;
using Mat96 = Eigen::Matrix<double, 9, 6>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Eigen-decomposition of the symmetric 2x2 C = F^T F in closed form.
struct Spectrum {
  Mat32 F;
  double lambda1, lambda2;   // lambda1 >= lambda2
  double gap;                // lambda1 - lambda2 = 2 r, exact (not a difference of rounded values)
  Eigen::Vector2d v1, v2;    // orthonormal eigenvectors
};

Spectrum spectrum(const Mat32& F) {
  Spectrum sp;
  sp.F = F;
  const double c00 = F.col(0).squaredNorm(), c11 = F.col(1).squaredNorm(), c01 = F.col(0).dot(F.col(1));
  const double m = 0.5 * (c00 + c11), d = 0.5 * (c00 - c11);
  const double r = std::hypot(d, c01);
  sp.lambda1 = m + r;
  sp.lambda2 = m - r;
  sp.gap = 2.0 * r;
  // Eigenvector of lambda1, from whichever row of C - lambda2 I avoids cancellation:
  // (d + r, c01) if d >= 0, (c01, r - d) otherwise (both components are sums of non-negative terms
  // or exact). r == 0 (C = m I): any basis; take the axes.
  Eigen::Vector2d v = d >= 0.0 ? Eigen::Vector2d(d + r, c01) : Eigen::Vector2d(c01, r - d);
  const double n = v.norm();
  sp.v1 = n > 0.0 ? Eigen::Vector2d(v / n) : Eigen::Vector2d(1.0, 0.0);
  sp.v2 = Eigen::Vector2d(-sp.v1.y(), sp.v1.x());
  return sp;
}

double sigma_max_of(const Mat32& F) {
  const double c00 = F.col(0).squaredNorm(), c11 = F.col(1).squaredNorm(), c01 = F.col(0).dot(F.col(1));
  return std::sqrt(0.5 * (c00 + c11) + std::hypot(0.5 * (c00 - c11), c01));
}

// psi(lambda) of the header's barrier and its first two derivatives, for one settings. Whether an
// eigenvalue is in the band or over the wall is decided on sigma = sqrt(lambda), the quantity
// max_step tests, so that the two can never disagree by a rounding.
class Barrier {
 public:
  explicit Barrier(const StrainLimitSettings& s)
      : limit_(s.limit), ghat_(s.activation), shat_(s.limit - s.activation) {}

  bool active(double lambda) const { return std::sqrt(lambda) > shat_; }
  bool admissible(double lambda) const { return std::sqrt(lambda) < limit_; }

  // beta and its derivatives at sigma = sqrt(lambda), for s_hat < sigma < s. u = t - 1 is formed
  // from s_hat - sigma directly and ln t as log1p(u), so the band's entry (t -> 1) keeps its digits.
  struct Beta { double sigma, b, db, d2b; };
  Beta beta(double lambda) const {
    Beta r;
    r.sigma = std::sqrt(lambda);
    const double u = (shat_ - r.sigma) / ghat_;  // t - 1, in (-1, 0)
    const double t = (limit_ - r.sigma) / ghat_;
    const double lt = std::log1p(u);
    r.b = -u * u * lt;
    r.db = -2.0 * u * lt - u * u / t;
    r.d2b = -2.0 * lt - 4.0 * u / t + (u / t) * (u / t);
    return r;
  }

  double value(double lambda) const {
    if (!active(lambda)) return 0.0;
    if (!admissible(lambda)) return kInf;
    return beta(lambda).b;
  }
  double d1(double lambda) const {
    if (!active(lambda)) return 0.0;
    const Beta r = beta(lambda);
    return -r.db / (2.0 * ghat_ * r.sigma);
  }
  double d2(double lambda) const {
    if (!active(lambda)) return 0.0;
    const Beta r = beta(lambda);
    const double s2 = r.sigma * r.sigma;
    return r.d2b / (4.0 * ghat_ * ghat_ * s2) + r.db / (4.0 * ghat_ * s2 * r.sigma);
  }

  // D = (psi'(l1) - psi'(l2)) / gap, gap = l1 - l2 >= 0, l1 admissible.
  double divided_difference(double l1, double l2, double gap) const {
    if (!active(l1)) return 0.0;
    // l2 outside the band: psi'(l2) = 0, no cancellation (and gap > 0 since l2 < l1).
    if (!active(l2)) return d1(l1) / gap;
    // Far apart relative to the barrier's length scale (the distance W of l1 to the wall, over
    // which psi's derivatives change by O(1) relative): the difference quotient loses at most
    // ~eps W / gap of its digits, i.e. nothing.
    const double W = limit_ * limit_ - l1;
    if (gap > 0.1 * W) return (d1(l1) - d1(l2)) / gap;
    // Close eigenvalues: D is the mean of psi'' over [l2, l1]; 3-point Gauss-Legendre integrates it
    // with relative error ~ 3e-3 (gap / W)^6 < 1e-8 (psi'' is smooth on [l2, l1], both ends in the
    // band), and gives psi''(l1) exactly when gap == 0.
    const double mid = 0.5 * (l1 + l2), off = 0.5 * gap * std::sqrt(0.6);
    return (5.0 * d2(mid - off) + 8.0 * d2(mid) + 5.0 * d2(mid + off)) / 18.0;
  }

 private:
  double limit_, ghat_, shat_;
};

Mat32 deformation_gradient(const Vec<9>& x, const Eigen::Matrix2d& B) {
  Mat32 e;
  e.col(0) = x.segment<3>(3) - x.segment<3>(0);
  e.col(1) = x.segment<3>(6) - x.segment<3>(0);
  return e * B;
}

// T(v, j) = dF_j / dx_v (a multiple of I3), see the derivation.
Eigen::Matrix<double, 3, 2> vertex_weights(const Eigen::Matrix2d& B) {
  Eigen::Matrix<double, 3, 2> T;
  T.row(0) = -(B.row(0) + B.row(1));
  T.row(1) = B.row(0);
  T.row(2) = B.row(1);
  return T;
}

}  // namespace

double default_strain_limit_activation(double limit) { return 0.1 * (limit - 1.0); }

double default_strain_limit_stiffness(double youngs, double thickness) {
  if (!(youngs >= 0.0) || !std::isfinite(youngs))
    throw std::invalid_argument("StrainLimitSettings: Young's modulus must be finite and >= 0 (Pa)");
  if (!(thickness > 0.0) || !std::isfinite(thickness))
    throw std::invalid_argument("StrainLimitSettings: thickness must be finite and > 0 (m)");
  return youngs * thickness;
}

StrainLimitSettings StrainLimitSettings::from(double limit, double youngs, double thickness) {
  StrainLimitSettings s;
  s.limit = limit;
  s.stiffness = default_strain_limit_stiffness(youngs, thickness);
  return resolve_strain_limit_settings(s);
}

void check_strain_limit_settings(const StrainLimitSettings& s) {
  if (!(s.limit > 1.0) || !std::isfinite(s.limit))
    throw std::invalid_argument("StrainLimitSettings: limit must be a finite stretch > 1");
  if (!(s.activation > 0.0 && s.activation <= s.limit - 1.0))
    throw std::invalid_argument("StrainLimitSettings: activation must lie in (0, limit - 1]");
  if (!(s.stiffness >= 0.0) || !std::isfinite(s.stiffness))
    throw std::invalid_argument("StrainLimitSettings: stiffness must be finite and >= 0 (J/m^2)");
}

StrainLimitSettings resolve_strain_limit_settings(const StrainLimitSettings& settings) {
  StrainLimitSettings s = settings;
  if (s.activation == 0.0 && s.limit > 1.0) s.activation = default_strain_limit_activation(s.limit);
  check_strain_limit_settings(s);
  return s;
}

StrainLimitRest strain_limit_rest(const Vec3& X0, const Vec3& X1, const Vec3& X2) {
  const Vec3 E1 = X1 - X0, E2 = X2 - X0;
  const Vec3 n = E1.cross(E2);
  const double twice_area = n.norm();
  if (!(twice_area > 0.0) || !std::isfinite(twice_area))
    throw std::invalid_argument("strain_limit_rest: rest triangle has zero area");
  const double len1 = E1.norm();
  const Vec3 t1 = E1 / len1;
  const Vec3 t2 = n.cross(E1).normalized();  // in the plane, perpendicular to t1, towards X2
  Eigen::Matrix2d Dm;
  Dm << len1, E2.dot(t1),
        0.0,  E2.dot(t2);
  StrainLimitRest r;
  // Dm is upper triangular with positive diagonal (E2 . t2 = 2 area / len1 > 0).
  r.B << 1.0 / Dm(0, 0), -Dm(0, 1) / (Dm(0, 0) * Dm(1, 1)),
         0.0,            1.0 / Dm(1, 1);
  r.area = 0.5 * twice_area;
  return r;
}

Eigen::Matrix<double, 3, 2> strain_limit_deformation_gradient(const Vec<9>& x, const StrainLimitRest& rest) {
  return deformation_gradient(x, rest.B);
}

Eigen::Vector2d principal_stretches(const Vec<9>& x, const StrainLimitRest& rest) {
  const Spectrum sp = spectrum(deformation_gradient(x, rest.B));
  // lambda2 = det C / lambda1 keeps the small singular value's digits (m - r cancels when
  // lambda2 << lambda1); det C = |F0 x F1|^2.
  const double det = sp.F.col(0).cross(sp.F.col(1)).squaredNorm();
  const double l2 = sp.lambda1 > 0.0 ? det / sp.lambda1 : 0.0;
  return Eigen::Vector2d(std::sqrt(sp.lambda1), std::sqrt(l2));
}

double strain_limit_energy(const Vec<9>& x, const StrainLimitRest& rest, const StrainLimitSettings& s) {
  const Barrier psi(s);
  const Spectrum sp = spectrum(deformation_gradient(x, rest.B));
  if (!psi.admissible(sp.lambda1)) return kInf;
  if (!psi.active(sp.lambda1)) return 0.0;
  return s.stiffness * rest.area * (psi.value(sp.lambda1) + psi.value(sp.lambda2));
}

Vec<9> strain_limit_gradient(const Vec<9>& x, const StrainLimitRest& rest, const StrainLimitSettings& s) {
  const Barrier psi(s);
  const Spectrum sp = spectrum(deformation_gradient(x, rest.B));
  if (!psi.admissible(sp.lambda1)) return Vec<9>::Constant(kNaN);
  if (!psi.active(sp.lambda1)) return Vec<9>::Zero();
  const Eigen::Matrix2d S = psi.d1(sp.lambda1) * sp.v1 * sp.v1.transpose() +
                            psi.d1(sp.lambda2) * sp.v2 * sp.v2.transpose();
  const Mat32 P = (2.0 * s.stiffness * rest.area) * (sp.F * S);  // dE/dF, J
  const Eigen::Matrix<double, 3, 2> T = vertex_weights(rest.B);
  Vec<9> g;
  for (int v = 0; v < 3; ++v) g.segment<3>(3 * v) = T(v, 0) * P.col(0) + T(v, 1) * P.col(1);
  return g;
}

Mat<9> strain_limit_hessian(const Vec<9>& x, const StrainLimitRest& rest, const StrainLimitSettings& s) {
  const Barrier psi(s);
  const Spectrum sp = spectrum(deformation_gradient(x, rest.B));
  if (!psi.admissible(sp.lambda1)) return Mat<9>::Constant(kNaN);
  if (!psi.active(sp.lambda1)) return Mat<9>::Zero();

  const Eigen::Matrix2d S = psi.d1(sp.lambda1) * sp.v1 * sp.v1.transpose() +
                            psi.d1(sp.lambda2) * sp.v2 * sp.v2.transpose();
  const Vec3 u1 = sp.F * sp.v1, u2 = sp.F * sp.v2;
  Vec6 a1, a2, c;
  a1 << 2.0 * sp.v1[0] * u1, 2.0 * sp.v1[1] * u1;
  a2 << 2.0 * sp.v2[0] * u2, 2.0 * sp.v2[1] * u2;
  c << sp.v1[0] * u2 + sp.v2[0] * u1, sp.v1[1] * u2 + sp.v2[1] * u1;

  Mat6 HF = psi.d2(sp.lambda1) * a1 * a1.transpose() + psi.d2(sp.lambda2) * a2 * a2.transpose() +
            (2.0 * psi.divided_difference(sp.lambda1, sp.lambda2, sp.gap)) * c * c.transpose();
  for (int j = 0; j < 2; ++j)
    for (int l = 0; l < 2; ++l) HF.block<3, 3>(3 * j, 3 * l).diagonal().array() += 2.0 * S(j, l);
  HF *= s.stiffness * rest.area;

  // H = Tx HF Tx^T with Tx (9x6) = dvec(F)/dx transposed: block (v, j) = T(v, j) I3.
  const Eigen::Matrix<double, 3, 2> T = vertex_weights(rest.B);
  Mat96 Tx = Mat96::Zero();
  for (int v = 0; v < 3; ++v)
    for (int j = 0; j < 2; ++j) Tx.block<3, 3>(3 * v, 3 * j).diagonal().setConstant(T(v, j));
  Mat<9> H = Tx * HF * Tx.transpose();
  return 0.5 * (H + H.transpose());  // exact symmetry for the projection's Cholesky test
}

double strain_limit_step(const Vec<9>& x, const Vec<9>& dx, const StrainLimitRest& rest, double limit) {
  // Stretch at x + alpha dx, formed as the caller's trial point is (x + alpha dx entry by entry),
  // so that the admissibility test here sees the same rounding as value() at the trial.
  auto stretch_at = [&](double alpha) {
    const Vec<9> xa = x + alpha * dx;
    return sigma_max_of(deformation_gradient(xa, rest.B));
  };
  if (!(stretch_at(0.0) < limit)) return 0.0;
  if (stretch_at(1.0) < limit) return 1.0;
  // Convex in alpha (see the header): [0, alpha*) admissible, lo admissible, hi not.
  double lo = 0.0, hi = 1.0;
  for (int it = 0; it < 200 && (lo == 0.0 || hi - lo > 1e-6 * lo); ++it) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;  // interval exhausted at double precision
    (stretch_at(mid) < limit ? lo : hi) = mid;
  }
  return kStrainLimitStepSafety * lo;
}

StrainLimitTerm::StrainLimitTerm(const Faces& faces, const Positions& rest,
                                 const StrainLimitSettings& settings)
    : settings_(resolve_strain_limit_settings(settings)) {
  min_dofs_ = build_triangle_rest("StrainLimitTerm", faces, rest, strain_limit_rest, faces_, rest_);
}

void StrainLimitTerm::set_stiffness(double stiffness) {
  StrainLimitSettings s = settings_;
  s.stiffness = stiffness;
  check_strain_limit_settings(s);
  settings_ = s;
}

void StrainLimitTerm::check_size(const Eigen::VectorXd& x) const {
  if (x.size() < min_dofs_)
    throw std::invalid_argument("StrainLimitTerm: x is shorter than the faces' vertex indices need");
}

Vec<9> StrainLimitTerm::gather(const Eigen::VectorXd& x, int face) const {
  Vec<9> xe;
  for (int k = 0; k < 3; ++k) xe.segment<3>(3 * k) = x.segment<3>(3 * faces_[face][k]);
  return xe;
}

double StrainLimitTerm::value(const Eigen::VectorXd& x) const {
  check_size(x);
  double total = 0.0;
  for (int f = 0; f < num_faces(); ++f) {
    const double ef = strain_limit_energy(gather(x, f), rest_[f], settings_);
    if (ef == kInf) return ef;  // over the limit: reject the step
    total += ef;
  }
  return total;
}

void StrainLimitTerm::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  check_size(x);
  if (grad.size() != x.size())
    throw std::invalid_argument("StrainLimitTerm::add_gradient: grad and x differ in size");
  for (int f = 0; f < num_faces(); ++f) {
    const Vec<9> g = strain_limit_gradient(gather(x, f), rest_[f], settings_);
    for (int k = 0; k < 3; ++k) grad.segment<3>(3 * faces_[f][k]) += g.segment<3>(3 * k);
  }
}

void StrainLimitTerm::add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                                  HessianAssembly& hessian) const {
  check_size(x);
  for (int f = 0; f < num_faces(); ++f) {
    const Mat<9> H = strain_limit_hessian(gather(x, f), rest_[f], settings_);
    // Inactive elements are exactly zero: skip the projection's factorization for them.
    hessian.add<3>(faces_[f], H.isZero(0.0) ? H : project_hessian<9>(H, projection));
  }
}

double StrainLimitTerm::max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const {
  check_size(x);
  if (dx.size() != x.size())
    throw std::invalid_argument("StrainLimitTerm::max_step: dx and x differ in size");
  double alpha = 1.0;
  for (int f = 0; f < num_faces() && alpha > 0.0; ++f)
    alpha = std::min(alpha, strain_limit_step(gather(x, f), gather(dx, f), rest_[f], settings_.limit));
  return alpha;
}

double StrainLimitTerm::max_stretch(const Eigen::VectorXd& x) const {
  check_size(x);
  double m = 0.0;
  for (int f = 0; f < num_faces(); ++f)
    m = std::max(m, sigma_max_of(deformation_gradient(gather(x, f), rest_[f].B)));
  return m;
}

int StrainLimitTerm::first_violating_triangle(const Eigen::VectorXd& x) const {
  check_size(x);
  for (int f = 0; f < num_faces(); ++f)
    if (!(sigma_max_of(deformation_gradient(gather(x, f), rest_[f].B)) < settings_.limit)) return f;
  return -1;
}

}  // namespace pd
