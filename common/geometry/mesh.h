#pragma once
// Triangle meshes and the position conventions every part of the library shares.
//
// Conventions (used everywhere, stated once here):
// - Positions are in metres, one row per vertex: V(i, k) is coordinate k of vertex i (0-based).
// - Faces hold 0-based vertex indices, counter-clockwise seen from the side the normal points to.
// - The solver's degrees of freedom are positions stacked per vertex: x[3*i + k] = V(i, k).
//   Positions is row-major so that a Positions block and the stacked vector share one memory layout.
#include <Eigen/Core>

namespace pd {

using Positions = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using Faces = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
template <int N> using Vec = Eigen::Matrix<double, N, 1>;
template <int N> using Mat = Eigen::Matrix<double, N, N>;

struct TriMesh {
  Positions V;  // (n, 3) vertex positions, metres
  Faces F;      // (m, 3) triangles, 0-based
  int num_vertices() const { return static_cast<int>(V.rows()); }
  int num_faces() const { return static_cast<int>(F.rows()); }
};

// The cross-product matrix: cross_matrix(v) * u == v.cross(u).
inline Mat3 cross_matrix(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(),
       v.z(), 0.0, -v.x(),
       -v.y(), v.x(), 0.0;
  return m;
}

// View of the stacked vector x (size 3n) as (n, 3) rows, and back, without copying.
inline Eigen::Map<const Positions> as_rows(const Eigen::VectorXd& x) {
  return Eigen::Map<const Positions>(x.data(), x.size() / 3, 3);
}
inline Eigen::VectorXd stacked(const Positions& V) {
  return Eigen::Map<const Eigen::VectorXd>(V.data(), V.size());
}

}  // namespace pd
