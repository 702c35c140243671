#include "physics/bending_midedge_fit.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "physics/bending_hinge.h"
#include "physics/element_loops.h"

namespace pd {

namespace {

using Vec2 = Eigen::Vector2d;

// Eigenvalues of a fit's normal matrix V^T V (coordinates scaled by the edge length) below this
// fraction of the largest count as its null space (points on a conic), see fit_slope_weights.
constexpr double kFitConditioning = 1e-9;

// ---------------------------------------------------------------------------------------------
// Rest data

// Directed edge (a, b) -> the face that traverses it and its local edge (the edge opposite local
// vertex i runs v[i+1] -> v[i+2]).
class DirectedEdges {
 public:
  explicit DirectedEdges(const Faces& F) {
    map_.reserve(static_cast<size_t>(3 * F.rows()));
    for (int f = 0; f < F.rows(); ++f)
      for (int i = 0; i < 3; ++i)
        if (!map_.emplace(key(F(f, (i + 1) % 3), F(f, (i + 2) % 3)), 3 * f + i).second)
          throw std::invalid_argument("MidedgeFitBending: edge (" + std::to_string(F(f, (i + 1) % 3)) + ", " +
                                      std::to_string(F(f, (i + 2) % 3)) +
                                      ") is traversed twice in one direction (non-manifold or inconsistently "
                                      "oriented mesh)");
  }
  // 3 f + i of the face traversing a -> b, or -1.
  int find(int a, int b) const {
    const auto it = map_.find(key(a, b));
    return it == map_.end() ? -1 : it->second;
  }

