#pragma once
// The task graph of a farm job (../shared/DESIGN.md, "Task graph of a job"): which tasks a job is cut
// into and which frames each one needs before it is dispatched. The scheduler adds these to the task
// store (store/task_store.h); farm/makespan.h replays the same graph to predict a job's wall time.
//
// A job has N frames (t = 0..N) and L + 1 hierarchy levels (0 = coarsest). Its tasks, in this order:
//   1. one hierarchy task (kind hierarchy, level 0, first = last = 0), waiting for nothing;
//   2. level 0, the preview: a chain of chunks (0, c], (c, 2c], ..., the last one ending at N. Chunk
//      (a, b] with a > 0 continues horizontally from level 0's frames a - 1 and a, so it needs them;
//   3. unless preview_only, each level l = 1..L cut into K time subsets (a, b] with boundaries
//      b_k = round(k N / K) = (k N + K / 2) / K in integer arithmetic (K is clamped to N so that no
//      subset is empty), or at the given seams (farm/seam_placement.h: placed from the stored
//      preview): strictly increasing in (0, N), subsets - 1 of them. The first subset starts from the level's initial state at frame 0, the
//      others vertically (safe upsampling of level l - 1's frame a); one whose vertical start is
//      refused continues horizontally instead (TaskStore::continue_horizontally adds the needs).
//   4. with a stitch width W >= 2 (GraphOptions::stitch), at each seam s of a refinement level whose
//      later subset (s, b] starts vertically: a stitch task (s, s + w - 1], w = min(W, b - s - 1) (none
//      when w < 2: the later subset keeps its last two frames, from which the next seam's stitch
//      continues). The later subset stores its frames s + 1 .. s + w - 1 as guide frames (NewTask::
//      guides = w - 1), not as the level's frames; the stitch task continues the earlier subset
//      horizontally from the level's frames s - 1 and s and solves those frames itself, guided toward
//      the guide frames with a weight ramped up to land on the later subset by s + w - 1
//      (progressive/level_task.h, docs/progressive.md "Stitching a seam"), so a seam does not pop.
//      It needs the level's frames s - 1 and s, the first guide frame s + 1, and the level below as a
//      subset (s, s + w - 1] would; it is then fed the other guide frames as they are stored (the
//      protocol's GuideFrame), as it is fed the level below. The level above reads the stitched
//      frames like any others.
// Every task but the hierarchy task waits for the hierarchy task (after_hierarchy).
//
// Frame dependencies (PD eq. 5): step t -> t + 1 of level l >= 1 reads level l - 1's frames t and
// t - 1 (frame -1 meaning frame 0). So a level-l task (a, b] needs level l - 1's frames max(a-1, 0)
// and a stored before dispatch, and is then fed level l - 1's frames up to b - 1 as they land
// (fed_frames); it can solve its frame t + 1 only once level l - 1's frame t is stored.
// One addition: a subset of level l >= 2 with a > 0 and b > a + 1 also needs level l - 1's frame
// a + 1, so that it is never dispatched before the task feeding it has started (a task dispatched
// ahead of its feeder holds a worker idle and can starve the feeder of workers; task_graph.cpp).
//
// Bad options throw std::invalid_argument naming the field: "task graph: subsets must be >= 1, got 0".
#include <optional>
#include <vector>

#include "store/task_store.h"

namespace pd::farm {

struct GraphOptions {
  int frames = 0;          // N: the job solves frames 1..N of each level (frame 0 is the initial state)
  int levels = 0;          // L + 1: hierarchy levels of the job, level 0 the preview
  int subsets = 1;         // K: time subsets of each level l >= 1 (clamped to N)
  int preview_chunk = 0;   // frames per level-0 chunk; 0: default_preview_chunk(frames); clamped to N
  bool preview_only = false;  // no refinement tasks (pd refine adds them later: refinement_tasks)
  int stitch = 0;          // W: frames a seam is stitched over (item 4 above); 0 or 1: no stitch
};

// The default stitch width: with the smootherstep ramp (progressive/level_task.cpp) 8 frames kept every
// seam and junction of the seam bench at its K = 1 pop (docs/progressive.md, "Stitching a seam") but
// left 2 of 14 of drape-gear's visible at K = 8 (its finest level's seam 113 and junction 138); 10
// left none there, and cost 2 frames per seam more: pd plan puts flag-large-10s on 64 workers at
// 33.4x one worker (35.8x at 8, 28.7x at 16, the default until the ramp changed).
constexpr int kDefaultStitchFrames = 10;
// The widest stitch a job may ask for: 1 000 frames is 10 s of a shot at 100 fps, and a stitch's guide
// frames are kept in the task store (farm.sqlite) until the job is removed.
constexpr int kMaxStitchFrames = 1000;

// The level-0 chunk length used when GraphOptions::preview_chunk is 0: min(50, N) frames.
int default_preview_chunk(int frames);

// The job's whole graph: the hierarchy task, level 0's chain, then levels 1..L (unless preview_only),
// each level's tasks by first frame.
// seams: empty for the even split, else as above (std::invalid_argument otherwise).
std::vector<pd::NewTask> job_tasks(const GraphOptions& options, const std::vector<int>& seams = {});

// Levels 1..L only (what pd refine adds to a preview-only job); preview_only is ignored. Empty when
// the job has a single level.
std::vector<pd::NewTask> refinement_tasks(const GraphOptions& options, const std::vector<int>& seams = {});

// A range of frames [first, last] (both included) of one level.
struct FrameRange {
  int level = 0;
  int first = 0;
  int last = 0;
};

// The frames a refinement subset (a, b] of level l >= 1 needs stored before it is dispatched (the
// rule above: level l-1's frames max(a-1, 0) and a, and a + 1 on levels >= 2 when b > a + 1). Used
// for the job's graph and for a subset whose seam moved (TaskStore::move_seam).
std::vector<pd::FrameKey> subset_needs(int level, int first, int last);

// The stitch task of the seam s of a refinement level whose later subset is (s, b] (item 4 above), or
// nullopt when min(stitch, b - s - 1) < 2. Used for the job's graph and for a seam that moved.
std::optional<pd::NewTask> stitch_task(int level, int seam, int last, int stitch);

// The frames of level l - 1 a level-l task (a, b], l >= 1, is fed: max(a - 1, 0) .. b - 1 (the
// protocol's BelowFrame messages). nullopt for the hierarchy task and level-0 tasks. Throws
// std::invalid_argument for a level task with level < 0, first < 0 or last <= first.
std::optional<FrameRange> fed_frames(const pd::NewTask& task);

// The frames of its own level a level task (a, b] stores: a + 1 + guides .. b, and frame 0 too when
// a = 0 (the level's initial state, sent first). nullopt for the hierarchy task. Same checks as
// fed_frames.
std::optional<FrameRange> produced_frames(const pd::NewTask& task);

// The guide frames a later subset stores instead (a + 1 .. a + guides); nullopt when it has none.
std::optional<FrameRange> guide_frames(const pd::NewTask& task);

}  // namespace pd::farm
