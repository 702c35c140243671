#pragma once
// The per-vertex order of an element set's gradient contributions (physics/element_loops.h uses it
// to scatter element gradients on several threads with the serial scatter's bits).
#include <algorithm>
#include <array>
#include <vector>

namespace pd {

// Where each vertex's gradient comes from, for an element set whose vertices do not change (a
// term's faces or hinges): for every vertex some element touches, its slots e * N + a (element e,
// local vertex a) in ascending order. With it the scatter of add_element_gradients runs per vertex
// on every thread and still adds each vertex's contributions in element order, as the serial
// scatter does, so the gradient is the same bit for bit. Built once, with the term.
class GradientScatterPlan {
 public:
  GradientScatterPlan() = default;
  template <int N, class Verts>
  static GradientScatterPlan build(int count, const Verts& verts);

  int elements() const { return elements_; }
  int vertices() const { return static_cast<int>(vertex_.size()); }
  int vertex(int k) const { return vertex_[static_cast<size_t>(k)]; }
  // Slots of the k-th vertex: [slot_begin(k), slot_begin(k + 1)) into slot().
  int slot_begin(int k) const { return begin_[static_cast<size_t>(k)]; }
  int slot(int i) const { return slot_[static_cast<size_t>(i)]; }

 private:
  int elements_ = -1;        // count it was built for (-1: not built)
  std::vector<int> vertex_;  // touched vertices, ascending
  std::vector<int> begin_;   // vertices() + 1 offsets into slot_
  std::vector<int> slot_;    // e * N + a, ascending within each vertex
};

template <int N, class Verts>
GradientScatterPlan GradientScatterPlan::build(int count, const Verts& verts) {
  // A counting sort of the slots by vertex; slots are visited in ascending order, so each vertex's
  // list comes out ascending.
  int max_vertex = -1;
  for (int e = 0; e < count; ++e)
    for (int v : verts(e)) max_vertex = std::max(max_vertex, v);
  std::vector<int> per_vertex(static_cast<size_t>(max_vertex) + 2, 0);
  for (int e = 0; e < count; ++e)
    for (int v : verts(e)) ++per_vertex[static_cast<size_t>(v) + 1];
  GradientScatterPlan plan;
  plan.elements_ = count;
  std::vector<int> first(per_vertex.size(), 0);  // by vertex id: first slot position
  for (size_t v = 0; v + 1 < per_vertex.size(); ++v) {
    first[v + 1] = first[v] + per_vertex[v + 1];
    if (per_vertex[v + 1] > 0) {
      plan.vertex_.push_back(static_cast<int>(v));
      plan.begin_.push_back(first[v]);
    }
  }
  plan.begin_.push_back(first.back());
  plan.slot_.resize(static_cast<size_t>(first.back()));
  for (int e = 0; e < count; ++e) {
    const std::array<int, N> v = verts(e);
    for (int a = 0; a < N; ++a) plan.slot_[static_cast<size_t>(first[static_cast<size_t>(v[a])]++)] = N * e + a;
  }
  return plan;
}

}  // namespace pd
