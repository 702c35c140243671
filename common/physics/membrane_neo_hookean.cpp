#include "physics/membrane_neo_hookean.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

#include "physics/element_loops.h"
#include "physics/triangle_rest.h"

// Derivation (notation of the header; B = abar^{-1}, A = a^{-1}, L = ln det M, all 2x2 symmetric).
//   tr M = tr(B e^T e)             => d(tr M)/de = 2 e B
//   L = ln det a - ln det abar     => dL/de = 2 e A          (d ln det a = tr(A da), da = de^T e + e^T de)
// so the energy density's derivative with respect to the edge matrix is
//   P = dW/de = e S,  S = mu B + c A,  c = lambda L / 2 - mu          (S: 2x2, the "second Piola" stress).
// Second variation in directions de (columns v_j) and de' (columns u_i), with G = e A (columns g_i) and
// the tangent-plane projector Pi = e A e^T:
//   <de', dP[de]> = sum_ij u_i^T [ S_ij I + lambda g_i g_j^T - c (g_j g_i^T + A_ij Pi) ] v_j
// (dS = (lambda/2) dL A + c dA, dL = 2 <G, de>, dA = -A da A). Finally e1 = x1 - x0, e2 = x2 - x0
// gives the vertex gradient (g1, g2) = hA (P.col(0), P.col(1)), g0 = -(g1 + g2), and the 9x9 Hessian
// from the 2x2 grid of 3x3 edge blocks by the same chain rule.

