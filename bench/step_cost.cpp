// Cost of one implicit time step of a hanging cloth sheet, split into energy assembly (gradient and
// projected Hessian), factorization (symbolic analysis + numeric CHOLMOD) and triangular solves,
// for square grids of about 1K, 6K and 25K vertices (or the sizes given on the command line as
// cells per side).
//
//   pd_bench_step_cost            # 31, 77, 157 cells per side: 1024, 6084, 24964 vertices
//   pd_bench_step_cost 50 100     # other sizes
//   pd_bench_step_cost --threads 2 157   # element loops on 2 threads (default: every core)
// The last column is a hash of the final positions' bytes: equal hashes for two thread counts mean
// the same result bit for bit.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "geometry/shapes.h"
#include "progressive/level_stepper.h"
#include "util/fnv1a.h"
#include "util/parallel.h"
#include "util/process_setup.h"

using namespace pd;

int main(int argc, char** argv) {
  limit_openmp_threads(argv);
  std::vector<int> sizes = {31, 77, 157};
  int first_size = 1;
  if (argc > 2 && std::string(argv[1]) == "--threads") {
    set_element_threads(std::atoi(argv[2]));
    first_size = 3;
  }
  if (argc > first_size) {
    sizes.clear();
    for (int i = first_size; i < argc; ++i) sizes.push_back(std::atoi(argv[i]));
  }
  std::printf("element threads: %d\n", effective_element_threads());
  const int steps = 5;
  std::printf("%8s %8s %6s %10s %10s %10s %10s %10s %10s %18s\n", "vertices", "faces", "steps", "its/step",
              "assemble", "analyse", "factorize", "solve", "step", "x hash");
  std::printf("%8s %8s %6s %10s %10s %10s %10s %10s %10s\n", "", "", "", "", "ms/it", "ms/step", "ms/it",
              "ms/it", "ms/step");
  for (int cells : sizes) {
    Scene scene;
    scene.name = "bench";
    scene.time_step = 1.0 / 100;
    scene.frames = steps;
    SceneObject sheet;
    sheet.name = "sheet";
    sheet.rest = make_rectangle(1.0, 1.0, cells, cells);
    sheet.initial = sheet.rest.V;
    sheet.material.density = 472.6;  // cotton-like
    sheet.material.youngs_modulus = 0.8e6;
    sheet.material.poisson_ratio = 0.3;
    sheet.material.thickness = 3.2e-4;
    PinGroup corners;
    corners.vertices = {cells * (cells + 1), (cells + 1) * (cells + 1) - 1};  // top corners
    sheet.pins.push_back(corners);
    scene.objects.push_back(sheet);

    SceneSystem sys = build_scene_system(scene);
    LevelStepper stepper(sys, scene.solver, scene.time_step);
    Eigen::VectorXd x = sys.x0, v = sys.v0;
    double assemble = 0, analyse = 0, factorize = 0, solve = 0, total = 0;
    int its = 0;
    for (int s = 0; s < steps; ++s) {
      const FrameRecord r = stepper.step(s, x, v);
      its += r.newton.iterations;
      assemble += r.newton.assemble_seconds;
      analyse += r.newton.analyse_seconds;
      factorize += r.newton.factorize_seconds;
      solve += r.newton.solve_seconds;
      total += r.seconds;
    }
    Fnv1a hash;  // over the bytes of x
    hash.bytes(x.data(), sizeof(double) * static_cast<std::size_t>(x.size()));
    std::printf("%8d %8d %6d %10.1f %10.2f %10.2f %10.2f %10.2f %10.1f %18llx\n", sys.rest.num_vertices(),
                sys.rest.num_faces(), steps, double(its) / steps, 1e3 * assemble / its, 1e3 * analyse / steps,
                1e3 * factorize / its, 1e3 * solve / its, 1e3 * total / steps, static_cast<unsigned long long>(hash.value()));
  }
  return 0;
}
