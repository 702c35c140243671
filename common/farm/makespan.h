#pragma once
// Makespan prediction: replays a job's task graph (farm/task_graph.h) on W identical workers the way
// the scheduler runs it, to predict its wall time from per-level step costs (pd plan).
//
// The model (times in seconds from submission):
//   - one task per worker at a time; a free worker takes the ready task first in the order (level
//     ascending, first frame ascending), as TaskStore::claim_next does within a job;
//   - a task is ready when the hierarchy task is done and the frames it needs (NewTask::needs) are
//     stored; the hierarchy task is ready at time 0; with K >= 2 every refinement task also needs
//     level 0's frame N (the scheduler adds them once the preview is stored, to place the seams);
//   - a task taken at time s starts working at s + dispatch_seconds (the overhead of every task,
//     the hierarchy task's included); the hierarchy task then takes hierarchy_seconds;
//   - a level task (a, b] with a = 0 stores its frame 0 (the level's initial state) when it starts
//     working; a level-0 chunk with a > 0 continues horizontally at no extra cost; a level-l >= 1
//     subset with a > 0 first spends vertical_start_seconds[l] on its vertical start;
//   - then it solves frames a+1..b one by one: frame t + 1 is stored at
//       max(its frame t's time, the time level l-1's frame t is stored) + step_seconds[l]
//     (level 0: its frame t's time + step_seconds[0]); while level l-1's frame t is missing the
//     worker waits, held and idle. The worker is free when frame b is stored.
//   - a seam's stitch task (task_graph.h, GraphOptions::stitch) is a horizontal continuation (no
//     vertical start) guided toward the later subset's guide frames: it is ready once the first is
//     stored, and its frame t + 1 also waits for guide frame t + 1. Guide frames count as stored for
//     it only; the level above waits for the stitched frames instead.
// Frames are stored the moment they are solved (transfer and HDF5 writes are not modelled).
// Deterministic: the same inputs give the same Plan bit for bit.
#include <vector>

#include "farm/task_graph.h"

namespace pd::farm {

struct Costs {
  std::vector<double> step_seconds;            // per level (L + 1 entries): one step t -> t + 1
  std::vector<double> vertical_start_seconds;  // per level (L + 1 entries; entry 0 unused): one vertical start
  double hierarchy_seconds = 0.0;              // the hierarchy task's work
  double dispatch_seconds = 0.0;               // per task, before its work starts
  // Optional, per level (L + 1 entries) and frame t = 0..N (N + 1 entries): the cost of the step that
  // solves frame t (entry 0 unused), e.g. each frame's solve_seconds in a run of the shot. Where given
  // it replaces step_seconds, so that subsets of equal length but unequal work (the flag's level 2:
  // 10 to 19 s per 150 frames) are planned as they run: with the mean, pd plan missed a K = 4 run on
  // two workers by -16 %, the longest subset setting the wall time.
  std::vector<std::vector<double>> frame_step_seconds;
};

struct Plan {
  double makespan = 0.0;                     // when the last task ends
  double preview_seconds = 0.0;              // when level 0's frame N is stored
  double first_preview_frame_seconds = 0.0;  // when level 0's frame 1 is stored
  std::vector<double> level_finish;          // per simulated level (1 entry when preview_only): its frame N stored
  // Work (hierarchy, dispatches, vertical starts, steps) over W x makespan: the share of worker time
  // not spent idle or waiting for a frame of the level below. 0 when makespan is 0.
  double busy_fraction = 0.0;
};

// Predicts the job's plan on `workers` workers. Throws std::invalid_argument for bad options (as
// job_tasks), workers < 1, a cost vector whose size is not options.levels, or a cost that is negative
// or not finite, naming the field: "makespan: step_seconds[1] must be finite and >= 0, got -1".
// seams: the refinement levels' seams (farm/seam_placement.h) as job_tasks takes them; empty: the
// even split.
Plan predict_plan(const GraphOptions& options, const Costs& costs, int workers, const std::vector<int>& seams = {});

}  // namespace pd::farm
