// Squared distances between contact primitives: classification, per-type closed forms, scatter.
// Conventions and the classification rule are documented in distance.h.
//
// Derivations. Every per-type function is written in a few relative vectors and then pulled back to
// the vertex positions with a constant selector matrix J of +-I blocks: g = J^T g_loc,
// H = J^T H_loc J (the relative vectors are linear in the positions, so no further terms).
//
// Point-line, relative vectors r = p - e0, e = e1 - e0, s = (r.e)/(e.e) the foot parameter and
// q = r - s e (foot to point):
//   d = |r x e|^2 / |e|^2 = r.r - (r.e)^2/(e.e)
//   d_r = 2 q,  d_e = -2 s q
//   d_rr = 2 (I - e e^T / e.e),  d_re = -2 (s I + e (r - 2 s e)^T / e.e),
//   d_ee = 2 s^2 I - 2 (r - 2 s e)(r - 2 s e)^T / e.e
// (the cross-product form of d is used for the value: r.r - (r.e)^2/e.e cancels catastrophically
// when the point is close to the line).
//
// Point-plane and line-line share one function of (r, u, v), n = u x v, a = n.r, b = n.n:
//   phi = a^2 / b,   point-plane: r = p - t0, u = t1 - t0, v = t2 - t0;
//                    line-line:   r = ea0 - eb0, u = ea1 - ea0, v = eb1 - eb0.
// First in (r, n):
//   phi_r = (2a/b) n,  phi_n = (2a/b) (r - (a/b) n)
//   phi_rr = (2/b) n n^T,  phi_rn = (2/b)(n r^T + a I) - (4a/b^2) n n^T
//   phi_nn = (2/b) r r^T - (4a/b^2)(r n^T + n r^T) - (2a^2/b^2) I + (8a^2/b^3) n n^T
// then through n(u, v) = u x v, dn/du = -[v]x, dn/dv = [u]x ([w]x w' = w x w'), whose second
// derivative contributes sum_k phi_n,k d2 n_k / du dv = -[phi_n]x to the (u, v) block.
#include "physics/contact/distance.h"

#include <Eigen/Geometry>

