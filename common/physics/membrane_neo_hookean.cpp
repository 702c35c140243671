#include "physics/membrane_neo_hookean.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

#include "physics/element_loops.h"
#include "physics/lanes.h"
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

// A symmetric 2x2 matrix [[xx, xy], [xy, yy]] of T: double, or Lanes for two triangles at once
// (physics/lanes.h: each lane gets the bits of the double code). Written out entry by entry in the
// order Eigen's 2x2 expressions take, so the bits are those of the Matrix2d code this replaced.
template <class T>
struct Sym2 {
  T xx, xy, yy;
};
template <class T>
T determinant(const Sym2<T>& m) {
  return m.xx * m.yy - m.xy * m.xy;
}
// tr(X Y) for symmetric X and Y.
template <class T>
T trace_of_product(const Sym2<T>& X, const Sym2<T>& Y) {
  return X.xx * Y.xx + 2.0 * X.xy * Y.xy + X.yy * Y.yy;
}
Eigen::Matrix2d to_matrix(const Sym2<double>& m) { return (Eigen::Matrix2d() << m.xx, m.xy, m.xy, m.yy).finished(); }

// A triangle's rest metric abar (m^2), its inverse B (1/m^2) and its area (m^2); one or two triangles.
template <class T>
struct Rest {
  Sym2<T> abar, abar_inv;
  T area;
};
Rest<double> rest_of(const MembraneRest& r) {
  return {{r.abar(0, 0), r.abar(0, 1), r.abar(1, 1)}, {r.abar_inv(0, 0), r.abar_inv(0, 1), r.abar_inv(1, 1)}, r.area};
}
Rest<Lanes> rest_pair(const MembraneRest& r0, const MembraneRest& r1) {
  const auto pair = [](double a, double b) { return Lanes{a, b}; };
  return {{pair(r0.abar(0, 0), r1.abar(0, 0)), pair(r0.abar(0, 1), r1.abar(0, 1)), pair(r0.abar(1, 1), r1.abar(1, 1))},
          {pair(r0.abar_inv(0, 0), r1.abar_inv(0, 0)), pair(r0.abar_inv(0, 1), r1.abar_inv(0, 1)),
           pair(r0.abar_inv(1, 1), r1.abar_inv(1, 1))},
          pair(r0.area, r1.area)};
}

// Deformed metric quantities of one triangle (or two), from its edges e1 = x1 - x0, e2 = x2 - x0.
template <class T>
struct Metric {
  T det_a;        // det a = |e1 x e2|^2: free of the cancellation in a00 a11 - a01^2 for slivers, m^4
  Sym2<T> a;      // e^T e, m^2
  Sym2<T> a_inv;  // 1/m^2
  T tr_Bda;       // tr(abar^{-1} (a - abar)) = tr M - 2, free of cancellation
  T det_Bda;      // det(abar^{-1} (a - abar))
  T s;            // det M - 1 = tr_Bda + det_Bda
  T log_det_M{};  // L = ln det M = ln(det a / det abar), set per lane by log_det_M below
};
template <class T>
Metric<T> metric_of(const V3<T>& e1, const V3<T>& e2, const Rest<T>& rest) {
  Metric<T> m;
  const V3<T> n = cross(e1, e2);
  m.det_a = dot(n, n);
  m.a = {dot(e1, e1), dot(e1, e2), dot(e2, e2)};
  m.a_inv = {m.a.yy / m.det_a, -m.a.xy / m.det_a, m.a.xx / m.det_a};
  // Near rest, det M = 1 + s with s = tr(B da) + det(B da), da = a - abar, B = abar^{-1} (exact for
  // 2x2), and log1p(s) keeps the strain's digits; far from rest (s < -1/2, collapsing triangles) the
  // product form is the accurate one (log_det_M).
  const Sym2<T> da{m.a.xx - rest.abar.xx, m.a.xy - rest.abar.xy, m.a.yy - rest.abar.yy};
  m.tr_Bda = trace_of_product(rest.abar_inv, da);
  m.det_Bda = determinant(rest.abar_inv) * (da.xx * da.yy - da.xy * da.xy);
  m.s = m.tr_Bda + m.det_Bda;
  return m;
}
// Whether lane l's deformed triangle has a metric: zero-area (degenerate) or non-finite ones do not,
// ln det M is undefined there. Sets lane l of m.log_det_M when it does.
template <class T>
bool log_det_M(Metric<T>& m, const Rest<T>& rest, int l) {
  const double det_a = lane(m.det_a, l), s = lane(m.s, l);
  if (!(det_a > 0.0) || !std::isfinite(det_a)) return false;
  set_lane(m.log_det_M, l, s > -0.5 ? std::log1p(s) : std::log(det_a * lane(determinant(rest.abar_inv), l)));
  return true;
}

