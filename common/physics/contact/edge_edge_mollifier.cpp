// Edge-edge mollifier (see edge_edge_mollifier.h).
//
// Derivatives of c = n.n, n = u x v, u = ea1 - ea0, v = eb1 - eb0. With dn/du = -[v]x and
// dn/dv = [u]x ([w]x w' = w x w'):
//   c_u = 2 (dn/du)^T n = 2 v x n,   c_v = 2 (dn/dv)^T n = 2 n x u,
//   c_(u,v)(u,v) = 2 Jn^T Jn + [[0, -[2n]x], [[2n]x, 0]],   Jn = [-[v]x, [u]x],
// the last term being sum_k (dc/dn_k) d2 n_k / du dv (n is bilinear in u, v). These are pulled back
// to (ea0, ea1, eb0, eb1) with u = ea1 - ea0, v = eb1 - eb0. Then the chain rule in c:
//   grad m = m'(c) grad c,   hess m = m''(c) grad c grad c^T + m'(c) hess c.
#include "physics/contact/edge_edge_mollifier.h"

#include <Eigen/Geometry>

namespace pd {
namespace {

Vec3 u_of(const Vec<12>& x) { return x.segment<3>(3) - x.segment<3>(0); }
Vec3 v_of(const Vec<12>& x) { return x.segment<3>(9) - x.segment<3>(6); }

// Pull back a (u, v) gradient to (ea0, ea1, eb0, eb1): d/dea0 = -d/du, d/dea1 = d/du, etc.
Vec<12> pull_back(const Vec<6>& g_uv) {
  Vec<12> g;
  g << -g_uv.head<3>(), g_uv.head<3>(), -g_uv.tail<3>(), g_uv.tail<3>();
  return g;
}
Mat<12> pull_back(const Mat<6>& H_uv) {
  Eigen::Matrix<double, 6, 12> J = Eigen::Matrix<double, 6, 12>::Zero();
  J.block<3, 3>(0, 0) = -Mat3::Identity();
  J.block<3, 3>(0, 3) = Mat3::Identity();
  J.block<3, 3>(3, 6) = -Mat3::Identity();
  J.block<3, 3>(3, 9) = Mat3::Identity();
  return J.transpose() * H_uv * J;
}

}  // namespace

double edge_edge_mollifier_threshold(const Vec3& ea0_rest, const Vec3& ea1_rest, const Vec3& eb0_rest,
                                     const Vec3& eb1_rest) {
  return kEdgeEdgeMollifierScale * (ea1_rest - ea0_rest).squaredNorm() *
         (eb1_rest - eb0_rest).squaredNorm();
}

double edge_edge_cross_squared_norm(const Vec<12>& x) { return u_of(x).cross(v_of(x)).squaredNorm(); }

Vec<12> edge_edge_cross_squared_norm_gradient(const Vec<12>& x) {
  const Vec3 u = u_of(x), v = v_of(x), n = u.cross(v);
  Vec<6> g;
  g << 2 * v.cross(n), 2 * n.cross(u);
  return pull_back(g);
}

Mat<12> edge_edge_cross_squared_norm_hessian(const Vec<12>& x) {
  const Vec3 u = u_of(x), v = v_of(x), n = u.cross(v);
  Eigen::Matrix<double, 3, 6> Jn;
  Jn << -cross_matrix(v), cross_matrix(u);
  Mat<6> H = 2 * Jn.transpose() * Jn;
  H.block<3, 3>(0, 3) -= cross_matrix(2 * n);
  H.block<3, 3>(3, 0) += cross_matrix(2 * n);
  return pull_back(H);
}

double edge_edge_mollifier_of(double c, double eps_x) {
  if (!(c < eps_x)) return 1.0;
  const double r = c / eps_x;
  return (2 - r) * r;  // = -c^2/eps_x^2 + 2 c/eps_x
}
double edge_edge_mollifier_derivative_of(double c, double eps_x) {
  if (!(c < eps_x)) return 0.0;
  return 2 * (1 - c / eps_x) / eps_x;
}
double edge_edge_mollifier_second_derivative_of(double c, double eps_x) {
  if (!(c < eps_x)) return 0.0;
  return -2 / (eps_x * eps_x);
}

bool edge_edge_mollifier_active(const Vec<12>& x, double eps_x) {
  return edge_edge_cross_squared_norm(x) < eps_x;
}

double edge_edge_mollifier(const Vec<12>& x, double eps_x) {
  return edge_edge_mollifier_of(edge_edge_cross_squared_norm(x), eps_x);
}

Vec<12> edge_edge_mollifier_gradient(const Vec<12>& x, double eps_x) {
  const double c = edge_edge_cross_squared_norm(x);
  if (!(c < eps_x)) return Vec<12>::Zero();
  return edge_edge_mollifier_derivative_of(c, eps_x) * edge_edge_cross_squared_norm_gradient(x);
}

Mat<12> edge_edge_mollifier_hessian(const Vec<12>& x, double eps_x) {
  const double c = edge_edge_cross_squared_norm(x);
  if (!(c < eps_x)) return Mat<12>::Zero();
  const Vec<12> gc = edge_edge_cross_squared_norm_gradient(x);
  return edge_edge_mollifier_second_derivative_of(c, eps_x) * gc * gc.transpose() +
         edge_edge_mollifier_derivative_of(c, eps_x) * edge_edge_cross_squared_norm_hessian(x);
}

}  // namespace pd
