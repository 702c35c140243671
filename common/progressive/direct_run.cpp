#include "progressive/direct_run.h"

#include "store/frame_store.h"

namespace pd {

namespace {

FrameStats to_stats(const FrameRecord& r) {
  FrameStats s;
  const NewtonReport& n = r.newton;
  s.scalars = {{"newton_iterations", double(n.iterations)},
               {"line_search_cuts", double(n.line_search_cuts)},
               {"newton_converged", r.frame == 0 ? 1.0 : double(n.converged)},
               {"solve_seconds", r.seconds},
               {"assemble_seconds", n.assemble_seconds},
               {"factorize_seconds", n.analyse_seconds + n.factorize_seconds},
               {"kinetic_energy", r.kinetic_energy}};
  for (const auto& [name, value] : r.energies) s.scalars.emplace_back("energy_" + name, value);
  for (const auto& stat : r.contact) s.scalars.push_back(stat);
  s.scalars.emplace_back("pin_rounds", r.pin_rounds);
  s.center_of_mass = r.center_of_mass;
  return s;
}

}  // namespace

int run_direct(const Scene& scene, const DirectRunOptions& options) {
  const int frames = options.frames >= 1 ? options.frames : scene.frames;
  SceneSystem sys = build_scene_system(scene);
  check_start_state(scene, sys);
  FrameWriter writer = FrameWriter::create(options.out_path, scene.json_text, frames);
  writer.add_level(0, sys.rest.V, sys.rest.F, sys.object_offsets, sys.object_names);

  LevelStepper stepper(sys, scene.solver, scene.time_step);
  FrameRecord r = stepper.initial_frame();
  writer.write_frame(0, 0, as_rows(r.x), to_stats(r));
  if (options.on_frame) options.on_frame(r);

  Eigen::VectorXd x = sys.x0, v = sys.v0;
  int not_converged = 0;
  for (int t = 0; t < frames; ++t) {
    r = stepper.step(t, x, v);
    not_converged += !r.newton.converged;
    writer.write_frame(0, t + 1, as_rows(r.x), to_stats(r));
    if (options.on_frame) options.on_frame(r);
  }
  return not_converged;
}

}  // namespace pd
