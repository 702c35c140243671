#include "physics/bending_hinge.h"

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <cmath>
#include <stdexcept>
#include <string>

#include "physics/element_loops.h"

namespace pd {

namespace {

// Wings whose doubled area |n| is below this fraction of |e|^2 count as degenerate (see header).
constexpr double kDegenerateRatio = 1e-12;

// The hinge in relative coordinates: everything is measured from x0, so that
//   e = x1 - x0 (edge), a = x2 - x0 (wing 1), b = x3 - x0 (wing 2),
//   n1 = e x a, n2 = b x e (face normals, length = twice the triangle area).
struct HingeFrame {
  Vec3 e, a, b, n1, n2;
  double len;  // |e|
  bool degenerate;

  explicit HingeFrame(const Vec<12>& x) {
    const Vec3 x0 = x.segment<3>(0);
    e = x.segment<3>(3) - x0;
    a = x.segment<3>(6) - x0;
    b = x.segment<3>(9) - x0;
    n1 = e.cross(a);
    n2 = b.cross(e);
    len = e.norm();
    // |n| > tol compared squared (no square roots); tol^2 underflows only for |e| < 1e-70 m.
    const double tol = kDegenerateRatio * len * len, tol2 = tol * tol;
    degenerate = !(n1.squaredNorm() > tol2 && n2.squaredNorm() > tol2);  // also true for len == 0 or NaN input
  }
};

// Both wings are handled by one function of the edge e and the wing vector c:
//   F(e, c) = -|e| N / |N|^2,  N = e x c  (the frame's n1 for c = a, -n2 for c = b: passed in, not
//   recomputed; the negation is exact, so the bits are those of computing e x b).
// dtheta/da = F(e, a) (moving x2 along n1 folds the hinge towards its normals: theta decreases),
// and since n2 = -(e x b), dtheta/db = -F(e, b).
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
double angle_of(const HingeFrame& f) {
  if (f.degenerate) return 0.0;
  // (n1 x n2) is parallel to e; its signed length along e^ is the sine part.
  const double sine_part = f.n1.cross(f.n2).dot(f.e) / f.len;
  return std::atan2(sine_part, f.n1.dot(f.n2));
}

// Relative-coordinate gradient (G_e, G_a, G_b) mapped back to the vertices:
// x1 moves only e, x2 only a, x3 only b, and x0 moves all three with a minus sign.
Vec<12> angle_gradient_of(const HingeFrame& f) {
  Vec<12> g = Vec<12>::Zero();
  if (f.degenerate) return g;
  const double len2 = f.len * f.len;
  const Vec3 Ga = wing_gradient(f.len, f.n1);
  const Vec3 Gb = -wing_gradient(f.len, -f.n2);
  const double alpha1 = f.a.dot(f.e) / len2, alpha2 = f.b.dot(f.e) / len2;
  const Vec3 Ge = -alpha1 * Ga - alpha2 * Gb;
  g.segment<3>(0) = -(Ge + Ga + Gb);
  g.segment<3>(3) = Ge;
  g.segment<3>(6) = Ga;
  g.segment<3>(9) = Gb;
  return g;
}

// Hessian in the relative coordinates y = (e, a, b), blocks Hy[i][j] (i, j = 0: e, 1: a, 2: b):
//   H_aa = dF/dc(e, a),   H_bb = -dF/dc(e, b),   H_ab = 0 (each wing gradient ignores the other wing)
//   H_ae = dF/de(e, a),   H_be = -dF/de(e, b),   H_ea = H_ae^T, H_eb = H_be^T
//   H_ee = d/de [ -alpha1 F(e, a) + alpha2 F(e, b) ]
//        = -F(e,a) dalpha1^T - alpha1 dF/de(e,a) + F(e,b) dalpha2^T + alpha2 dF/de(e,b).
// Then H_x = J^T Hy J for the constant map y = J x (e = x1 - x0, a = x2 - x0, b = x3 - x0):
// block (p, q) for p, q >= 1 is Hy[p-1][q-1]; row/column 0 collects minus the sums.
Mat<12> angle_hessian_of(const HingeFrame& f) {
  Mat<12> H = Mat<12>::Zero();
  if (f.degenerate) return H;
  const double len2 = f.len * f.len;

  const Vec3 Na = f.n1, Nb = -f.n2;  // e x a, e x b
  const Vec3 Fa = wing_gradient(f.len, Na);
  const Vec3 Fb = wing_gradient(f.len, Nb);
  Mat3 Fa_c, Fa_e, Fb_c, Fb_e;
  wing_derivatives(f.e, f.len, f.a, Na, Fa_c, Fa_e);
  wing_derivatives(f.e, f.len, f.b, Nb, Fb_c, Fb_e);
  const double alpha1 = f.a.dot(f.e) / len2, alpha2 = f.b.dot(f.e) / len2;

  Mat3 Hy[3][3];
  Hy[1][1] = Fa_c;
  Hy[2][2] = -Fb_c;
  Hy[1][2] = Hy[2][1] = Mat3::Zero();
  Hy[1][0] = Fa_e;
  Hy[2][0] = -Fb_e;
  Hy[0][1] = Fa_e.transpose();
  Hy[0][2] = -Fb_e.transpose();
  Hy[0][0] = -Fa * alpha_gradient(f.e, len2, f.a).transpose() - alpha1 * Fa_e +
             Fb * alpha_gradient(f.e, len2, f.b).transpose() + alpha2 * Fb_e;

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

// The bending energy and its gradient from the hinge's angle theta (and, for the gradient, its frame).
double energy_of(double theta, const HingeRest& rest, double k) {
  const double d = theta - rest.theta_bar;
  return k * rest.weight * d * d;
}
Vec<12> gradient_of(const HingeFrame& f, double theta, const HingeRest& rest, double k) {
  return (2.0 * k * rest.weight * (theta - rest.theta_bar)) * angle_gradient_of(f);
}

}  // namespace

double dihedral_angle(const Vec<12>& x) { return angle_of(HingeFrame(x)); }
Vec<12> dihedral_angle_gradient(const Vec<12>& x) { return angle_gradient_of(HingeFrame(x)); }
Mat<12> dihedral_angle_hessian(const Vec<12>& x) { return angle_hessian_of(HingeFrame(x)); }

HingeRest hinge_rest(const Vec<12>& X) {
  const HingeFrame f(X);
  // |n_i| = 2 A_i, so Abar1 + Abar2 = (|n1| + |n2|) / 2.
  const double area_sum = 0.5 * (f.n1.norm() + f.n2.norm());
  return HingeRest{angle_of(f), f.len * f.len / area_sum};
}

double hinge_bending_energy(const Vec<12>& x, const HingeRest& rest, double k) {
  return energy_of(dihedral_angle(x), rest, k);
}

Vec<12> hinge_bending_gradient(const Vec<12>& x, const HingeRest& rest, double k) {
  const HingeFrame f(x);
  return gradient_of(f, angle_of(f), rest, k);
}

// d^2 E = 2 k w (grad theta grad theta^T + (theta - theta_bar) hess theta).
Mat<12> hinge_bending_hessian(const Vec<12>& x, const HingeRest& rest, double k) {
  const HingeFrame f(x);
  if (f.degenerate) return Mat<12>::Zero();
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
    if (HingeFrame(X).degenerate || !std::isfinite(r.weight))
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
// (physics/element_loops.h).
// value() keeps each hinge's angle for a gradient at the same x (util/state_key.h), and its sum for
// a second value() there (a frame's statistics ask at the state Newton accepted last).
double HingeBending::value(const Eigen::VectorXd& x) const {
  if (angles_key_.matches(x)) return total_;
  angles_key_.clear();
  angles_.resize(hinges_.size());
  total_ = sum_element_energies(static_cast<int>(hinges_.size()), [&](int i) {
    const double theta = angle_of(HingeFrame(gather(x, hinges_[i])));
    angles_[static_cast<size_t>(i)] = theta;
    return energy_of(theta, rest_[i], k_);
  });
  angles_key_.set(x);
  return total_;
}

void HingeBending::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  const bool reuse = angles_key_.matches(x);
  add_element_gradients<4>(
      static_cast<int>(hinges_.size()), [&](int i) { return hinges_[i].v; },
      [&](int i) {
        const HingeFrame f(gather(x, hinges_[i]));
        return gradient_of(f, reuse ? angles_[static_cast<size_t>(i)] : angle_of(f), rest_[i], k_);
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
