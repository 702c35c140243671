#pragma once
// The three loops every element energy runs (value, gradient, Hessian), on several threads with
// results independent of the thread count (util/parallel.h's rule): each element's value, gradient
// or Hessian is computed in parallel into its own slot, and the sum, the scatter into the global
// gradient and the assembly add in element order, exactly as the serial loops did (the scatter
// with a GradientScatterPlan does so per vertex, on every thread).
//
// Shapes shared by all three: `count` elements; verts(e) -> std::array<int, N> (the element's
// global vertex indices, its local dofs ordered verts[0] xyz, verts[1] xyz, ...).
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "physics/gradient_scatter_plan.h"
#include "physics/hessian_assembly.h"
#include "util/parallel.h"

namespace pd {

// Sum over e in [0, count) of energy(e) (J), added in element order.
template <class Energy>
double sum_element_energies(int count, const Energy& energy) {
  if (effective_element_threads() == 1) {  // the same sum, without the per-element buffer
    double total = 0.0;
    for (int e = 0; e < count; ++e) total += energy(e);
    return total;
  }
  std::vector<double> values(static_cast<size_t>(count));
  parallel_for_index(count, [&](int e) { values[static_cast<size_t>(e)] = energy(e); });
  double total = 0.0;
  for (double v : values) total += v;
  return total;
}

// The element gradients gradient(e), e in [0, count), each computed into its own slot.
template <int N, class Gradient>
std::vector<Eigen::Matrix<double, 3 * N, 1>> element_gradients(int count, const Gradient& gradient) {
  std::vector<Eigen::Matrix<double, 3 * N, 1>> g(static_cast<size_t>(count));
  parallel_for_index(count, [&](int e) { g[static_cast<size_t>(e)] = gradient(e); });
  return g;
}

// grad += one element's gradient g on its vertices v.
template <int N>
void add_to_vertices(const std::array<int, N>& v, const Eigen::Matrix<double, 3 * N, 1>& g, Eigen::VectorXd& grad) {
  for (int a = 0; a < N; ++a) grad.template segment<3>(3 * v[a]) += g.template segment<3>(3 * a);
}

// grad += the element gradients gradient(e) (Eigen::Matrix<double, 3N, 1>, J/m), scattered in
// element order. On one thread each is added as it comes: the same additions in the same order,
// without the 3N-doubles-per-element buffer (1.7 MB for flag-large's hinges) the threads write into.
template <int N, class Verts, class Gradient>
void add_element_gradients(int count, const Verts& verts, const Gradient& gradient, Eigen::VectorXd& grad) {
  if (effective_element_threads() == 1) {
    for (int e = 0; e < count; ++e) add_to_vertices<N>(verts(e), gradient(e), grad);
    return;
  }
  const auto g = element_gradients<N>(count, gradient);
  for (int e = 0; e < count; ++e) add_to_vertices<N>(verts(e), g[static_cast<size_t>(e)], grad);
}

// grad += the element gradients g, per vertex on every thread: each vertex sums its elements'
// slots in element order (`plan` built for these elements), the bits of a serial scatter.
template <int N>
void scatter_with_plan(const std::vector<Eigen::Matrix<double, 3 * N, 1>>& g, const GradientScatterPlan& plan,
                       Eigen::VectorXd& grad) {
  parallel_for_index(plan.vertices(), [&](int k) {
    auto out = grad.template segment<3>(3 * plan.vertex(k));
    for (int i = plan.slot_begin(k); i < plan.slot_begin(k + 1); ++i) {
      const int s = plan.slot(i);
      out += g[static_cast<size_t>(s / N)].template segment<3>(3 * (s % N));
    }
  });
}

// add_element_gradients with the scatter run per vertex on every thread (same bits as the serial
// scatter; on one thread the serial scatter itself, which takes fewer instructions). `plan` must
// have been built for these `count` elements and `verts` (throws std::logic_error when its element
// count differs).
template <int N, class Verts, class Gradient>
void add_element_gradients(int count, const Verts& verts, const Gradient& gradient, const GradientScatterPlan& plan,
                           Eigen::VectorXd& grad) {
  if (plan.elements() != count)
    throw std::logic_error("add_element_gradients: a scatter plan built for " + std::to_string(plan.elements()) +
                           " elements, used for " + std::to_string(count));
  if (effective_element_threads() == 1) {
    add_element_gradients<N>(count, verts, gradient, grad);
    return;
  }
  scatter_with_plan<N>(element_gradients<N>(count, gradient), plan, grad);
}

// Energies evaluated two elements per pass (physics/lanes.h). pair(e, m, out) computes elements
// e .. e + m - 1 into out[0 .. m), where m = 2, or 1 for the last element of an odd count; it is
// called for e = 0, 2, 4, ... on every element thread and writes only its elements' outputs.

// Sum over the elements of their energies (J), added in element order.
template <class Pair>
double sum_element_energy_pairs(int count, const Pair& pair) {
  const auto size = [count](int e) { return e + 1 < count ? 2 : 1; };
  double total = 0.0;
  if (effective_element_threads() == 1) {
    for (int e = 0; e < count; e += 2) {
      double out[2];
      pair(e, size(e), out);
      for (int l = 0; l < size(e); ++l) total += out[l];
    }
    return total;
  }
  std::vector<double> values(static_cast<size_t>(count));
  parallel_for_index((count + 1) / 2, [&](int p) { pair(2 * p, size(2 * p), values.data() + 2 * p); });
  for (double v : values) total += v;
  return total;
}

// grad += the elements' gradients (J/m), scattered in element order as add_element_gradients does.
template <int N, class Verts, class Pair>
void add_element_gradient_pairs(int count, const Verts& verts, const Pair& pair, const GradientScatterPlan& plan,
                                Eigen::VectorXd& grad) {
  using Gradient = Eigen::Matrix<double, 3 * N, 1>;
  if (plan.elements() != count)
    throw std::logic_error("add_element_gradient_pairs: a scatter plan built for " + std::to_string(plan.elements()) +
                           " elements, used for " + std::to_string(count));
  const auto size = [count](int e) { return e + 1 < count ? 2 : 1; };
  if (effective_element_threads() == 1) {
    for (int e = 0; e < count; e += 2) {
      Gradient out[2];
      pair(e, size(e), out);
      for (int l = 0; l < size(e); ++l) add_to_vertices<N>(verts(e + l), out[l], grad);
    }
    return;
  }
  std::vector<Gradient> g(static_cast<size_t>(count));
  parallel_for_index((count + 1) / 2, [&](int p) { pair(2 * p, size(2 * p), g.data() + 2 * p); });
  scatter_with_plan<N>(g, plan, grad);
}

// Adds the element Hessians hessian(e) (3N x 3N, already projected, J/m^2) to `assembly`, the same
// entries in the same order as `count` calls of HessianAssembly::add.
template <int N, class Verts, class Hessian>
void add_element_hessians(int count, const Verts& verts, const Hessian& hessian, HessianAssembly& assembly) {
  assembly.add_elements<N>(count, verts, hessian);
}

}  // namespace pd