namespace pd {
namespace {

// Selector from K vertex positions (3K entries) to R relative vectors (3R entries): relative vector
// i is vertex plus[i] minus vertex minus[i].
template <int R, int K>
Eigen::Matrix<double, 3 * R, 3 * K> selector(const int (&plus)[R], const int (&minus)[R]) {
  Eigen::Matrix<double, 3 * R, 3 * K> J = Eigen::Matrix<double, 3 * R, 3 * K>::Zero();
  for (int i = 0; i < R; ++i) {
    J.template block<3, 3>(3 * i, 3 * plus[i]) = Mat3::Identity();
    if (minus[i] >= 0) J.template block<3, 3>(3 * i, 3 * minus[i]) = -Mat3::Identity();
  }
  return J;
}

// ---- point-line in local (r, e) ----
struct PointLineLocal {
  Vec<6> g;
  Mat<6> H;
};
PointLineLocal point_line_local(const Vec3& r, const Vec3& e) {
  const double ee = e.squaredNorm();
  const double s = r.dot(e) / ee;
  const Vec3 q = r - s * e;
  const Vec3 w = r - 2 * s * e;
  const Mat3 I = Mat3::Identity();
  PointLineLocal out;
  out.g << 2 * q, -2 * s * q;
  out.H.block<3, 3>(0, 0) = 2 * (I - e * e.transpose() / ee);
  out.H.block<3, 3>(0, 3) = -2 * (s * I + e * w.transpose() / ee);
  out.H.block<3, 3>(3, 0) = out.H.block<3, 3>(0, 3).transpose();
  out.H.block<3, 3>(3, 3) = 2 * s * s * I - 2 * w * w.transpose() / ee;
  return out;
}
// (p, e0, e1) -> (r, e) = (p - e0, e1 - e0). Function-local statics: built on first use, so safe
// even if called during another translation unit's static initialisation.
const Eigen::Matrix<double, 6, 9>& point_line_J() {
  static const Eigen::Matrix<double, 6, 9> J = selector<2, 3>({0, 2}, {1, 1});
  return J;
}

// ---- plane-like phi(r, u, v) = ((u x v).r)^2 / |u x v|^2 in local (r, u, v) ----
struct PlaneLocal {
  Vec<9> g;
  Mat<9> H;
};
PlaneLocal plane_local(const Vec3& r, const Vec3& u, const Vec3& v) {
  const Vec3 n = u.cross(v);
  const double a = n.dot(r), b = n.squaredNorm();
  const Vec3 phi_n = (2 * a / b) * (r - (a / b) * n);
  const Mat3 I = Mat3::Identity();
  const Mat3 nn = n * n.transpose(), rn = r * n.transpose();
  const Mat3 phi_rr = (2 / b) * nn;
  const Mat3 phi_rn = (2 / b) * (rn.transpose() + a * I) - (4 * a / (b * b)) * nn;
  const Mat3 phi_nn = (2 / b) * r * r.transpose() - (4 * a / (b * b)) * (rn + rn.transpose()) -
                      (2 * a * a / (b * b)) * I + (8 * a * a / (b * b * b)) * nn;
  Eigen::Matrix<double, 3, 6> Jn;  // dn/d(u, v)
  Jn << -cross_matrix(v), cross_matrix(u);
  PlaneLocal out;
  out.g << (2 * a / b) * n, Jn.transpose() * phi_n;
  out.H.block<3, 3>(0, 0) = phi_rr;
  out.H.block<3, 6>(0, 3) = phi_rn * Jn;
  out.H.block<6, 3>(3, 0) = out.H.block<3, 6>(0, 3).transpose();
  Mat<6> Huv = Jn.transpose() * phi_nn * Jn;
  Huv.block<3, 3>(0, 3) -= cross_matrix(phi_n);
  Huv.block<3, 3>(3, 0) += cross_matrix(phi_n);
  out.H.block<6, 6>(3, 3) = Huv;
  return out;
}
// (p, t0, t1, t2) -> (p - t0, t1 - t0, t2 - t0)
const Eigen::Matrix<double, 9, 12>& point_plane_J() {
  static const Eigen::Matrix<double, 9, 12> J = selector<3, 4>({0, 2, 3}, {1, 1, 1});
  return J;
}
// (ea0, ea1, eb0, eb1) -> (ea0 - eb0, ea1 - ea0, eb1 - eb0)
const Eigen::Matrix<double, 9, 12>& line_line_J() {
  static const Eigen::Matrix<double, 9, 12> J = selector<3, 4>({0, 1, 3}, {2, 0, 2});
  return J;
}

// ---- classification helpers ----

// Closest point of segment (a, b) to p: squared distance and where it lies (0: a, 1: interior,
// 2: b). A zero-length segment gives num = 0, hence its endpoint a.
struct SegmentHit {
  double d2;
  int where;
};
SegmentHit point_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 e = b - a;
  const double num = (p - a).dot(e), ee = e.squaredNorm();
  if (num <= 0) return {(p - a).squaredNorm(), 0};
  if (num >= ee) return {(p - b).squaredNorm(), 2};
  return {(p - a - (num / ee) * e).squaredNorm(), 1};
}

bool not_parallel(const Vec3& u, const Vec3& v) {
  // Also false for a zero vector (0 > 0 fails), which sends degenerate input to the boundary cases.
  return u.cross(v).squaredNorm() > kParallelSin2Threshold * u.squaredNorm() * v.squaredNorm();
}

// Which per-type function a type uses, and on which vertex blocks of the 12-vector (in the order of
// that function's arguments).
enum class Kind { PointPoint, PointLine, PointPlane, LineLine };
struct Stencil {
  Kind kind;
  int v[4];
};

Stencil stencil(PointTriangleType type) {
  switch (type) {
    case PointTriangleType::P_T0: return {Kind::PointPoint, {0, 1, -1, -1}};
    case PointTriangleType::P_T1: return {Kind::PointPoint, {0, 2, -1, -1}};
    case PointTriangleType::P_T2: return {Kind::PointPoint, {0, 3, -1, -1}};
    case PointTriangleType::P_E0: return {Kind::PointLine, {0, 1, 2, -1}};
    case PointTriangleType::P_E1: return {Kind::PointLine, {0, 2, 3, -1}};
    case PointTriangleType::P_E2: return {Kind::PointLine, {0, 3, 1, -1}};
    case PointTriangleType::P_T: break;
  }
  return {Kind::PointPlane, {0, 1, 2, 3}};
}

Stencil stencil(EdgeEdgeType type) {
  switch (type) {
    case EdgeEdgeType::EA0_EB0: return {Kind::PointPoint, {0, 2, -1, -1}};
    case EdgeEdgeType::EA0_EB1: return {Kind::PointPoint, {0, 3, -1, -1}};
    case EdgeEdgeType::EA1_EB0: return {Kind::PointPoint, {1, 2, -1, -1}};
    case EdgeEdgeType::EA1_EB1: return {Kind::PointPoint, {1, 3, -1, -1}};
    case EdgeEdgeType::EA_EB0: return {Kind::PointLine, {2, 0, 1, -1}};
    case EdgeEdgeType::EA_EB1: return {Kind::PointLine, {3, 0, 1, -1}};
    case EdgeEdgeType::EA0_EB: return {Kind::PointLine, {0, 2, 3, -1}};
    case EdgeEdgeType::EA1_EB: return {Kind::PointLine, {1, 2, 3, -1}};
    case EdgeEdgeType::EA_EB: break;
  }
  return {Kind::LineLine, {0, 1, 2, 3}};
}

// Copies K vertex blocks of a per-type derivative into the 12-vector / 12x12 (blocks are distinct).
template <int K>
void scatter(const Vec<3 * K>& g_loc, const int* v, Vec<12>& g) {
  for (int i = 0; i < K; ++i) g.segment<3>(3 * v[i]) = g_loc.template segment<3>(3 * i);
}
template <int K>
void scatter(const Mat<3 * K>& H_loc, const int* v, Mat<12>& H) {
  for (int i = 0; i < K; ++i)
    for (int j = 0; j < K; ++j)
      H.block<3, 3>(3 * v[i], 3 * v[j]) = H_loc.template block<3, 3>(3 * i, 3 * j);
}

Vec3 block(const Vec<12>& x, int i) { return x.segment<3>(3 * i); }

double value(const Vec<12>& x, const Stencil& s) {
  const int* v = s.v;
  switch (s.kind) {
    case Kind::PointPoint: return point_point_squared_distance(block(x, v[0]), block(x, v[1]));
    case Kind::PointLine:
      return point_line_squared_distance(block(x, v[0]), block(x, v[1]), block(x, v[2]));
    case Kind::PointPlane:
      return point_plane_squared_distance(block(x, 0), block(x, 1), block(x, 2), block(x, 3));
    case Kind::LineLine: break;
  }
  return line_line_squared_distance(block(x, 0), block(x, 1), block(x, 2), block(x, 3));
}

Vec<12> gradient(const Vec<12>& x, const Stencil& s) {
  const int* v = s.v;
  Vec<12> g = Vec<12>::Zero();
  switch (s.kind) {
    case Kind::PointPoint:
      scatter<2>(point_point_squared_distance_gradient(block(x, v[0]), block(x, v[1])), v, g);
      break;
    case Kind::PointLine:
      scatter<3>(point_line_squared_distance_gradient(block(x, v[0]), block(x, v[1]), block(x, v[2])),
                 v, g);
      break;
    case Kind::PointPlane:
      g = point_plane_squared_distance_gradient(block(x, 0), block(x, 1), block(x, 2), block(x, 3));
      break;
    case Kind::LineLine:
      g = line_line_squared_distance_gradient(block(x, 0), block(x, 1), block(x, 2), block(x, 3));
      break;
  }
  return g;
}

Mat<12> hessian(const Vec<12>& x, const Stencil& s) {
  const int* v = s.v;
  Mat<12> H = Mat<12>::Zero();
  switch (s.kind) {
    case Kind::PointPoint:
      scatter<2>(point_point_squared_distance_hessian(block(x, v[0]), block(x, v[1])), v, H);
      break;
    case Kind::PointLine:
      scatter<3>(point_line_squared_distance_hessian(block(x, v[0]), block(x, v[1]), block(x, v[2])),
                 v, H);
      break;
    case Kind::PointPlane:
      H = point_plane_squared_distance_hessian(block(x, 0), block(x, 1), block(x, 2), block(x, 3));
      break;
    case Kind::LineLine:
      H = line_line_squared_distance_hessian(block(x, 0), block(x, 1), block(x, 2), block(x, 3));
      break;
  }
  return H;
}

}  // namespace

