#include "physics/pressure.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace pd {

namespace {

Vec3 vertex(const Eigen::VectorXd& x, int i) { return x.segment<3>(3 * i); }

Mat3 skew(const Vec3& a) {  // skew(a) b = a x b
  Mat3 S;
  S << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return S;
}

// Gradient of one triangle's volume x0 . (x1 x x2) / 6 with respect to (x0, x1, x2), m^2.
Vec<9> triangle_volume_gradient(const Vec3& x0, const Vec3& x1, const Vec3& x2) {
  Vec<9> g;
  g << x1.cross(x2), x2.cross(x0), x0.cross(x1);
  return g / 6.0;
}

// Its Hessian, m: d(x_a x x_b)/dx_b = skew(x_a), so block (a, a+1) = -skew(x_{a+2}) / 6 and its
// transpose block (a+1, a) = skew(x_{a+2}) / 6 (indices mod 3); diagonal blocks are zero.
Mat<9> triangle_volume_hessian(const Vec3& x0, const Vec3& x1, const Vec3& x2) {
  const Vec3 p[3] = {x0, x1, x2};
  Mat<9> H = Mat<9>::Zero();
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    H.block<3, 3>(3 * a, 3 * b) = -skew(p[c]) / 6.0;
    H.block<3, 3>(3 * b, 3 * a) = skew(p[c]) / 6.0;
  }
  return H;
}

// q(alpha) = c[0] + c[1] alpha + c[2] alpha^2 + c[3] alpha^3.
double cubic(const double c[4], double a) { return c[0] + a * (c[1] + a * (c[2] + a * c[3])); }

}  // namespace

double enclosed_volume(const Faces& faces, const Eigen::VectorXd& x) {
  double V = 0.0;
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    V += vertex(x, faces(f, 0)).dot(vertex(x, faces(f, 1)).cross(vertex(x, faces(f, 2))));
  return V / 6.0;
}

PressureTerm::PressureTerm(const Faces& faces, const Eigen::VectorXd& initial, const Pressure& params)
    : faces_(faces), params_(params), V0_(enclosed_volume(faces, initial)) {
  if (!(V0_ > 0.0))
    throw std::invalid_argument("pressure: enclosed volume of the initial shape is " +
                                std::to_string(V0_) + " m^3; the shell must be closed and outward-oriented");
}

double PressureTerm::pressure_at(double V) const {
  return params_.model == Pressure::Model::Constant ? params_.pressure : params_.pressure * V0_ / V;
}

double PressureTerm::dU_dV(double V) const { return -pressure_at(V); }

double PressureTerm::d2U_dV2(double V) const {
  return params_.model == Pressure::Model::Constant ? 0.0 : params_.pressure * V0_ / (V * V);
}

double PressureTerm::value(const Eigen::VectorXd& x) const {
  const double V = volume(x);
  if (params_.model == Pressure::Model::Constant) return -params_.pressure * V;
  if (!(V > 0.0)) return std::numeric_limits<double>::infinity();
  return -params_.pressure * V0_ * std::log(V);
}

void PressureTerm::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  // The constant model needs no volume; the ideal gas needs V before any triangle's share.
  const double s = dU_dV(params_.model == Pressure::Model::Constant ? 1.0 : volume(x));
  for (Eigen::Index f = 0; f < faces_.rows(); ++f) {
    const int i0 = faces_(f, 0), i1 = faces_(f, 1), i2 = faces_(f, 2);
    const Vec<9> g = s * triangle_volume_gradient(vertex(x, i0), vertex(x, i1), vertex(x, i2));
    grad.segment<3>(3 * i0) += g.segment<3>(0);
    grad.segment<3>(3 * i1) += g.segment<3>(3);
    grad.segment<3>(3 * i2) += g.segment<3>(6);
  }
}

void PressureTerm::add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                               HessianAssembly& hessian) const {
  const double s = dU_dV(params_.model == Pressure::Model::Constant ? 1.0 : volume(x));
  for (Eigen::Index f = 0; f < faces_.rows(); ++f) {
    const int i0 = faces_(f, 0), i1 = faces_(f, 1), i2 = faces_(f, 2);
    const Mat<9> H = s * triangle_volume_hessian(vertex(x, i0), vertex(x, i1), vertex(x, i2));
    hessian.add<3>({i0, i1, i2}, project_hessian<9>(H, projection));
  }
}

