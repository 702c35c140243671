#pragma once
// The unit of work of a progressive run (PD Algorithm 1, section 4.6): solve level l, frames (a, b].
// The farm dispatches these; a whole progressive run is the sequence level 0 (0, N], level 1 (0, N],
// ..., and a level may also be cut into time subsets solved in parallel.
//
// Per step t -> t+1 of level l:
//   level 0 (the preview, PD eq. 4): plain implicit Euler momentum xhat = x_0^t + h v_0^t;
//   level l >= 1 (refinement, PD eqs. 5-6): the momentum prolonged from level l-1,
//     xhat = P_l^{l-1}(x_{l-1}^t) + U_l^{l-1} (x_{l-1}^t - x_{l-1}^{t-1}),
//   with x_{l-1}^{-1} = x_{l-1}^0 - h v^0 (the scene's initial velocity) for t = 0;
//   both with contact and strain limits on level l's geometry and the finest level's elasticity
//   through P^l (progressive/level_system.h). Each step warm-starts from the level's previous frame
//   (horizontal warm start). Coarser levels use the scene's Newton cap (solver.max_newton_iterations);
//   the finest level of a progressive run, which should stop only on convergence (PD 4.6), ten times
//   that (a direct run keeps the scene's cap, as plain pd simulate does).
//
// Where a task starts (its frame a of level l):
//   a = 0             the level's initial state (level_system's x0, v0), stored as frame 0;
//   own frames given  horizontal continuation: x_l^a and v_l^a = (x_l^a - x_l^{a-1}) / h (a >= 1);
//   otherwise         vertical start (l >= 1 only): x_l^a = safe upsampling of x_{l-1}^a (PSQ 4.4,
//                     hierarchy/safe_upsampling.h), v_l^a = U (x_{l-1}^a - x_{l-1}^{a-1}) / h.
// Documented effect of cutting a level into subsets: a subset that starts vertically at a > 0 starts
// from the upsampled x_l^a instead of the solved one. Its momentum target is the same (it comes from
// level l-1), so without contact its frames are the single run's to round-off (measured 3e-17 m).
// With contact they are not: the barrier stiffness adapts from the task's start, lagged friction and
// drag read the start state, and a cloth resting on a faceted collider has nearby equilibria; in
// tests/progressive/level_task_test.cpp (cloth on a 42-vertex sphere) the frames after a vertical
// start at frame 12 stay 5-6 mm from the single run's. A horizontal continuation (own frames a-1,
// a, and with contact the barrier stiffness of frame a) repeats the single run bit for bit.
//
// Deterministic: the same inputs give the same frames bit for bit.
//
// Conventions: frames are stacked positions (3 n_l, m) in level l's global vertex ids; level 0 =
// coarsest; frame t is at time t h.
#include <functional>
#include <optional>

#include <Eigen/Core>

#include "hierarchy/safe_upsampling.h"
#include "hierarchy/scene_hierarchy.h"
#include "progressive/level_stepper.h"
#include "progressive/level_system.h"
#include "scene/scene.h"

namespace pd {

struct LevelTask {
  int level = 0;
  int first = 0;  // a: the frame the task starts from (already solved, or the initial state)
  int last = 0;   // b: the last frame it solves, a < b <= the scene's frame count
};

struct LevelTaskInputs {
  // Level l-1's frame t (stacked, level l-1 ids), asked for t in [max(a-1, 0), b-1]; required for
  // l >= 1. May throw (e.g. a frame missing from a file): the task then stops with that error.
  std::function<Eigen::VectorXd(int t)> below;
  // Level l's own frames a-1 and a, for a horizontal continuation (a >= 1). Level 0 requires them
  // when a >= 1; level l >= 1 without them starts vertically.
  std::optional<Eigen::VectorXd> own_before, own_start;
  // With a horizontal continuation of a scene with contact: the barrier stiffness at frame a (its
  // barrier_stiffness stat, J/m^4). Given, the task continues with it and repeats the single run bit
  // for bit; absent, it balances a new one at its first step.
  std::optional<double> own_kappa;
  // A stitch (physics/guide.h): with a horizontal continuation from own frames a-1 and a, the steps
  // to frames a+1..a+stitch_frames (from the seam, below) add a guide toward stitch_target(f) (the later subset's frame f of
  // the same level, stacked) whose weight w ramps so that w / (1 + w) follows smootherstep((f - a) / stitch_frames):
  // from 0 to 100 times the inertia's stiffness. Later subset frames solve the same step problems
  // (their inertia targets come from the level below, not from their own past), so each is a
  // stationary point of step energy plus guide, and the last stitched frame lands on the later
  // subset's frame to the solver's tolerance. stitch_frames = 0: no stitch.
  std::function<Eigen::VectorXd(int f)> stitch_target;
  int stitch_frames = 0;
  // The frame the stitch's ramp counts from (the seam s: the guide acts on frames s+1..s+stitch_frames
  // with weight kStitchWeight * ramp((f - s) / stitch_frames)); -1: the task's first frame a. A farm
  // stitch task resumed after a lost worker starts at a later frame but keeps its seam's ramp.
  int stitch_seam = -1;
};

// The stitch guide's weight at its last frame, in units of the inertia's stiffness M / h^2.
constexpr double kStitchWeight = 100.0;

// A refinement level's start (its frame 0, the scene's initial state on its mesh) is not the
// prolongation of the level below's frame 0: PD eq. 5's inertia target P(x_{l-1}^t) + U(x_{l-1}^t -
// x_{l-1}^{t-1}) would pull the level onto the prolonged trajectory in its first step. So the target
// of its first kLevelStartFrames steps carries the start offset d0 = x_l^0 - P(x_{l-1}^0), decayed
// by 1 - smootherstep((t + 1) / kLevelStartFrames) for the step to frame t + 1: the first step is
// the level's own momentum, and the offset fades with no jump in velocity nor acceleration.
// docs/progressive.md, "Where a refinement level starts".
constexpr int kLevelStartFrames = 10;

struct LevelTaskOptions {
  LevelSystemOptions system;
  UpsamplingSettings upsampling;  // for a vertical start
};

// What a task did, beside the frames it sent.
struct LevelTaskReport {
  bool vertical_start = false;
  UpsamplingReport upsampling;  // valid when vertical_start
  int unconverged_steps = 0;    // steps whose Newton solve stopped before its tolerance (frames still sent)
};

// Solves level task.level, frames (a, b], sending each solved frame to `sink` as it is solved (and
// frame 0, the level's initial state, first when a = 0; a vertical start at a > 0 does not send its
// upsampled frame a, which belongs to the task that solved it). Throws
// std::invalid_argument for a task outside the scene (level, a, b) or missing / mis-sized inputs,
// and UpsamplingFailed if a vertical start has no safe upsampling (an invalid_argument from inside
// safe upsampling included: it refused one of its own intermediate states; and an upsampled state
// that intersects itself, hierarchy/self_intersection_cgal.h).
LevelTaskReport solve_level_task(const Scene& scene, const SceneHierarchy& hierarchy, const LevelTask& task,
                                 const LevelTaskInputs& inputs, const std::function<void(const FrameRecord&)>& sink,
                                 const LevelTaskOptions& options = {});

}  // namespace pd