// ---- per-type functions ----

double point_point_squared_distance(const Vec3& p, const Vec3& q) { return (p - q).squaredNorm(); }
Vec<6> point_point_squared_distance_gradient(const Vec3& p, const Vec3& q) {
  Vec<6> g;
  g << 2 * (p - q), 2 * (q - p);
  return g;
}
Mat<6> point_point_squared_distance_hessian(const Vec3&, const Vec3&) {
  Mat<6> H;
  const Mat3 I2 = 2 * Mat3::Identity();
  H << I2, -I2, -I2, I2;
  return H;
}

double point_line_squared_distance(const Vec3& p, const Vec3& e0, const Vec3& e1) {
  const Vec3 e = e1 - e0;
  return (p - e0).cross(e).squaredNorm() / e.squaredNorm();
}
Vec<9> point_line_squared_distance_gradient(const Vec3& p, const Vec3& e0, const Vec3& e1) {
  return point_line_J().transpose() * point_line_local(p - e0, e1 - e0).g;
}
Mat<9> point_line_squared_distance_hessian(const Vec3& p, const Vec3& e0, const Vec3& e1) {
  return point_line_J().transpose() * point_line_local(p - e0, e1 - e0).H * point_line_J();
}

double point_plane_squared_distance(const Vec3& p, const Vec3& t0, const Vec3& t1, const Vec3& t2) {
  const Vec3 n = (t1 - t0).cross(t2 - t0);
  const double a = n.dot(p - t0);
  return a * a / n.squaredNorm();
}
Vec<12> point_plane_squared_distance_gradient(const Vec3& p, const Vec3& t0, const Vec3& t1,
                                              const Vec3& t2) {
  return point_plane_J().transpose() * plane_local(p - t0, t1 - t0, t2 - t0).g;
}
Mat<12> point_plane_squared_distance_hessian(const Vec3& p, const Vec3& t0, const Vec3& t1,
                                             const Vec3& t2) {
  return point_plane_J().transpose() * plane_local(p - t0, t1 - t0, t2 - t0).H * point_plane_J();
}