// The metric of the triangle with stacked vertices x (x0, x1, x2); false where it has none.
bool deformed_metric(const Vec<9>& x, const MembraneRest& rest, Metric<double>& m) {
  const Rest<double> r = rest_of(rest);
  m = metric_of(vertex_at(x, 1) - vertex_at(x, 0), vertex_at(x, 2) - vertex_at(x, 0), r);
  return log_det_M(m, r, 0);
}

// s - log1p(s) >= 0 without cancellation: a series for small |s| (truncation below 1e-16 relative),
// the direct form otherwise (its relative error is ~1e-16 / |s| there).
constexpr double kSeriesBelow = 1e-2;
template <class T>
T s_minus_log1p_series(const T& s) {
  T term = s * s, sum{};
  for (int k = 2; k <= 9; ++k, term *= -s) sum += term / static_cast<double>(k);
  return sum;
}
double s_minus_log1p(double s) { return std::abs(s) < kSeriesBelow ? s_minus_log1p_series(s) : s - std::log1p(s); }

// tr M - 2 - ln det M, written so that no O(1) terms cancel: with s = det M - 1,
//   tr M - 2 - ln det M = (tr_Bda - s) + (s - log1p(s)) = -det_Bda + (s - log1p(s)).
// The naive form loses ~1e-16 absolute, i.e. all digits of a 1e-8 strain energy; for stiff shells
// (metal plates, E ~ 1e11) that noise hides the energy decrease of Newton steps and stalls the line
// search away from equilibrium (see the strip-cantilever test).
double deviatoric_part(double s, double det_Bda, double tr_Bda, double L) {
  return s > -0.5 ? -det_Bda + s_minus_log1p(s) : tr_Bda - L;
}
double deviatoric_part(const Metric<double>& m) { return deviatoric_part(m.s, m.det_Bda, m.tr_Bda, m.log_det_M); }
Lanes deviatoric_part(const Metric<Lanes>& m) {
  if (std::abs(m.s[0]) < kSeriesBelow && std::abs(m.s[1]) < kSeriesBelow)  // the usual case, in both lanes at once
    return -m.det_Bda + s_minus_log1p_series(m.s);
  Lanes dev;
  for (int l = 0; l < 2; ++l) dev[l] = deviatoric_part(m.s[l], m.det_Bda[l], m.tr_Bda[l], m.log_det_M[l]);
  return dev;
}

// S = mu B + c A with c = lambda L / 2 - mu (see the derivation above).
template <class T>
T stress_coefficient(const Metric<T>& m, const MembraneMaterialParams& p) {
  return 0.5 * p.lambda * m.log_det_M - p.mu;
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The element energy (J) from its metric.
template <class T>
T energy_from_metric(const Metric<T>& m, const Rest<T>& rest, const MembraneMaterialParams& p) {
  const T& L = m.log_det_M;
  const T W = 0.5 * p.mu * deviatoric_part(m) + 0.125 * p.lambda * L * L;
  return p.thickness * rest.area * W;
}

// The stress S (1/m^2) from the metric.
template <class T>
Sym2<T> stress_of(const Metric<T>& m, const Rest<T>& rest, const MembraneMaterialParams& p) {
  const T c = stress_coefficient(m, p);
  return {p.mu * rest.abar_inv.xx + c * m.a_inv.xx, p.mu * rest.abar_inv.xy + c * m.a_inv.xy,
          p.mu * rest.abar_inv.yy + c * m.a_inv.yy};
}

// The element gradient (N) from the stress S and the edge matrix e: d energy / d e = h A e S.
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
  Metric<double> m;
  if (!deformed_metric(x, rest, m)) return std::numeric_limits<double>::infinity();
  return energy_from_metric(m, rest_of(rest), p);
}