namespace pd {

namespace {

using Mat32 = Eigen::Matrix<double, 3, 2>;

Mat32 edge_matrix(const Vec<9>& x) {
  Mat32 e;
  e.col(0) = x.segment<3>(3) - x.segment<3>(0);
  e.col(1) = x.segment<3>(6) - x.segment<3>(0);
  return e;
}

// Deformed metric quantities of one triangle. Returns false for a degenerate (zero-area) or
// non-finite deformed triangle, where ln det M is undefined.
struct Metric {
  Eigen::Matrix2d a;      // e^T e, m^2
  Eigen::Matrix2d a_inv;  // 1/m^2
  double log_det_M;       // L = ln det M = ln(det a / det abar)
  double tr_Bda;          // tr(abar^{-1} (a - abar)) = tr M - 2, free of cancellation
  double det_Bda;         // det(abar^{-1} (a - abar))
  double det_M_minus_1;   // det M - 1 = tr_Bda + det_Bda
};

// tr(X Y) for symmetric 2x2 X and Y.
double trace_of_product(const Eigen::Matrix2d& X, const Eigen::Matrix2d& Y) {
  return X(0, 0) * Y(0, 0) + 2.0 * X(0, 1) * Y(0, 1) + X(1, 1) * Y(1, 1);
}

bool deformed_metric(const Mat32& e, const MembraneRest& rest, Metric& m) {
  // det a = |e1 x e2|^2: free of the cancellation in a00 a11 - a01^2 for slivers, never negative.
  const double det_a = e.col(0).cross(e.col(1)).squaredNorm();
  if (!(det_a > 0.0) || !std::isfinite(det_a)) return false;
  m.a.noalias() = e.transpose() * e;
  m.a_inv << m.a(1, 1), -m.a(0, 1), -m.a(1, 0), m.a(0, 0);
  m.a_inv /= det_a;
  // ln det M. Near rest, det M = 1 + s with s = tr(B da) + det(B da), da = a - abar, B = abar^{-1}
  // (exact for 2x2), and log1p(s) keeps the strain's digits; far from rest (s < -1/2, collapsing
  // triangles) the product form is the accurate one.
  const Eigen::Matrix2d da = m.a - rest.abar;
  m.tr_Bda = trace_of_product(rest.abar_inv, da);
  m.det_Bda = rest.abar_inv.determinant() * (da(0, 0) * da(1, 1) - da(0, 1) * da(1, 0));
  const double s = m.tr_Bda + m.det_Bda;
  m.log_det_M = s > -0.5 ? std::log1p(s) : std::log(det_a * rest.abar_inv.determinant());
  m.det_M_minus_1 = s;
  return true;
}

// s - log1p(s) >= 0 without cancellation: a series for small |s| (truncation below 1e-16 relative),
// the direct form otherwise (its relative error is ~1e-16 / |s| there).
double s_minus_log1p(double s) {
  if (std::abs(s) < 1e-2) {
    double term = s * s, sum = 0.0;
    for (int k = 2; k <= 9; ++k, term *= -s) sum += term / k;
    return sum;
  }
  return s - std::log1p(s);
}

// S = mu B + c A with c = lambda L / 2 - mu (see the derivation above).
double stress_coefficient(const Metric& m, const MembraneMaterialParams& p) {
  return 0.5 * p.lambda * m.log_det_M - p.mu;
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The element energy (J) from its metric.
double energy_from_metric(const Metric& m, const MembraneRest& rest, const MembraneMaterialParams& p) {
  // tr M - 2 - L, written so that no O(1) terms cancel: with s = det M - 1,
  //   tr M - 2 - ln det M = (tr_Bda - s) + (s - log1p(s)) = -det_Bda + (s - log1p(s)).
  // The naive form loses ~1e-16 absolute, i.e. all digits of a 1e-8 strain energy; for stiff shells
  // (metal plates, E ~ 1e11) that noise hides the energy decrease of Newton steps and stalls the line
  // search away from equilibrium (see the strip-cantilever test).
  const double L = m.log_det_M;
  const double dev = m.det_M_minus_1 > -0.5 ? -m.det_Bda + s_minus_log1p(m.det_M_minus_1)
                                            : m.tr_Bda - L;
  const double W = 0.5 * p.mu * dev + 0.125 * p.lambda * L * L;
  return p.thickness * rest.area * W;
}

// The stress S (1/m^2, symmetric 2x2) from the metric, and the element gradient (N) from S and the
// edge matrix e: d energy / d e = h A e S.
Eigen::Matrix2d stress_from_metric(const Metric& m, const MembraneRest& rest, const MembraneMaterialParams& p) {
  return p.mu * rest.abar_inv + stress_coefficient(m, p) * m.a_inv;
}
Vec<9> gradient_from_stress(const Mat32& e, const Eigen::Matrix2d& S, const MembraneRest& rest,
                            const MembraneMaterialParams& p) {
  const Mat32 P = (p.thickness * rest.area) * (e * S);  // d energy / d e, N
  Vec<9> g;
  g.segment<3>(3) = P.col(0);
  g.segment<3>(6) = P.col(1);
  g.segment<3>(0) = -(P.col(0) + P.col(1));
  return g;
}

}  // namespace

MembraneRest membrane_rest(const Vec3& X0, const Vec3& X1, const Vec3& X2) {
  const Vec3 E1 = X1 - X0, E2 = X2 - X0;
  const double det_abar = E1.cross(E2).squaredNorm();  // = det(E^T E) = (2 * area)^2
  if (!(det_abar > 0.0) || !std::isfinite(det_abar))
    throw std::invalid_argument("membrane_rest: rest triangle has zero area");
  const double e11 = E1.squaredNorm(), e12 = E1.dot(E2), e22 = E2.squaredNorm();
  MembraneRest r;
  r.abar << e11, e12, e12, e22;
  r.abar_inv << e22, -e12, -e12, e11;
  r.abar_inv /= det_abar;
  r.area = 0.5 * std::sqrt(det_abar);
  return r;
}

MembraneMaterialParams MembraneMaterialParams::from(double youngs, double poisson, double thickness) {
  if (!(youngs >= 0.0) || !std::isfinite(youngs))
    throw std::invalid_argument("MembraneMaterialParams: Young's modulus must be finite and >= 0 (Pa)");
  if (!(poisson > -1.0 && poisson < 1.0))
    throw std::invalid_argument("MembraneMaterialParams: Poisson ratio must lie in (-1, 1)");
  if (!(thickness > 0.0) || !std::isfinite(thickness))
    throw std::invalid_argument("MembraneMaterialParams: thickness must be finite and > 0 (m)");
  MembraneMaterialParams p;
  p.mu = youngs / (2.0 * (1.0 + poisson));
  p.lambda = youngs * poisson / (1.0 - poisson * poisson);  // 2D (plane-stress) value, as libshell
  p.thickness = thickness;
  return p;
}

double neo_hookean_membrane_energy(const Vec<9>& x, const MembraneRest& rest,
                                   const MembraneMaterialParams& p) {
  const Mat32 e = edge_matrix(x);
  Metric m;
  if (!deformed_metric(e, rest, m)) return std::numeric_limits<double>::infinity();
  return energy_from_metric(m, rest, p);
}

Vec<9> neo_hookean_membrane_gradient(const Vec<9>& x, const MembraneRest& rest,
                                     const MembraneMaterialParams& p) {
  const Mat32 e = edge_matrix(x);
  Metric m;
  if (!deformed_metric(e, rest, m)) return Vec<9>::Constant(kNaN);
  return gradient_from_stress(e, stress_from_metric(m, rest, p), rest, p);
}

Mat<9> neo_hookean_membrane_hessian(const Vec<9>& x, const MembraneRest& rest,
                                    const MembraneMaterialParams& p) {
  const Mat32 e = edge_matrix(x);
  Metric m;
  if (!deformed_metric(e, rest, m)) return Mat<9>::Constant(kNaN);
  const double c = stress_coefficient(m, p);
  const Eigen::Matrix2d S = p.mu * rest.abar_inv + c * m.a_inv;
  const Mat32 G = e * m.a_inv;                    // 1/m
  const Mat3 Pi = G * e.transpose();              // projector onto the deformed triangle's plane
  const double hA = p.thickness * rest.area;

  // Edge-space blocks d^2 E / (d e_i d e_j), 3x3 each, N/m.
  Mat3 blk[2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      blk[i][j].noalias() = p.lambda * G.col(i) * G.col(j).transpose();
      blk[i][j].noalias() -= c * G.col(j) * G.col(i).transpose();
      blk[i][j] -= (c * m.a_inv(i, j)) * Pi;
      blk[i][j].diagonal().array() += S(i, j);
      blk[i][j] *= hA;
    }

  // Chain rule through e_i = x_{i+1} - x0.
  Mat<9> H;
  Mat3 corner = Mat3::Zero();
  for (int i = 0; i < 2; ++i) {
    const Mat3 row_sum = blk[i][0] + blk[i][1];  // coupling of e_i with x0 (up to sign)
    const Mat3 col_sum = blk[0][i] + blk[1][i];
    H.block<3, 3>(3 + 3 * i, 0) = -row_sum;
    H.block<3, 3>(0, 3 + 3 * i) = -col_sum;
    corner += row_sum;
    for (int j = 0; j < 2; ++j) H.block<3, 3>(3 + 3 * i, 3 + 3 * j) = blk[i][j];
  }
  H.block<3, 3>(0, 0) = corner;
  return H;
}

NeoHookeanMembrane::NeoHookeanMembrane(const Faces& faces, const Positions& rest,
                                       const MembraneMaterialParams& params)
    : params_(params) {
  min_dofs_ = build_triangle_rest("NeoHookeanMembrane", faces, rest, membrane_rest, faces_, rest_);
  scatter_ = GradientScatterPlan::build<3>(num_faces(), [&](int f) { return faces_[static_cast<size_t>(f)]; });
}

void NeoHookeanMembrane::check_size(const Eigen::VectorXd& x) const {
  if (x.size() < min_dofs_)
    throw std::invalid_argument("NeoHookeanMembrane: x is shorter than the faces' vertex indices need");
}

Vec<9> NeoHookeanMembrane::gather(const Eigen::VectorXd& x, int face) const {
  Vec<9> xe;
  for (int k = 0; k < 3; ++k) xe.segment<3>(3 * k) = x.segment<3>(3 * faces_[face][k]);
  return xe;
}

// The three loops run on every element thread with thread-count-independent results
// (physics/element_loops.h).
// value() keeps each face's stress for a gradient at the same x (util/state_key.h); a degenerate
// face keeps NaN, so that its gradient is NaN as neo_hookean_membrane_gradient's is.
double NeoHookeanMembrane::value(const Eigen::VectorXd& x) const {
  check_size(x);
  if (stress_key_.matches(x)) return total_;  // a second value() at the same x (frame statistics)
  stress_key_.clear();
  stress_.resize(faces_.size());
  // A degenerate face gives +inf, and so does the sum (energies are >= 0): the step is rejected.
  total_ = sum_element_energies(num_faces(), [&](int f) {
    Eigen::Matrix2d& S = stress_[static_cast<size_t>(f)];
    Metric m;
    if (!deformed_metric(edge_matrix(gather(x, f)), rest_[f], m)) {
      S.setConstant(kNaN);
      return std::numeric_limits<double>::infinity();
    }
    S = stress_from_metric(m, rest_[f], params_);
    return energy_from_metric(m, rest_[f], params_);
  });
  stress_key_.set(x);
  return total_;
}

void NeoHookeanMembrane::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  check_size(x);
  if (grad.size() != x.size())
    throw std::invalid_argument("NeoHookeanMembrane::add_gradient: grad and x differ in size");
  const bool reuse = stress_key_.matches(x);
  add_element_gradients<3>(
      num_faces(), [&](int f) { return faces_[f]; },
      [&](int f) -> Vec<9> {
        if (!reuse) return neo_hookean_membrane_gradient(gather(x, f), rest_[f], params_);
        const Eigen::Matrix2d& S = stress_[static_cast<size_t>(f)];
        if (std::isnan(S(0, 0))) return Vec<9>::Constant(kNaN);
        return gradient_from_stress(edge_matrix(gather(x, f)), S, rest_[f], params_);
      },
      scatter_, grad);
}

void NeoHookeanMembrane::add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                                     HessianAssembly& hessian) const {
  check_size(x);
  add_element_hessians<3>(
      num_faces(), [&](int f) { return faces_[f]; },
      [&](int f) {
        return project_hessian<9>(neo_hookean_membrane_hessian(gather(x, f), rest_[f], params_), projection);
      },
      hessian);
}

}  // namespace pd