double line_line_squared_distance(const Vec3& ea0, const Vec3& ea1, const Vec3& eb0, const Vec3& eb1) {
  const Vec3 n = (ea1 - ea0).cross(eb1 - eb0);
  const double a = n.dot(ea0 - eb0);
  return a * a / n.squaredNorm();
}
Vec<12> line_line_squared_distance_gradient(const Vec3& ea0, const Vec3& ea1, const Vec3& eb0,
                                            const Vec3& eb1) {
  return line_line_J().transpose() * plane_local(ea0 - eb0, ea1 - ea0, eb1 - eb0).g;
}
Mat<12> line_line_squared_distance_hessian(const Vec3& ea0, const Vec3& ea1, const Vec3& eb0,
                                           const Vec3& eb1) {
  return line_line_J().transpose() * plane_local(ea0 - eb0, ea1 - ea0, eb1 - eb0).H * line_line_J();
}

// ---- classification ----

PointTriangleType point_triangle_type(const Vec3& p, const Vec3& t0, const Vec3& t1, const Vec3& t2) {
  const Vec3 t[3] = {t0, t1, t2};
  const Vec3 u = t1 - t0, v = t2 - t0;
  if (not_parallel(u, v)) {
    // The projection of p lies in the triangle iff p is on the inner side of all three edges,
    // measured against the triangle normal (>= 0: on an edge counts as inside; both formulas agree
    // there).
    const Vec3 n = u.cross(v);
    bool inside = true;
    for (int i = 0; i < 3 && inside; ++i) {
      const Vec3& a = t[i];
      inside = (t[(i + 1) % 3] - a).cross(p - a).dot(n) >= 0;
    }
    if (inside) return PointTriangleType::P_T;
  }
  static constexpr PointTriangleType kVertex[3] = {PointTriangleType::P_T0, PointTriangleType::P_T1,
                                                   PointTriangleType::P_T2};
  static constexpr PointTriangleType kEdge[3] = {PointTriangleType::P_E0, PointTriangleType::P_E1,
                                                 PointTriangleType::P_E2};
  double best = 0;
  PointTriangleType type = PointTriangleType::P_T0;
  for (int i = 0; i < 3; ++i) {
    const SegmentHit h = point_segment(p, t[i], t[(i + 1) % 3]);
    if (i > 0 && !(h.d2 < best)) continue;
    best = h.d2;
    type = h.where == 0 ? kVertex[i] : h.where == 2 ? kVertex[(i + 1) % 3] : kEdge[i];
  }
  return type;
}

