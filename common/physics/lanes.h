#pragma once
// Two elements per pass: the element loops of the value and gradient evaluate a pair of elements in
// the two lanes of one register.
//
// Why: flag-large's preview spends most of its time in the fine energies' values and gradients
// (docs/performance.md), and their arithmetic is scalar: Eigen cannot vectorize a 3-vector. Two
// elements side by side fill the SSE2 registers every x86-64 machine has (the hinge's value 2.2x and
// gradient 3x faster, bench/element_kernels.cpp).
//
// Same bits. A formula written once as a template of T and instantiated with Lanes performs, in
// each lane, the IEEE operations its double instantiation performs, in the same order, so each lane
// holds the bits the one-element code gives, whichever lane or pair an element falls in and however
// many threads run. Two things keep it so: no fused multiply-add contraction (common/CMakeLists.txt
// builds with -ffp-contract=off; baseline x86-64 has no FMA anyway), and the V3 operations below
// keep Eigen's order for Vector3d (cross as MatrixBase::cross, dot and squaredNorm as (x + y) + z),
// so code moved here from Eigen keeps its bits too. Functions with no lane form (sqrt, atan2, log1p)
// run per lane on doubles.
#include <cmath>

#include <Eigen/Core>

namespace pd {

// Two doubles, operated on lane by lane (GCC's and Clang's vector extension).
using Lanes = double __attribute__((vector_size(16)));

// Lane l (0 or 1) of v; a double is its own only lane.
inline double lane(double v, int) { return v; }
inline double lane(Lanes v, int l) { return v[l]; }

// Sets lane l of v to x.
inline void set_lane(double& v, int, double x) { v = x; }
inline void set_lane(Lanes& v, int l, double x) { v[l] = x; }

inline double sqrt_of(double v) { return std::sqrt(v); }
inline Lanes sqrt_of(Lanes v) { return Lanes{std::sqrt(v[0]), std::sqrt(v[1])}; }

// A 3-vector of T (double or Lanes).
template <class T>
struct V3 {
  T x, y, z;
};

template <class T>
V3<T> operator+(const V3<T>& a, const V3<T>& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class T>
V3<T> operator-(const V3<T>& a, const V3<T>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
V3<T> operator-(const V3<T>& a) {
  return {-a.x, -a.y, -a.z};
}
template <class T>
V3<T> operator*(const T& s, const V3<T>& a) {
  return {s * a.x, s * a.y, s * a.z};
}
template <class T>
V3<T> cross(const V3<T>& a, const V3<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T>
T dot(const V3<T>& a, const V3<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

// Vertex v of stacked positions x (x[3v + k], m: the whole state or one element's vector), as a
// V3<double>.
template <class Vector>
V3<double> vertex_at(const Vector& x, int v) {
  return {x[3 * v], x[3 * v + 1], x[3 * v + 2]};
}

// Vertex v0 in lane 0 and v1 in lane 1.
inline V3<Lanes> vertex_pair(const Eigen::VectorXd& x, int v0, int v1) {
  return {Lanes{x[3 * v0], x[3 * v1]}, Lanes{x[3 * v0 + 1], x[3 * v1 + 1]}, Lanes{x[3 * v0 + 2], x[3 * v1 + 2]}};
}

inline Eigen::Vector3d to_eigen(const V3<double>& a) { return {a.x, a.y, a.z}; }

// Lane l of a as a double vector; a double vector is its own only lane.
inline V3<double> lane(const V3<Lanes>& a, int l) { return {a.x[l], a.y[l], a.z[l]}; }
inline V3<double> lane(const V3<double>& a, int) { return a; }

}  // namespace pd
