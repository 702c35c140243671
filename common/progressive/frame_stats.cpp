#include "progressive/frame_stats.h"

namespace pd {

FrameStats frame_stats(const FrameRecord& r) {
  FrameStats s;
  const NewtonReport& n = r.newton;
  s.scalars = {{"newton_iterations", double(n.iterations)},
               {"line_search_cuts", double(n.line_search_cuts)},
               {"exact_hessians", double(n.exact_hessians)},
               {"projection_fallbacks", double(n.projection_fallbacks)},
               {"extended_steps", double(n.extended_steps)},
               {"exact_curvature_iterations", double(n.exact_curvature_iterations)},
               {"curvature_probes", double(n.curvature_probes)},
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

}  // namespace pd
