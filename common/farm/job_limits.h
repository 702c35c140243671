#pragma once
// What one farm job may ask for, checked by the scheduler before any of its work starts (submit and
// refine requests). Every field of a request can be within its own range while their product is
// not: `pd submit cube-trampoline.json --frames 10000000 --subsets 10000000 --levels 20` took the
// scheduler past 3 GB in 9 s, `--frames 10000000 --preview-chunk 1 --levels 1` held its loop for over
// 60 s (10^7 task rows in one transaction; no request answered, workers dropped as silent). So the
// size of the task graph is computed (not built) first, and the frames the job would store are
// estimated against the farm folder's free space; a refusal names the fields and the figures.
#include <cstdint>
#include <string>

#include "farm/task_graph.h"

namespace pd::farm {

// As a scene's own bounds (docs/scene-format.md, "Sizes"): hierarchy.levels and frames.
constexpr int kMaxJobLevels = 20;
constexpr int kMaxJobFrames = 10'000'000;
// Tasks of one job. A production shot needs hundreds (flag-large-10s: 1 000 frames, K = 64 over 4
// levels with stitches, 20 preview chunks: 402). Why this bound: the tasks of a request are inserted
// in one SQLite transaction on the scheduler's loop, which must answer within a heartbeat (1 s by
// default); a 19 001-task job was inserted and answered in 0.15 s
// (FarmTest.AbsurdJobSizesAreRefusedNamingTheFiguresAndTheSchedulerKeepsAnswering).
constexpr int64_t kMaxJobTasks = 20'000;

// At least as many tasks as job_tasks(options) makes (exactly as many without stitches: a stitch is
// counted at every seam, where a short subset may have none), computed in O(1). options.preview_only
// drops the refinement levels, as in job_tasks; `refinement_only` counts refinement_tasks' instead.
int64_t job_task_bound(const GraphOptions& options, bool refinement_only = false);

// Bytes of frames a job stores (positions as doubles, frames 0..N of every level), from the finest
// level's vertex count and the hierarchy's ratio (level l has about n / ratio^(L - l) vertices).
// Stored twice (the task store and the job file), so this counts both.
double job_frame_bytes(int frames, int levels, int64_t finest_vertices, double ratio);

// Refuses a job that exceeds the bounds above or whose frames would not fit in `free_bytes` (the farm
// folder's free space): InputError "<request>: <what> would need <figure>; the limit is <limit>
// (<which option lowers it>)". Call before job_tasks / refinement_tasks.
void check_job_size(const std::string& request, const GraphOptions& options, bool refinement_only,
                    int64_t finest_vertices, double ratio, double free_bytes);

// Free bytes of the file system holding `path` (statvfs, for an unprivileged user); +infinity when it
// cannot be asked (then only the other bounds apply).
double free_bytes_at(const std::string& path);

}  // namespace pd::farm