Vec<9> neo_hookean_membrane_gradient(const Vec<9>& x, const MembraneRest& rest,
                                     const MembraneMaterialParams& p) {
  Metric<double> m;
  if (!deformed_metric(x, rest, m)) return Vec<9>::Constant(kNaN);
  return gradient_from_stress(edge_matrix(x), to_matrix(stress_of(m, rest_of(rest), p)), rest, p);
}

Mat<9> neo_hookean_membrane_hessian(const Vec<9>& x, const MembraneRest& rest,
                                    const MembraneMaterialParams& p) {
  Metric<double> m;
  if (!deformed_metric(x, rest, m)) return Mat<9>::Constant(kNaN);
  const Mat32 e = edge_matrix(x);
  const double c = stress_coefficient(m, p);
  const Eigen::Matrix2d S = to_matrix(stress_of(m, rest_of(rest), p));
  const Eigen::Matrix2d A = to_matrix(m.a_inv);
  const Mat32 G = e * A;                          // 1/m
  const Mat3 Pi = G * e.transpose();              // projector onto the deformed triangle's plane
  const double hA = p.thickness * rest.area;

  // Edge-space blocks d^2 E / (d e_i d e_j), 3x3 each, N/m.
  Mat3 blk[2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      blk[i][j].noalias() = p.lambda * G.col(i) * G.col(j).transpose();
      blk[i][j].noalias() -= c * G.col(j) * G.col(i).transpose();
      blk[i][j] -= (c * A(i, j)) * Pi;
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
// value() takes two faces per pass (physics/lanes.h), with the bits of the one-face functions (an odd
// last face fills both lanes), and keeps each face's stress for a gradient at the same x
// (util/state_key.h); a degenerate face keeps NaN, so that its gradient is NaN as
// neo_hookean_membrane_gradient's is.
double NeoHookeanMembrane::value(const Eigen::VectorXd& x) const {
  check_size(x);
  if (stress_key_.matches(x)) return total_;  // a second value() at the same x (frame statistics)
  stress_key_.clear();
  stress_.resize(faces_.size());
  // A degenerate face gives +inf, and so does the sum (energies are >= 0): the step is rejected.
  total_ = sum_element_energy_pairs(num_faces(), [&](int f, int m, double* out) {
    const std::array<int, 3>& v0 = faces_[static_cast<size_t>(f)];
    const std::array<int, 3>& v1 = faces_[static_cast<size_t>(f + m - 1)];
    const auto at = [&](int k) { return vertex_pair(x, v0[static_cast<size_t>(k)], v1[static_cast<size_t>(k)]); };
    const Rest<Lanes> rest = rest_pair(rest_[f], rest_[f + m - 1]);
    Metric<Lanes> metric = metric_of(at(1) - at(0), at(2) - at(0), rest);
    bool valid[2];
    for (int l = 0; l < 2; ++l) valid[l] = log_det_M(metric, rest, l);
    const Lanes energy = energy_from_metric(metric, rest, params_);
    const Sym2<Lanes> S = stress_of(metric, rest, params_);
    for (int l = 0; l < m; ++l) {
      Eigen::Matrix2d& stress = stress_[static_cast<size_t>(f + l)];
      if (!valid[l]) {
        stress.setConstant(kNaN);
        out[l] = std::numeric_limits<double>::infinity();
        continue;
      }
      stress << S.xx[l], S.xy[l], S.xy[l], S.yy[l];
      out[l] = energy[l];
    }
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
