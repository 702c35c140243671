#include "physics/bending_hinge.h"

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <cmath>
#include <stdexcept>
#include <string>

#include "physics/element_loops.h"
#include "physics/lanes.h"

namespace pd {

namespace {

// Wings whose doubled area |n| is below this fraction of |e|^2 count as degenerate (see header).
constexpr double kDegenerateRatio = 1e-12;

// The hinge in relative coordinates: everything is measured from x0, so that
//   e = x1 - x0 (edge), a = x2 - x0 (wing 1), b = x3 - x0 (wing 2),
//   n1 = e x a, n2 = b x e (face normals, length = twice the triangle area).
// T is double, or Lanes for two hinges at once (physics/lanes.h: each lane gets the double's bits).
template <class T>
struct HingeFrame {
  V3<T> e, a, b, n1, n2;
  T len;           // |e|
  T n1_sq, n2_sq;  // |n1|^2, |n2|^2
};

template <class T>
HingeFrame<T> hinge_frame(const V3<T>& x0, const V3<T>& x1, const V3<T>& x2, const V3<T>& x3) {
  HingeFrame<T> f;
  f.e = x1 - x0;
  f.a = x2 - x0;
  f.b = x3 - x0;
  f.n1 = cross(f.e, f.a);
  f.n2 = cross(f.b, f.e);
  f.len = sqrt_of(dot(f.e, f.e));
  f.n1_sq = dot(f.n1, f.n1);
  f.n2_sq = dot(f.n2, f.n2);
  return f;
}

HingeFrame<double> hinge_frame(const Vec<12>& x) {
  return hinge_frame(vertex_at(x, 0), vertex_at(x, 1), vertex_at(x, 2), vertex_at(x, 3));
}

// Hinge h0 in lane 0 and hinge h1 in lane 1, from the stacked positions x.
HingeFrame<Lanes> hinge_frame_pair(const Eigen::VectorXd& x, const Hinge& h0, const Hinge& h1) {
  const auto at = [&](int k) { return vertex_pair(x, h0.v[k], h1.v[k]); };
  return hinge_frame(at(0), at(1), at(2), at(3));
}

// Whether a hinge's wings are too thin to have normals (see the header), from its frame's lane l.
bool degenerate(double len, double n1_sq, double n2_sq) {
  // |n| > tol compared squared (no square roots); tol^2 underflows only for |e| < 1e-70 m.
  const double tol = kDegenerateRatio * len * len, tol2 = tol * tol;
  return !(n1_sq > tol2 && n2_sq > tol2);  // also true for len == 0 or NaN input
}
template <class T>
bool degenerate(const HingeFrame<T>& f, int l) {
  return degenerate(lane(f.len, l), lane(f.n1_sq, l), lane(f.n2_sq, l));
}

// Both wings are handled by one function of the edge e and the wing vector c:
//   F(e, c) = -|e| N / |N|^2,  N = e x c  (the frame's n1 for c = a, -n2 for c = b: passed in, not
//   recomputed; the negation is exact, so the bits are those of computing e x b).
// dtheta/da = F(e, a) (moving x2 along n1 folds the hinge towards its normals: theta decreases),
// and since n2 = -(e x b), dtheta/db = -F(e, b). The Hessian's form, on Eigen vectors:
Vec3 wing_gradient(double len, const Vec3& N) {
  return -len / N.squaredNorm() * N;
}

// Derivatives of F(e, c). With s = |N|^2, P = I - 2 N^ N^T (the derivative of N / |N|^2 is P / s):
//   dN = e x dc - c x de,  d|e| = e^ . de
//   dF = -(e^ . de) N / s - (|e| / s) P dN
// so
//   dF/dc = -(|e| / s) P [e]x                    (symmetric: N is orthogonal to e)
//   dF/de = -N e^^T / s + (|e| / s) P [c]x      (e^ = e / |e|)
void wing_derivatives(const Vec3& e, double len, const Vec3& c, const Vec3& N, Mat3& dF_dc, Mat3& dF_de) {
  const double s = N.squaredNorm();
  const Mat3 P = Mat3::Identity() - (2.0 / s) * N * N.transpose();
  dF_dc = (-len / s) * P * cross_matrix(e);
  dF_de = (-1.0 / (s * len)) * N * e.transpose() + (len / s) * P * cross_matrix(c);
}

// alpha(c) = c.e / |e|^2: where the foot of the wing vertex lies along the edge (0 at x0, 1 at x1).
// d alpha / de = c / |e|^2 - 2 (c.e) e / |e|^4.
Vec3 alpha_gradient(const Vec3& e, double len2, const Vec3& c) {
  return c / len2 - (2.0 * c.dot(e) / (len2 * len2)) * e;
}

// The angle and its derivatives from a frame built once per hinge and call (each public function
// below builds one; the bending energy's gradient and Hessian share theirs).
// (n1 x n2) is parallel to e; its signed length along e^ is the sine part, n1 . n2 the cosine part.
template <class T>
T sine_part(const HingeFrame<T>& f) {
  return dot(cross(f.n1, f.n2), f.e) / f.len;
}
template <class T>
T cosine_part(const HingeFrame<T>& f) {
  return dot(f.n1, f.n2);
}
// The angle of lane l (0 for a degenerate hinge), from its frame's sine and cosine parts.
template <class T>
double angle_of(const HingeFrame<T>& f, const T& sine, const T& cosine, int l) {
  return degenerate(f, l) ? 0.0 : std::atan2(lane(sine, l), lane(cosine, l));
}
double angle_of(const HingeFrame<double>& f) { return angle_of(f, sine_part(f), cosine_part(f), 0); }

// Relative-coordinate gradient (G_e, G_a, G_b) mapped back to the vertices:
// x1 moves only e, x2 only a, x3 only b, and x0 moves all three with a minus sign. Per vertex
// (x0, x1, x2, x3); meaningless for a degenerate lane, whose gradient is zero
// (scaled_angle_gradients sees to it).
template <class T>
std::array<V3<T>, 4> angle_gradient_parts(const HingeFrame<T>& f) {
  const T len2 = f.len * f.len;
  const V3<T> Ga = (-f.len / f.n1_sq) * f.n1;  // F(e, a)
  const V3<T> Gb = (-f.len / f.n2_sq) * f.n2;  // -F(e, b), F's two negations cancelled exactly
  const T alpha1 = dot(f.a, f.e) / len2, alpha2 = dot(f.b, f.e) / len2;
  const T minus_alpha1 = -alpha1;
  const V3<T> Ge = minus_alpha1 * Ga - alpha2 * Gb;
  return {-((Ge + Ga) + Gb), Ge, Ga, Gb};
}

// out[l] = factor * dtheta/dx of lane l < m: the gradient of an energy whose derivative in theta is
// factor. A degenerate lane gives factor * 0 (as an exact zero angle gradient scaled by factor would).
template <class T>
void scaled_angle_gradients(const HingeFrame<T>& f, const T& factor, int m, Vec<12>* out) {
  const std::array<V3<T>, 4> parts = angle_gradient_parts(f);
  for (int k = 0; k < 4; ++k) {
    const V3<T> scaled = factor * parts[static_cast<size_t>(k)];
    for (int l = 0; l < m; ++l) {
      const V3<double> p = lane(scaled, l);
      out[l].segment<3>(3 * k) << p.x, p.y, p.z;
    }
  }
  for (int l = 0; l < m; ++l)
    if (degenerate(f, l)) out[l].setConstant(lane(factor, l) * 0.0);
}

Vec<12> angle_gradient_of(const HingeFrame<double>& f) {
  Vec<12> g;
  scaled_angle_gradients(f, 1.0, 1, &g);
  return g;
}

// Hessian in the relative coordinates y = (e, a, b), blocks Hy[i][j] (i, j = 0: e, 1: a, 2: b):
//   H_aa = dF/dc(e, a),   H_bb = -dF/dc(e, b),   H_ab = 0 (each wing gradient ignores the other wing)
//   H_ae = dF/de(e, a),   H_be = -dF/de(e, b),   H_ea = H_ae^T, H_eb = H_be^T
//   H_ee = d/de [ -alpha1 F(e, a) + alpha2 F(e, b) ]
//        = -F(e,a) dalpha1^T - alpha1 dF/de(e,a) + F(e,b) dalpha2^T + alpha2 dF/de(e,b).
// Then H_x = J^T Hy J for the constant map y = J x (e = x1 - x0, a = x2 - x0, b = x3 - x0):
// block (p, q) for p, q >= 1 is Hy[p-1][q-1]; row/column 0 collects minus the sums.
Mat<12> angle_hessian_of(const HingeFrame<double>& frame) {
  Mat<12> H = Mat<12>::Zero();
  if (degenerate(frame, 0)) return H;
  const double len = frame.len, len2 = len * len;
  const Vec3 e = to_eigen(frame.e), a = to_eigen(frame.a), b = to_eigen(frame.b);

  const Vec3 Na = to_eigen(frame.n1), Nb = -to_eigen(frame.n2);  // e x a, e x b
  const Vec3 Fa = wing_gradient(len, Na);
  const Vec3 Fb = wing_gradient(len, Nb);
  Mat3 Fa_c, Fa_e, Fb_c, Fb_e;
  wing_derivatives(e, len, a, Na, Fa_c, Fa_e);
  wing_derivatives(e, len, b, Nb, Fb_c, Fb_e);
  const double alpha1 = a.dot(e) / len2, alpha2 = b.dot(e) / len2;

  Mat3 Hy[3][3];
  Hy[1][1] = Fa_c;
  Hy[2][2] = -Fb_c;
  Hy[1][2] = Hy[2][1] = Mat3::Zero();
  Hy[1][0] = Fa_e;
  Hy[2][0] = -Fb_e;
  Hy[0][1] = Fa_e.transpose();
  Hy[0][2] = -Fb_e.transpose();
  Hy[0][0] = -Fa * alpha_gradient(e, len2, a).transpose() - alpha1 * Fa_e +
             Fb * alpha_gradient(e, len2, b).transpose() + alpha2 * Fb_e;

  Mat3 row_sum[3], total = Mat3::Zero();  // row_sum[j] = sum_i Hy[i][j]
  for (int j = 0; j < 3; ++j) {
    row_sum[j] = Hy[0][j] + Hy[1][j] + Hy[2][j];
    total += row_sum[j];
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) H.block<3, 3>(3 * (i + 1), 3 * (j + 1)) = Hy[i][j];
  for (int j = 0; j < 3; ++j) {
    H.block<3, 3>(0, 3 * (j + 1)) = -row_sum[j];
    H.block<3, 3>(3 * (j + 1), 0) = -row_sum[j].transpose();
  }
  H.block<3, 3>(0, 0) = total;
  // Exact symmetry is analytic; round-off (N only nearly orthogonal to e) breaks it at 1e-16.
  return 0.5 * (H + H.transpose());
}

// The bending energy from the hinge's angle theta, and its derivative in theta.
double energy_of(double theta, const HingeRest& rest, double k) {
  const double d = theta - rest.theta_bar;
  return k * rest.weight * d * d;
}
double energy_slope(double theta, const HingeRest& rest, double k) {
  return 2.0 * k * rest.weight * (theta - rest.theta_bar);
}

}  // namespace

double dihedral_angle(const Vec<12>& x) { return angle_of(hinge_frame(x)); }
Vec<12> dihedral_angle_gradient(const Vec<12>& x) { return angle_gradient_of(hinge_frame(x)); }
Mat<12> dihedral_angle_hessian(const Vec<12>& x) { return angle_hessian_of(hinge_frame(x)); }

HingeRest hinge_rest(const Vec<12>& X) {
  const HingeFrame<double> f = hinge_frame(X);
  // |n_i| = 2 A_i, so Abar1 + Abar2 = (|n1| + |n2|) / 2.
  const double area_sum = 0.5 * (to_eigen(f.n1).norm() + to_eigen(f.n2).norm());
  return HingeRest{angle_of(f), f.len * f.len / area_sum};
}

double hinge_bending_energy(const Vec<12>& x, const HingeRest& rest, double k) {
  return energy_of(dihedral_angle(x), rest, k);
}

Vec<12> hinge_bending_gradient(const Vec<12>& x, const HingeRest& rest, double k) {
  const HingeFrame<double> f = hinge_frame(x);
  Vec<12> g;
  scaled_angle_gradients(f, energy_slope(angle_of(f), rest, k), 1, &g);
  return g;
}

// d^2 E = 2 k w (grad theta grad theta^T + (theta - theta_bar) hess theta).
Mat<12> hinge_bending_hessian(const Vec<12>& x, const HingeRest& rest, double k) {
  const HingeFrame<double> f = hinge_frame(x);
  if (degenerate(f, 0)) return Mat<12>::Zero();
  const double d = angle_of(f) - rest.theta_bar;
  const Vec<12> g = angle_gradient_of(f);
  return (2.0 * k * rest.weight) * (g * g.transpose() + d * angle_hessian_of(f));
}

double hinge_stiffness(double bending_rigidity) { return 0.5 * bending_rigidity; }

HingeBending::HingeBending(const std::vector<Hinge>& hinges, const Positions& rest,
                           double bending_rigidity)
    : hinges_(hinges), k_(hinge_stiffness(bending_rigidity)) {
  rest_.reserve(hinges_.size());
  const int n = static_cast<int>(rest.rows());
  for (size_t i = 0; i < hinges_.size(); ++i) {
    Vec<12> X;
    for (int a = 0; a < 4; ++a) {
      const int v = hinges_[i].v[a];
      if (v < 0 || v >= n)
        throw std::invalid_argument("HingeBending: hinge " + std::to_string(i) + " has vertex " +
                                    std::to_string(v) + " outside the " + std::to_string(n) +
                                    " rest vertices");
      X.segment<3>(3 * a) = rest.row(v).transpose();
    }
    const HingeRest r = hinge_rest(X);
    if (degenerate(hinge_frame(X), 0) || !std::isfinite(r.weight))
      throw std::invalid_argument("HingeBending: hinge " + std::to_string(i) +
                                  " has a degenerate rest triangle");
    rest_.push_back(r);
  }
  scatter_ = GradientScatterPlan::build<4>(static_cast<int>(hinges_.size()), [&](int i) { return hinges_[i].v; });
}

Vec<12> HingeBending::gather(const Eigen::VectorXd& x, const Hinge& h) const {
  Vec<12> xe;
  for (int a = 0; a < 4; ++a) xe.segment<3>(3 * a) = x.segment<3>(3 * h.v[a]);
  return xe;
}

// The three loops run on every element thread with thread-count-independent results
// (physics/element_loops.h); value and gradient take two hinges per pass (physics/lanes.h), with
// the bits of the one-hinge functions above (an odd last hinge fills both lanes).
// value() keeps each hinge's angle for a gradient at the same x (util/state_key.h), and its sum for
// a second value() there (a frame's statistics ask at the state Newton accepted last).
double HingeBending::value(const Eigen::VectorXd& x) const {
  if (angles_key_.matches(x)) return total_;
  angles_key_.clear();
  angles_.resize(hinges_.size());
  total_ = sum_element_energy_pairs(static_cast<int>(hinges_.size()), [&](int i, int m, double* out) {
    const HingeFrame<Lanes> f = hinge_frame_pair(x, hinges_[i], hinges_[i + m - 1]);
    const Lanes sine = sine_part(f), cosine = cosine_part(f);
    for (int l = 0; l < m; ++l) {
      const double theta = angle_of(f, sine, cosine, l);
      angles_[static_cast<size_t>(i + l)] = theta;
      out[l] = energy_of(theta, rest_[i + l], k_);
    }
  });
  angles_key_.set(x);
  return total_;
}

void HingeBending::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  const bool reuse = angles_key_.matches(x);
  add_element_gradient_pairs<4>(
      static_cast<int>(hinges_.size()), [&](int i) { return hinges_[i].v; },
      [&](int i, int m, Vec<12>* out) {
        const HingeFrame<Lanes> f = hinge_frame_pair(x, hinges_[i], hinges_[i + m - 1]);
        Lanes sine{}, cosine{}, slope{};
        if (!reuse) {
          sine = sine_part(f);
          cosine = cosine_part(f);
        }
        for (int l = 0; l < m; ++l) {
          const double theta = reuse ? angles_[static_cast<size_t>(i + l)] : angle_of(f, sine, cosine, l);
          slope[l] = energy_slope(theta, rest_[i + l], k_);
        }
        scaled_angle_gradients(f, slope, m, out);
      },
      scatter_, grad);
}

// Degenerate hinges still add their (zero) block so that the sequence of stencils, and with it the
// sparsity pattern the factorization reuses, does not change when a triangle collapses.
void HingeBending::add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                               HessianAssembly& hessian) const {
  add_element_hessians<4>(
      static_cast<int>(hinges_.size()), [&](int i) { return hinges_[i].v; },
      [&](int i) { return project_hessian<12>(hinge_bending_hessian(gather(x, hinges_[i]), rest_[i], k_), projection); },
      hessian);
}

}  // namespace pd