 private:
  static long long key(int a, int b) { return (static_cast<long long>(a) << 32) | static_cast<unsigned>(b); }
  std::unordered_map<long long, int> map_;
};

// The vertex of the face across the edge a -> b (the face traversing b -> a), or -1 at a boundary.
int across(const Faces& F, const DirectedEdges& edges, int a, int b) {
  const int g = edges.find(b, a);
  return g < 0 ? -1 : F(g / 3, g % 3);
}

// Hinge j's four positions (pd::Hinge order) from the stacked stencil positions x.
Vec<12> hinge_positions(const Vec<36>& x, const MidedgeFitRest& rest, int j) {
  Vec<12> out;
  const auto& slots = rest.hinge[static_cast<size_t>(j)];
  for (int a = 0; a < 4; ++a) out.segment<3>(3 * a) = x.segment<3>(3 * slots[static_cast<size_t>(a)]);
  return out;
}

// Rest stencil of one face under construction: global ids and rest positions unfolded into the
// face's plane (2D, m).
struct RestStencil {
  std::vector<int> ids;
  std::vector<Vec2> at;
  // For each vertex after the face's three: the stencil indices (a, b, c) of the edge it was
  // unfolded across and of the near triangle's third vertex (its hinge is (a, b, c, the vertex)).
  std::vector<std::array<int, 3>> attach;
  int index(int id) const {
    for (size_t k = 0; k < ids.size(); ++k)
      if (ids[k] == id) return static_cast<int>(k);
    return -1;
  }
  // Adds vertex r, unfolded across the (already placed) edge (a, b) to the side away from c:
  // its distances to a and b and its height over their line are those of the rest mesh.
  int add_unfolded(int r, int a, int b, int c, const Positions& X) {
    const int known = index(r);
    if (known >= 0) return known;
    const Vec3 Xa = X.row(a).transpose(), e3 = X.row(b).transpose() - Xa, d3 = X.row(r).transpose() - Xa;
    const double along = d3.dot(e3) / e3.squaredNorm(), height = d3.cross(e3).norm() / e3.norm();
    const Vec2 Pa = at[static_cast<size_t>(index(a))], Pb = at[static_cast<size_t>(index(b))];
    const Vec2 e = Pb - Pa;
    Vec2 side(-e.y(), e.x());
    side.normalize();
    if (side.dot(at[static_cast<size_t>(index(c))] - Pa) > 0.0) side = -side;
    ids.push_back(r);
    at.push_back(Pa + along * e + height * side);
    attach.push_back({index(a), index(b), index(c)});
    return static_cast<int>(ids.size()) - 1;
  }
};

// Weights (1/m) of the normal derivative along n at `mid` of the least-squares quadratic through
// the points `pts` (stencil indices into s.at): s = sum_k weights[k] h_k. A fit whose points lie on a
// conic (two rows of three grid points, say) has a null space; its least-squares solution of least
// norm still gives the derivative exactly when the derivative does not see the null space (the
// conic's slope across the edge is zero at `mid`); false otherwise.
bool fit_slope_weights(const RestStencil& s, const std::vector<int>& pts, const Vec2& mid, const Vec2& n, double scale,
                       std::vector<double>& weights) {
  const int m = static_cast<int>(pts.size());
  Eigen::MatrixXd V(m, 6);
  for (int k = 0; k < m; ++k) {
    const Vec2 u = (s.at[static_cast<size_t>(pts[static_cast<size_t>(k)])] - mid) / scale;
    V.row(k) << 1.0, u.x(), u.y(), u.x() * u.x(), u.x() * u.y(), u.y() * u.y();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(V.transpose() * V);
  Eigen::Matrix<double, 6, 1> slope;
  slope << 0.0, n.x(), n.y(), 0.0, 0.0, 0.0;
  const double top = eig.eigenvalues()[5];
  Eigen::Matrix<double, 6, 1> coeff = Eigen::Matrix<double, 6, 1>::Zero();  // pseudo-inverse applied to slope
  for (int j = 0; j < 6; ++j) {
    const Eigen::Matrix<double, 6, 1> u = eig.eigenvectors().col(j);
    if (eig.eigenvalues()[j] > kFitConditioning * top) {
      coeff += (u.dot(slope) / eig.eigenvalues()[j]) * u;
    } else if (std::abs(u.dot(slope)) > 1e-6) {
      return false;  // the slope depends on what the points cannot tell
    }
  }
  const Eigen::VectorXd w = V * coeff / scale;
  weights.assign(w.data(), w.data() + m);
  return true;
}

// beta's components of the symmetric 2x2 matrix n n^T.
Vec3 outer_as_beta(const Vec2& n) { return Vec3(n.x() * n.x(), n.y() * n.y(), n.x() * n.y()); }

// Plate matrix condensed over the free boundary slopes (columns of G), see the header.
Mat3 condensed_plate_matrix(double area, double D, double nu, const Eigen::Matrix<double, 3, Eigen::Dynamic>& G) {
  Mat3 C;
  C << 1.0, nu, 0.0, nu, 1.0, 0.0, 0.0, 0.0, 2.0 * (1.0 - nu);
  C *= area * D;
  if (G.cols() == 0) return C;
  const Eigen::MatrixXd CG = C * G;
  const Eigen::MatrixXd S = G.transpose() * CG;
  if (G.cols() == 3) return Mat3::Zero();  // a lone triangle: every curvature is free
  const Mat3 out = C - CG * S.ldlt().solve(CG.transpose());
  return 0.5 * (out + out.transpose());
}

// The element of face f (see the header for the construction).
MidedgeFitElement build_element(const Faces& F, const DirectedEdges& edges, const Positions& X, int f, double D,
                                double nu) {
  const int v[3] = {F(f, 0), F(f, 1), F(f, 2)};
  const Vec3 X0 = X.row(v[0]).transpose(), E1 = X.row(v[1]).transpose() - X0, E2 = X.row(v[2]).transpose() - X0;
  const double l1 = E1.norm(), doubled_area = E1.cross(E2).norm();
  if (!(doubled_area > 0.0) || !std::isfinite(doubled_area))
    throw std::invalid_argument("MidedgeFitBending: rest triangle of face " + std::to_string(f) + " has zero area");
  const double area = 0.5 * doubled_area;
  RestStencil s;
  s.ids = {v[0], v[1], v[2]};
  s.at = {Vec2::Zero(), Vec2(l1, 0.0), Vec2(E2.dot(E1) / l1, doubled_area / l1)};

  // Opposite vertices, then the neighbours' further opposite vertices.
  int opposite[3], further[3][2];
  for (int i = 0; i < 3; ++i) {
    const int a = v[(i + 1) % 3], b = v[(i + 2) % 3];
    opposite[i] = across(F, edges, a, b);
    if (opposite[i] >= 0) s.add_unfolded(opposite[i], a, b, v[i], X);
  }
  for (int i = 0; i < 3; ++i) {
    further[i][0] = further[i][1] = -1;
    if (opposite[i] < 0) continue;
    const int a = v[(i + 1) % 3], b = v[(i + 2) % 3], q = opposite[i];  // neighbour runs b -> a -> q
    further[i][0] = across(F, edges, a, q);
    further[i][1] = across(F, edges, q, b);
    if (further[i][0] >= 0) s.add_unfolded(further[i][0], a, q, b, X);
    if (further[i][1] >= 0) s.add_unfolded(further[i][1], q, b, a, X);
  }

  MidedgeFitElement el;
  const int count = static_cast<int>(s.ids.size());
  el.rest.count = count;
  el.v.fill(v[0]);
  for (int k = 0; k < count; ++k) el.v[static_cast<size_t>(k)] = s.ids[static_cast<size_t>(k)];
  // Rh: beta = Rh h for the heights h_k over the face's plane (small slopes).
  Eigen::Matrix<double, 3, kMidedgeFitStencil> Rh = Eigen::Matrix<double, 3, kMidedgeFitStencil>::Zero();
  Eigen::Matrix<double, 3, Eigen::Dynamic> G(3, 0);
  for (int i = 0; i < 3; ++i) {
    const Vec2 Pa = s.at[static_cast<size_t>((i + 1) % 3)], Pb = s.at[static_cast<size_t>((i + 2) % 3)];
    const double len = (Pb - Pa).norm();
    const Vec2 t = (Pb - Pa) / len, n(t.y(), -t.x());  // outward: the face runs counter-clockwise
    const Vec3 per_slope = (len / area) * outer_as_beta(n);
    if (opposite[i] < 0) {
      G.conservativeResize(3, G.cols() + 1);
      G.col(G.cols() - 1) = per_slope;
      continue;
    }
    std::vector<int> pts = {0, 1, 2};
    for (int id : {opposite[0], opposite[1], opposite[2], further[i][0], further[i][1]}) {
      const int k = id < 0 ? -1 : s.index(id);
      if (k >= 0 && std::find(pts.begin(), pts.end(), k) == pts.end()) pts.push_back(k);
    }
    std::vector<double> w;
    if (fit_slope_weights(s, pts, 0.5 * (Pa + Pb), n, len, w)) {
      for (size_t j = 0; j < pts.size(); ++j) Rh.col(pts[j]) += w[j] * per_slope;
    } else {
      // Midedge average: half the slope of the neighbour's plane, the face's own being 0.
      const int k = s.index(opposite[i]);
      const double dist = std::abs((s.at[static_cast<size_t>(k)] - Pa).dot(n));
      Rh.col(k) += (0.5 / dist) * per_slope;
    }
  }
  // Heights from hinge angles (header): vertex k hangs on its hinge and on its near triangle's
  // vertex's hinge, if that is not a face vertex; folding hinge j by theta_j (positive: away from
  // the normals) lowers every point beyond it by its distance from the hinge's line times theta_j.
  el.rest.hinges = count - 3;
  Eigen::Matrix<double, kMidedgeFitStencil, kMidedgeFitStencil - 3> heights_per_angle =
      Eigen::Matrix<double, kMidedgeFitStencil, kMidedgeFitStencil - 3>::Zero();
  for (int k = 3; k < count; ++k) {
    for (int p = k; p >= 3;) {
      const std::array<int, 3>& h = s.attach[static_cast<size_t>(p - 3)];
      const Vec2 Pa = s.at[static_cast<size_t>(h[0])], e = s.at[static_cast<size_t>(h[1])] - Pa;
      Vec2 away(-e.y(), e.x());
      away.normalize();
      if (away.dot(s.at[static_cast<size_t>(p)] - Pa) < 0.0) away = -away;
      heights_per_angle(k, p - 3) = -away.dot(s.at[static_cast<size_t>(k)] - Pa);
      int parent = -1;
      for (int q : h)
        if (q >= 3) parent = q;
      p = parent;
    }
  }
  el.rest.c.setZero();
  el.rest.c.leftCols(count - 3) = Rh * heights_per_angle.leftCols(count - 3);
  for (int j = 0; j < count - 3; ++j) {
    const std::array<int, 3>& h = s.attach[static_cast<size_t>(j)];
    el.rest.hinge[static_cast<size_t>(j)] = {h[0], h[1], h[2], j + 3};
  }
  el.rest.C = condensed_plate_matrix(area, D, nu, G);
  return el;  // theta_bar and beta_bar: midedge_fit_elements, once the hinges have their final order
}

// ---------------------------------------------------------------------------------------------
// Deformed quantities

// The hinges' angles (rad) and beta - beta_bar (1/m).
struct Bending {
  Eigen::Matrix<double, kMidedgeFitStencil - 3, 1> theta;
  Vec3 dbeta;
};

Bending bending_of(const Vec<36>& x, const MidedgeFitRest& rest) {
  Bending b;
  b.theta.setZero();
  for (int j = 0; j < rest.hinges; ++j) b.theta[j] = dihedral_angle(hinge_positions(x, rest, j));
  b.dbeta = rest.c.leftCols(rest.hinges) * (b.theta - rest.theta_bar).head(rest.hinges);
  return b;
}

// out += factor * (hinge j's 12-vector g) on its stencil slots.
void scatter_hinge(const MidedgeFitRest& rest, int j, double factor, const Vec<12>& g, Vec<36>& out) {
  for (int a = 0; a < 4; ++a)
    out.segment<3>(3 * rest.hinge[static_cast<size_t>(j)][static_cast<size_t>(a)]) += factor * g.segment<3>(3 * a);
}

}  // namespace

std::vector<MidedgeFitElement> midedge_fit_elements(const Faces& faces, const Positions& rest, double D, double nu) {
  for (int f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (faces(f, k) < 0 || faces(f, k) >= rest.rows())
        throw std::invalid_argument("MidedgeFitBending: face " + std::to_string(f) +
                                    " has a vertex index outside the rest positions");
  const DirectedEdges edges(faces);
  std::vector<MidedgeFitElement> out;
  out.reserve(static_cast<size_t>(faces.rows()));
  for (int f = 0; f < faces.rows(); ++f) out.push_back(build_element(faces, edges, rest, f, D, nu));
  // Number the hinges (interior edges) in order of first use, and give every face's hinge the
  // vertex order of that first use, so that a hinge's angle gradient is the same 12 numbers in
  // every face that uses it (the term computes it once).
  std::unordered_map<long long, std::array<int, 4>> first;  // edge (min, max) -> global id, then hinge
  std::unordered_map<long long, int> index;
  for (MidedgeFitElement& el : out) {
    el.hinge_id.fill(-1);
    for (int j = 0; j < el.rest.hinges; ++j) {
      auto& slots = el.rest.hinge[static_cast<size_t>(j)];
      std::array<int, 4> ids;
      for (int a = 0; a < 4; ++a) ids[static_cast<size_t>(a)] = el.v[static_cast<size_t>(slots[static_cast<size_t>(a)])];
      const long long key = (static_cast<long long>(std::min(ids[0], ids[1])) << 32) |
                            static_cast<unsigned>(std::max(ids[0], ids[1]));
      const auto [it, added] = index.emplace(key, static_cast<int>(index.size()));
      el.hinge_id[static_cast<size_t>(j)] = it->second;
      if (added) {
        first.emplace(key, ids);
        continue;
      }
      const std::array<int, 4>& canonical = first.at(key);
      for (int a = 0; a < 4; ++a)
        for (int k = 0; k < el.rest.count; ++k)
          if (el.v[static_cast<size_t>(k)] == canonical[static_cast<size_t>(a)]) slots[static_cast<size_t>(a)] = k;
    }
    // The rest angles in that order: the bits the term computes at the rest shape (an angle seen
    // from its other wing agrees only to round-off), so that the rest shape has exactly zero energy.
    Vec<36> Xs;
    for (int k = 0; k < kMidedgeFitStencil; ++k) Xs.segment<3>(3 * k) = rest.row(el.v[static_cast<size_t>(k)]).transpose();
    for (int j = 0; j < el.rest.hinges; ++j) el.rest.theta_bar[j] = dihedral_angle(hinge_positions(Xs, el.rest, j));
    el.rest.beta_bar = midedge_fit_curvature(Xs, el.rest);
  }
  return out;
}

Vec3 midedge_fit_curvature(const Vec<36>& x, const MidedgeFitRest& rest) {
  Vec3 beta = Vec3::Zero();
  for (int j = 0; j < rest.hinges; ++j) beta += rest.c.col(j) * dihedral_angle(hinge_positions(x, rest, j));
  return beta;
}

double midedge_fit_energy(const Vec<36>& x, const MidedgeFitRest& rest) {
  const Vec3 d = bending_of(x, rest).dbeta;
  return 0.5 * d.dot(rest.C * d);
}

// dE = lambda . dbeta, lambda = C (beta - beta_bar), dbeta = sum_j c_j dtheta_j.
Vec<36> midedge_fit_gradient(const Vec<36>& x, const MidedgeFitRest& rest) {
  const Vec3 lambda = rest.C * bending_of(x, rest).dbeta;
  Vec<36> g = Vec<36>::Zero();
  for (int j = 0; j < rest.hinges; ++j)
    scatter_hinge(rest, j, lambda.dot(rest.c.col(j)), dihedral_angle_gradient(hinge_positions(x, rest, j)), g);
  return g;
}

// d2E = Gb C Gb^T + sum_j (lambda . c_j) d2theta_j, Gb's columns d beta_c / dx.
Mat<36> midedge_fit_hessian(const Vec<36>& x, const MidedgeFitRest& rest) {
  const Vec3 lambda = rest.C * bending_of(x, rest).dbeta;
  Eigen::Matrix<double, 36, 3> Gb = Eigen::Matrix<double, 36, 3>::Zero();
  Mat<36> H = Mat<36>::Zero();
  for (int j = 0; j < rest.hinges; ++j) {
    const Vec<12> xj = hinge_positions(x, rest, j);
    const Vec<12> g = dihedral_angle_gradient(xj);
    for (int c = 0; c < 3; ++c) {
      Vec<36> col = Gb.col(c);
      scatter_hinge(rest, j, rest.c(c, j), g, col);
      Gb.col(c) = col;
    }
    const double mu = lambda.dot(rest.c.col(j));
    if (mu == 0.0) continue;
    const Mat<12> Hj = dihedral_angle_hessian(xj);
    const auto& v = rest.hinge[static_cast<size_t>(j)];
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        H.block<3, 3>(3 * v[static_cast<size_t>(a)], 3 * v[static_cast<size_t>(b)]) += mu * Hj.block<3, 3>(3 * a, 3 * b);
  }
  H.noalias() += Gb * rest.C * Gb.transpose();
  return 0.5 * (H + H.transpose());
}

MidedgeFitBending::MidedgeFitBending(const Faces& faces, const Positions& rest, double bending_rigidity,
                                     double poisson_ratio)
    : elements_(midedge_fit_elements(faces, rest, bending_rigidity, poisson_ratio)) {
  // The hinges in global vertex ids, and for each the faces that use it (ascending).
  int count = 0;
  for (const MidedgeFitElement& el : elements_)
    for (int j = 0; j < el.rest.hinges; ++j) count = std::max(count, el.hinge_id[static_cast<size_t>(j)] + 1);
  hinges_.resize(static_cast<size_t>(count));
  std::vector<int> uses(static_cast<size_t>(count) + 1, 0);
  for (const MidedgeFitElement& el : elements_)
    for (int j = 0; j < el.rest.hinges; ++j) {
      const int h = el.hinge_id[static_cast<size_t>(j)];
      for (int a = 0; a < 4; ++a)
        hinges_[static_cast<size_t>(h)].v[static_cast<size_t>(a)] =
            el.v[static_cast<size_t>(el.rest.hinge[static_cast<size_t>(j)][static_cast<size_t>(a)])];
      ++uses[static_cast<size_t>(h) + 1];
    }
  for (int h = 0; h < count; ++h) uses[static_cast<size_t>(h) + 1] += uses[static_cast<size_t>(h)];
  use_begin_ = uses;
  use_.resize(static_cast<size_t>(uses.back()));
  for (int e = 0; e < static_cast<int>(elements_.size()); ++e) {
    const MidedgeFitElement& el = elements_[static_cast<size_t>(e)];
    for (int j = 0; j < el.rest.hinges; ++j)
      use_[static_cast<size_t>(uses[static_cast<size_t>(el.hinge_id[static_cast<size_t>(j)])]++)] = {e, j};
  }
  hinge_scatter_ = GradientScatterPlan::build<4>(count, [&](int h) { return hinges_[static_cast<size_t>(h)].v; });
}

Vec<12> MidedgeFitBending::hinge_at(const Eigen::VectorXd& x, int h) const {
  Vec<12> xe;
  for (int a = 0; a < 4; ++a) xe.segment<3>(3 * a) = x.segment<3>(3 * hinges_[static_cast<size_t>(h)].v[static_cast<size_t>(a)]);
  return xe;
}

std::vector<double> MidedgeFitBending::angles(const Eigen::VectorXd& x) const {
  std::vector<double> theta(hinges_.size());
  parallel_for_index(static_cast<int>(hinges_.size()),
                     [&](int h) { theta[static_cast<size_t>(h)] = dihedral_angle(hinge_at(x, h)); });
  return theta;
}

Vec3 MidedgeFitBending::dbeta(int e, const std::vector<double>& theta) const {
  const MidedgeFitElement& el = elements_[static_cast<size_t>(e)];
  Vec3 d = Vec3::Zero();
  for (int j = 0; j < el.rest.hinges; ++j)
    d += el.rest.c.col(j) *
         (theta[static_cast<size_t>(el.hinge_id[static_cast<size_t>(j)])] - el.rest.theta_bar[j]);
  return d;
}

// Per hinge, sum over the faces that use it of lambda_f . c_fj (lambda = C (beta - beta_bar)): the
// factor of that hinge's angle gradient and Hessian in the energy's. Faces in ascending order.
std::vector<double> MidedgeFitBending::angle_factors(const std::vector<double>& theta) const {
  std::vector<Vec3> lambda(elements_.size());
  parallel_for_index(static_cast<int>(elements_.size()), [&](int e) {
    lambda[static_cast<size_t>(e)] = elements_[static_cast<size_t>(e)].rest.C * dbeta(e, theta);
  });
  std::vector<double> factor(hinges_.size());
  parallel_for_index(static_cast<int>(hinges_.size()), [&](int h) {
    double sum = 0.0;
    for (int u = use_begin_[static_cast<size_t>(h)]; u < use_begin_[static_cast<size_t>(h) + 1]; ++u) {
      const auto [e, j] = use_[static_cast<size_t>(u)];
      sum += lambda[static_cast<size_t>(e)].dot(elements_[static_cast<size_t>(e)].rest.c.col(j));
    }
    factor[static_cast<size_t>(h)] = sum;
  });
  return factor;
}

// The loops run on every element thread with thread-count-independent results
// (physics/element_loops.h): each hinge's and face's numbers in their own slots, summed in order.
double MidedgeFitBending::value(const Eigen::VectorXd& x) const {
  const std::vector<double> theta = angles(x);
  return sum_element_energies(static_cast<int>(elements_.size()), [&](int e) {
    const Vec3 d = dbeta(e, theta);
    return 0.5 * d.dot(elements_[static_cast<size_t>(e)].rest.C * d);
  });
}

// dE = sum_h factor_h dtheta_h.
void MidedgeFitBending::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  const std::vector<double> factor = angle_factors(angles(x));
  add_element_gradients<4>(
      static_cast<int>(hinges_.size()), [&](int h) { return hinges_[static_cast<size_t>(h)].v; },
      [&](int h) { return Vec<12>(factor[static_cast<size_t>(h)] * dihedral_angle_gradient(hinge_at(x, h))); },
      hinge_scatter_, grad);
}

// d2E = sum_f Gb_f C_f Gb_f^T + sum_h factor_h d2theta_h (Gb_f: d beta_f / dx). The face blocks are
// positive semi-definite as they are (C_f is) and go in unprojected; each hinge block is projected
// with project_hessian<12>, as the discrete hinge's are. Degenerate hinges add their zero blocks, so
// the sparsity pattern never changes.
void MidedgeFitBending::add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                                    HessianAssembly& hessian) const {
  const std::vector<double> theta = angles(x);
  std::vector<Vec<12>> gradient(hinges_.size());
  parallel_for_index(static_cast<int>(hinges_.size()), [&](int h) {
    gradient[static_cast<size_t>(h)] = dihedral_angle_gradient(hinge_at(x, h));
  });
  const std::vector<double> factor = angle_factors(theta);
  add_element_hessians<kMidedgeFitStencil>(
      static_cast<int>(elements_.size()), [&](int e) { return elements_[static_cast<size_t>(e)].v; },
      [&](int e) {
        const MidedgeFitElement& el = elements_[static_cast<size_t>(e)];
        Eigen::Matrix<double, 36, 3> Gb = Eigen::Matrix<double, 36, 3>::Zero();
        for (int j = 0; j < el.rest.hinges; ++j) {
          const Vec<12>& g = gradient[static_cast<size_t>(el.hinge_id[static_cast<size_t>(j)])];
          const auto& slots = el.rest.hinge[static_cast<size_t>(j)];
          for (int a = 0; a < 4; ++a)
            Gb.middleRows<3>(3 * slots[static_cast<size_t>(a)]) += g.segment<3>(3 * a) * el.rest.c.col(j).transpose();
        }
        const Eigen::Matrix<double, 36, 3> GC = Gb * el.rest.C;
        return Mat<36>(GC * Gb.transpose());
      },
      hessian);
  add_element_hessians<4>(
      static_cast<int>(hinges_.size()), [&](int h) { return hinges_[static_cast<size_t>(h)].v; },
      [&](int h) {
        const double f = factor[static_cast<size_t>(h)];
        return project_hessian<12>(Mat<12>(f * dihedral_angle_hessian(hinge_at(x, h))), projection);
      },
      hessian);
}

}  // namespace pd
