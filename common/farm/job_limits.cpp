#include "farm/job_limits.h"

#include <sys/statvfs.h>

#include <algorithm>
#include <limits>

#include "util/input_error.h"
#include "util/memory_budget.h"

namespace pd::farm {

int64_t job_task_bound(const GraphOptions& o, bool refinement_only) {
  const int64_t N = std::max(o.frames, 1), levels = std::max(o.levels, 1);
  const int64_t K = std::min<int64_t>(std::max(o.subsets, 1), N);
  const int64_t chunk = std::min<int64_t>(o.preview_chunk > 0 ? o.preview_chunk : default_preview_chunk(std::max(o.frames, 1)), N);
  // Per refinement level: K subsets, and a stitch at each of the K - 1 seams when stitching.
  const int64_t per_level = K + (o.stitch >= 2 ? K - 1 : 0);
  const int64_t refinement = (levels - 1) * per_level;
  if (refinement_only) return refinement;
  return 1 + (N + chunk - 1) / chunk + (o.preview_only ? 0 : refinement);
}

double job_frame_bytes(int frames, int levels, int64_t finest_vertices, double ratio) {
  double vertices = 0.0, n = static_cast<double>(finest_vertices);
  for (int l = 0; l < levels; ++l, n /= std::max(ratio, 1.0)) vertices += std::max(n, 1.0);
  return 2.0 * 3.0 * sizeof(double) * vertices * (static_cast<double>(frames) + 1.0);
}

void check_job_size(const std::string& request, const GraphOptions& o, bool refinement_only, int64_t finest_vertices,
                    double ratio, double free_bytes) {
  const std::string r = request + ": ";
  if (o.levels < 1 || o.levels > kMaxJobLevels)
    throw InputError(r + "levels: must be 1 to " + std::to_string(kMaxJobLevels) + ", got " + std::to_string(o.levels));
  if (o.frames < 1 || o.frames > kMaxJobFrames)
    throw InputError(r + "frames: must be 1 to " + std::to_string(kMaxJobFrames) + ", got " + std::to_string(o.frames));
  const int64_t tasks = job_task_bound(o, refinement_only);
  if (tasks > kMaxJobTasks)
    throw InputError(r + std::to_string(o.frames) + " frames, " + std::to_string(o.levels) + " levels, " +
                     std::to_string(o.subsets) + " subsets and preview chunks of " +
                     std::to_string(o.preview_chunk > 0 ? o.preview_chunk : default_preview_chunk(o.frames)) +
                     " frames would need " + std::to_string(tasks) + " tasks; the limit is " +
                     std::to_string(kMaxJobTasks) + " (fewer --subsets, a longer --preview-chunk)");
  const double bytes = job_frame_bytes(o.frames, o.levels, finest_vertices, ratio);
  if (bytes > free_bytes)
    throw InputError(r + std::to_string(o.frames) + " frames of " + std::to_string(o.levels) + " levels (" +
                     std::to_string(finest_vertices) + " vertices on the finest) would need " + gib_text(bytes) +
                     " of frame storage; the farm folder has " + gib_text(free_bytes) +
                     " free (fewer --frames or --levels, or free space)");
}

double free_bytes_at(const std::string& path) {
  struct statvfs s = {};
  if (statvfs(path.c_str(), &s) != 0) return std::numeric_limits<double>::infinity();
  return static_cast<double>(s.f_bavail) * static_cast<double>(s.f_frsize);
}

}  // namespace pd::farm
