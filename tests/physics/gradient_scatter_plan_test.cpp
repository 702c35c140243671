#include "physics/gradient_scatter_plan.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <stdexcept>
#include <vector>

#include "geometry/mesh.h"
#include "physics/element_loops.h"
#include "util/parallel.h"

namespace pd {
namespace {

// Elements of 3 vertices over 0..n-1 drawn at random (vertices repeat across elements; vertex n - 1
// may be in none), so that each vertex collects contributions from several elements in no pattern.
std::vector<std::array<int, 3>> random_triangles(int count, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, n - 2);
  std::vector<std::array<int, 3>> tris(static_cast<size_t>(count));
  for (auto& t : tris) {
    t[0] = pick(rng);
    do t[1] = pick(rng); while (t[1] == t[0]);
    do t[2] = pick(rng); while (t[2] == t[0] || t[2] == t[1]);
  }
  return tris;
}

TEST(GradientScatterPlan, ListsEachVertexsSlotsInElementOrder) {
  const std::vector<std::array<int, 3>> tris = {{4, 1, 2}, {2, 4, 0}, {1, 2, 4}};
  const auto plan = GradientScatterPlan::build<3>(3, [&](int e) { return tris[static_cast<size_t>(e)]; });
  EXPECT_EQ(plan.elements(), 3);
  ASSERT_EQ(plan.vertices(), 4);  // vertex 3 is in no element
  const std::vector<int> vertices = {0, 1, 2, 4};
  const std::vector<std::vector<int>> slots = {{5}, {1, 6}, {2, 3, 7}, {0, 4, 8}};  // 3 e + a
  for (int k = 0; k < plan.vertices(); ++k) {
    EXPECT_EQ(plan.vertex(k), vertices[static_cast<size_t>(k)]);
    std::vector<int> got;
    for (int i = plan.slot_begin(k); i < plan.slot_begin(k + 1); ++i) got.push_back(plan.slot(i));
    EXPECT_EQ(got, slots[static_cast<size_t>(k)]) << "vertex " << plan.vertex(k);
  }
}

// The per-vertex scatter adds each vertex's contributions in the serial scatter's order, so the
// gradient is byte for byte the serial one on any thread count (the elements are many enough that
// parallel_for_index splits them: 4000 > 2 x 256).
TEST(GradientScatterPlan, ScatterGivesTheSerialBitsOnOneTwoAndThreeThreads) {
  const int n = 900, count = 4000;
  const auto tris = random_triangles(count, n, 7);
  const auto verts = [&](int e) { return tris[static_cast<size_t>(e)]; };
  // Element gradients of mixed magnitudes, so that a different summation order changes the bits.
  const auto gradient = [&](int e) {
    Vec<9> g;
    for (int i = 0; i < 9; ++i) g[i] = std::sin(1.3 * e + 0.7 * i) * std::pow(10.0, (e * 7 + i) % 9 - 4);
    return g;
  };
  const Eigen::VectorXd start = Eigen::VectorXd::LinSpaced(3 * n, -1.0, 1.0);
  Eigen::VectorXd serial = start;
  const int saved = element_threads();
  set_element_threads(1);
  add_element_gradients<3>(count, verts, gradient, serial);

  const auto plan = GradientScatterPlan::build<3>(count, verts);
  for (int threads : {1, 2, 3}) {  // 1: the serial scatter the overload keeps; 2, 3: the plan's
    set_element_threads(threads);
    Eigen::VectorXd planned = start;
    add_element_gradients<3>(count, verts, gradient, plan, planned);
    EXPECT_EQ(std::memcmp(planned.data(), serial.data(), sizeof(double) * static_cast<size_t>(serial.size())), 0)
        << threads << " threads";
  }
  set_element_threads(saved);
  EXPECT_EQ(serial[3 * (n - 1)], start[3 * (n - 1)]);  // the vertex in no element is untouched
  EXPECT_NE(serial, start);
}

TEST(GradientScatterPlan, RefusesAPlanBuiltForAnotherElementCount) {
  const auto tris = random_triangles(10, 8, 3);
  const auto plan = GradientScatterPlan::build<3>(10, [&](int e) { return tris[static_cast<size_t>(e)]; });
  Eigen::VectorXd grad = Eigen::VectorXd::Zero(24);
  const auto verts = [&](int e) { return tris[static_cast<size_t>(e)]; };
  EXPECT_THROW(add_element_gradients<3>(9, verts, [](int) { return Vec<9>::Zero().eval(); }, plan, grad),
               std::logic_error);
}

}  // namespace
}  // namespace pd