Eigen::MatrixXd PressureTerm::dense_hessian_for_tests(const Eigen::VectorXd& x) const {
  const double V = volume(x);
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(x.size(), x.size());
  Eigen::VectorXd gV = Eigen::VectorXd::Zero(x.size());
  for (Eigen::Index f = 0; f < faces_.rows(); ++f) {
    const int idx[3] = {faces_(f, 0), faces_(f, 1), faces_(f, 2)};
    const Vec3 p0 = vertex(x, idx[0]), p1 = vertex(x, idx[1]), p2 = vertex(x, idx[2]);
    const Mat<9> Hf = triangle_volume_hessian(p0, p1, p2);
    const Vec<9> gf = triangle_volume_gradient(p0, p1, p2);
    for (int a = 0; a < 3; ++a) {
      gV.segment<3>(3 * idx[a]) += gf.segment<3>(3 * a);
      for (int b = 0; b < 3; ++b) H.block<3, 3>(3 * idx[a], 3 * idx[b]) += Hf.block<3, 3>(3 * a, 3 * b);
    }
  }
  return dU_dV(V) * H + d2U_dV2(V) * gV * gV.transpose();
}

double PressureTerm::max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const {
  if (params_.model == Pressure::Model::Constant) return 1.0;
  // V(x + alpha dx) = c0 + c1 alpha + c2 alpha^2 + c3 alpha^3, summed triangle by triangle.
  double c[4] = {0, 0, 0, 0};
  for (Eigen::Index f = 0; f < faces_.rows(); ++f) {
    const int i0 = faces_(f, 0), i1 = faces_(f, 1), i2 = faces_(f, 2);
    const Vec3 x0 = vertex(x, i0), x1 = vertex(x, i1), x2 = vertex(x, i2);
    const Vec3 d0 = vertex(dx, i0), d1 = vertex(dx, i1), d2 = vertex(dx, i2);
    c[0] += x0.dot(x1.cross(x2));
    c[1] += d0.dot(x1.cross(x2)) + x0.dot(d1.cross(x2)) + x0.dot(x1.cross(d2));
    c[2] += x0.dot(d1.cross(d2)) + d0.dot(x1.cross(d2)) + d0.dot(d1.cross(x2));
    c[3] += d0.dot(d1.cross(d2));
  }
  for (double& ci : c) ci /= 6.0;
  if (!(c[0] > 0.0)) return 1.0;  // already inadmissible: nothing left to protect
  c[0] *= 1.0 - kMinVolumeRatio;  // q(alpha) = V(alpha) - kMinVolumeRatio V(0); q(0) > 0

  // Split [0, 1] where q' = c1 + 2 c2 a + 3 c3 a^2 vanishes; q is monotone between the breaks, so the
  // first piece whose right end has q <= 0 holds the first crossing, found by bisection.
  double breaks[4] = {0.0, 1.0, 1.0, 1.0};
  int nb = 1;
  const double A = 3.0 * c[3], B = 2.0 * c[2], C = c[1];
  if (A != 0.0) {
    const double disc = B * B - 4.0 * A * C;
    if (disc >= 0.0) {
      const double r = std::sqrt(disc);
      double a1 = (-B - r) / (2.0 * A), a2 = (-B + r) / (2.0 * A);
      if (a1 > a2) std::swap(a1, a2);
      if (a1 > 0.0 && a1 < 1.0) breaks[nb++] = a1;
      if (a2 > 0.0 && a2 < 1.0) breaks[nb++] = a2;
    }
  } else if (B != 0.0) {
    const double a1 = -C / B;
    if (a1 > 0.0 && a1 < 1.0) breaks[nb++] = a1;
  }
  breaks[nb++] = 1.0;
  for (int k = 1; k < nb; ++k) {
    if (cubic(c, breaks[k]) > 0.0) continue;
    double lo = breaks[k - 1], hi = breaks[k];  // q(lo) > 0 >= q(hi)
    for (int it = 0; it < 60; ++it) {
      const double mid = 0.5 * (lo + hi);
      (cubic(c, mid) > 0.0 ? lo : hi) = mid;
    }
    return lo;
  }
  return 1.0;
}

}  // namespace pd