EdgeEdgeType edge_edge_type(const Vec3& ea0, const Vec3& ea1, const Vec3& eb0, const Vec3& eb1) {
  using T = EdgeEdgeType;
  const Vec3 u = ea1 - ea0, v = eb1 - eb0, w = ea0 - eb0;
  if (not_parallel(u, v)) {
    // Parameters of the closest points ea0 + s u, eb0 + t v of the two lines. The usual
    // (b e - c d) / (a c - b^2) is rewritten with Lagrange's identity as cross products, which stay
    // accurate when the edges are nearly parallel (a c - b^2 cancels there).
    const Vec3 n = u.cross(v);
    const double nn = n.squaredNorm();
    const double s = n.dot(v.cross(w)) / nn, t = n.dot(u.cross(w)) / nn;
    if (s > 0 && s < 1 && t > 0 && t < 1) return T::EA_EB;
  }
  // Boundary of the parameter square: each endpoint against the other segment.
  struct Candidate {
    SegmentHit hit;
    T type[3];  // by hit.where
  };
  const Candidate c[4] = {
      {point_segment(ea0, eb0, eb1), {T::EA0_EB0, T::EA0_EB, T::EA0_EB1}},
      {point_segment(ea1, eb0, eb1), {T::EA1_EB0, T::EA1_EB, T::EA1_EB1}},
      {point_segment(eb0, ea0, ea1), {T::EA0_EB0, T::EA_EB0, T::EA1_EB0}},
      {point_segment(eb1, ea0, ea1), {T::EA0_EB1, T::EA_EB1, T::EA1_EB1}},
  };
  int best = 0;
  for (int i = 1; i < 4; ++i)
    if (c[i].hit.d2 < c[best].hit.d2) best = i;
  return c[best].type[c[best].hit.where];
}

PointTriangleType point_triangle_type(const Vec<12>& x) {
  return point_triangle_type(block(x, 0), block(x, 1), block(x, 2), block(x, 3));
}
EdgeEdgeType edge_edge_type(const Vec<12>& x) {
  return edge_edge_type(block(x, 0), block(x, 1), block(x, 2), block(x, 3));
}

const char* to_string(PointTriangleType type) {
  static constexpr const char* kNames[] = {"P_T0", "P_T1", "P_T2", "P_E0", "P_E1", "P_E2", "P_T"};
  return kNames[static_cast<int>(type)];
}
const char* to_string(EdgeEdgeType type) {
  static constexpr const char* kNames[] = {"EA0_EB0", "EA0_EB1", "EA1_EB0", "EA1_EB1", "EA_EB0",
                                           "EA_EB1",  "EA0_EB",  "EA1_EB",  "EA_EB"};
  return kNames[static_cast<int>(type)];
}

// ---- typed and auto-typed ----

double point_triangle_squared_distance(const Vec<12>& x, PointTriangleType type) {
  return value(x, stencil(type));
}
Vec<12> point_triangle_squared_distance_gradient(const Vec<12>& x, PointTriangleType type) {
  return gradient(x, stencil(type));
}
Mat<12> point_triangle_squared_distance_hessian(const Vec<12>& x, PointTriangleType type) {
  return hessian(x, stencil(type));
}
double edge_edge_squared_distance(const Vec<12>& x, EdgeEdgeType type) {
  return value(x, stencil(type));
}
Vec<12> edge_edge_squared_distance_gradient(const Vec<12>& x, EdgeEdgeType type) {
  return gradient(x, stencil(type));
}
Mat<12> edge_edge_squared_distance_hessian(const Vec<12>& x, EdgeEdgeType type) {
  return hessian(x, stencil(type));
}

double point_triangle_squared_distance(const Vec<12>& x) {
  return point_triangle_squared_distance(x, point_triangle_type(x));
}
Vec<12> point_triangle_squared_distance_gradient(const Vec<12>& x) {
  return point_triangle_squared_distance_gradient(x, point_triangle_type(x));
}
Mat<12> point_triangle_squared_distance_hessian(const Vec<12>& x) {
  return point_triangle_squared_distance_hessian(x, point_triangle_type(x));
}
double edge_edge_squared_distance(const Vec<12>& x) {
  return edge_edge_squared_distance(x, edge_edge_type(x));
}
Vec<12> edge_edge_squared_distance_gradient(const Vec<12>& x) {
  return edge_edge_squared_distance_gradient(x, edge_edge_type(x));
}
Mat<12> edge_edge_squared_distance_hessian(const Vec<12>& x) {
  return edge_edge_squared_distance_hessian(x, edge_edge_type(x));
}

}  // namespace pd
