#include "upsampling_report.h"

#include <cstdio>

namespace pd::bench {

std::string describe_upsampling(const UpsamplingReport& r) {
  const double other =
      r.seconds - r.perturb_seconds - r.advance_seconds - r.relax_seconds - r.pull_seconds - r.strain_seconds;
  char line[1024];
  std::snprintf(line, sizeof line,
                "%d batches, %d splits (%d random perturbations, %d samples), %d advance events (%d close, %d "
                "redirections), %d stopped, %d relaxed patches, %d unopened splits, %d short at the end (%d pull "
                "iterations), %d unresolved; gap %.3g -> %.3g m; target distance max %.3g m rms %.3g m; stretch %.4f -> "
                "%.4f; %.3f s (perturb %.3f, advance %.3f, relax %.3f, pull %.3f, strain %.3f, other %.3f)",
                r.batches, r.splits, r.random_perturbations, r.perturbation_samples, r.advance_events, r.close_events,
                r.redirections, r.stopped_vertices, r.relaxed_patches, r.unopened_splits, r.final_pull_vertices,
                r.pull_newton_iterations, r.unresolved_gaps, r.coarse_gap, r.final_gap, r.max_target_distance,
                r.rms_target_distance, r.max_stretch_before, r.max_stretch_after, r.seconds, r.perturb_seconds,
                r.advance_seconds, r.relax_seconds, r.pull_seconds, r.strain_seconds, other);
  return line;
}

}  // namespace pd::bench
