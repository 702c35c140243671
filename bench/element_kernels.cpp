// Wall time of the fine shell energies' values and gradients, the loops a preview's Newton iterations
// pay on the finest mesh (issue 16: flag-large's preview spends 1.39 of 2.18 s in them on one
// thread). A rectangle of cells_x by cells_y cells (default 100 x 60, flag-large's 6 161 vertices),
// bent and stretched a little so that no term is at rest; each call alternates between two states so
// that no term's per-state cache (util/state_key.h) answers in place of the loop.
//
//   pd_bench_element_kernels                  # 100 x 60 cells, 200 calls each, every core
//   pd_bench_element_kernels --threads 1 --calls 500 --cells 157 157
// Prints microseconds per call for each term and loop ("value", "gradient" after a value at the same
// state, as Newton asks after an accepted line-search trial, and "gradient-cold" at a state no value
// saw) and a hash of every result's bytes: two builds with equal hashes compute the same bits.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "bench_main.h"
#include "geometry/shapes.h"
#include "geometry/topology.h"
#include "physics/bending_hinge.h"
#include "physics/membrane_neo_hookean.h"
#include "util/fnv1a.h"
#include "util/parallel.h"

using namespace pd;

namespace {

// Stacked positions of the rectangle, bent along x by `bend` (rad over the width) and stretched by
// `stretch` along y: a state where membrane and bending both carry energy (m).
Eigen::VectorXd deformed(const TriMesh& mesh, double bend, double stretch) {
  Eigen::VectorXd x(3 * mesh.num_vertices());
  for (int i = 0; i < mesh.num_vertices(); ++i) {
    const double u = mesh.V(i, 0), v = mesh.V(i, 1);
    const double r = 1.0 / bend;
    x.segment<3>(3 * i) << r * std::sin(u / r), (1.0 + stretch) * v, r * (1.0 - std::cos(u / r));
  }
  return x;
}

// Seconds per call of fn over `calls` calls.
double per_call(int calls, const std::function<void(int)>& fn) {
  const auto start = std::chrono::steady_clock::now();
  for (int c = 0; c < calls; ++c) fn(c);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / calls;
}

void report(const std::string& term, const EnergyTerm& energy, const Eigen::VectorXd (&x)[2], int calls, Fnv1a& hash) {
  Eigen::VectorXd g = Eigen::VectorXd::Zero(x[0].size());
  double sum = 0.0;
  const double value = per_call(calls, [&](int c) { sum += energy.value(x[c % 2]); });
  const double warm = per_call(calls, [&](int c) {
    energy.value(x[c % 2]);
    energy.add_gradient(x[c % 2], g);
  }) - value;
  const double cold = per_call(calls, [&](int c) {
    energy.value(x[(c + 1) % 2]);  // the cache now holds the other state
    energy.add_gradient(x[c % 2], g);
  }) - value;
  hash.f64(sum);
  for (Eigen::Index i = 0; i < g.size(); ++i) hash.f64(g[i]);
  std::printf("%-10s value %8.1f us   gradient %8.1f us   gradient-cold %8.1f us\n", term.c_str(), 1e6 * value,
              1e6 * warm, 1e6 * cold);
}

}  // namespace

int main(int argc, char** argv) {
  return bench::run_benchmark("pd_bench_element_kernels", [](int ac, char** av) {
    CLI::App app{"Wall time of the shell energies' value and gradient loops"};
    int threads = 0, calls = 200;
    std::vector<int> cells{100, 60};
    app.add_option("--threads", threads, "element threads (0: every core)")->check(CLI::Range(0, 4096));
    app.add_option("--calls", calls, "calls per loop")->check(CLI::Range(1, 1'000'000'000));
    app.add_option("--cells", cells, "cells along x and y")->expected(2)->check(CLI::Range(1, 100'000));
    try {
      app.parse(ac, av);
    } catch (const CLI::ParseError& e) {
      return app.exit(e);
    }
    set_element_threads(threads);
    const TriMesh mesh = make_rectangle(1.0, 0.6, cells[0], cells[1]);
    const Topology topology = build_topology(mesh);
    const Eigen::VectorXd x[2] = {deformed(mesh, 0.8, 0.01), deformed(mesh, 1.1, 0.02)};
    const NeoHookeanMembrane membrane(mesh.F, mesh.V, MembraneMaterialParams::from(2e4, 0.3, 5e-4));
    const HingeBending bending(topology.hinges, mesh.V, 5e3 * std::pow(5e-4, 3) / 12.0);
    std::printf("%d vertices, %d faces, %zu hinges, %d element threads, %d calls\n", mesh.num_vertices(),
                mesh.num_faces(), topology.hinges.size(), effective_element_threads(), calls);
    Fnv1a hash;
    report("membrane", membrane, x, calls, hash);
    report("bending", bending, x, calls, hash);
    std::printf("result hash %016llx\n", static_cast<unsigned long long>(hash.value()));
    return 0;
  }, argc, argv);
}
