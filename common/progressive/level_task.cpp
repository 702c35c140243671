#include "progressive/level_task.h"

#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>

#include "hierarchy/self_intersection_cgal.h"
#include "physics/guide.h"
#include "physics/inertia.h"

namespace pd {

namespace {

constexpr int kFinestIterationFactor = 10;

void fail(const LevelTask& task, const std::string& what) {
  throw std::invalid_argument("level task (level " + std::to_string(task.level) + ", frames (" +
                              std::to_string(task.first) + ", " + std::to_string(task.last) + "]): " + what);
}

// The scene's initial velocity of every vertex of `level` (stacked, m/s): each object's uniform
// initial_velocity (obstacles move by script and have none).
Eigen::VectorXd initial_velocity(const Scene& scene, const SceneHierarchy& hierarchy, int level) {
  const SceneLevel& lv = hierarchy.levels[static_cast<std::size_t>(level)];
  Eigen::VectorXd v = Eigen::VectorXd::Zero(3 * lv.rest.V.rows());
  for (std::size_t o = 0; o < scene.objects.size(); ++o)
    for (int i = lv.vertex_offsets[o]; i < lv.vertex_offsets[o + 1]; ++i)
      v.segment<3>(3 * i) = scene.objects[o].obstacle ? Vec3::Zero() : scene.objects[o].initial_velocity;
  return v;
}

// The stitch guide's weight at u = (f - a) / W in (0, 1]: a guide of weight w alone (against inertia of
// stiffness 1) would put the frame a fraction w / (1 + w) of the way to its target, so the weight is
// chosen for that fraction to follow smootherstep(u) (6u^5 - 15u^4 + 10u^3: no jump in velocity nor
// acceleration where the stitch begins and ends), up to kStitchWeight at u = 1. The fraction ignores
// the momentum the guide's pull builds up over the frames before, so the ramp must start slowly:
// with smoothstep (3u^2 - 2u^3) an 8-frame stitch still popped 0.97 at the flag's seam at 100 (K = 1:
// 0.43), with smootherstep 0.38; a weight ramped linearly put the first stitched frame 80 % of the way
// at once (a pop of 1.5 there). docs/progressive.md, "Stitching a seam".
double smootherstep(double u) { return u * u * u * (u * (6.0 * u - 15.0) + 10.0); }

double stitch_weight(double u) {
  const double s = smootherstep(u);
  return s >= 1.0 ? kStitchWeight : std::min(kStitchWeight, s / (1.0 - s));
}

}  // namespace

LevelTaskReport solve_level_task(const Scene& scene, const SceneHierarchy& hierarchy, const LevelTask& task,
                                 const LevelTaskInputs& inputs, const std::function<void(const FrameRecord&)>& sink,
                                 const LevelTaskOptions& options) {
  const int l = task.level, a = task.first, b = task.last;
  if (l < 0 || l > hierarchy.finest()) fail(task, "no such level (the hierarchy has " + std::to_string(hierarchy.num_levels()) + ")");
  if (a < 0 || b <= a || b > scene.frames) fail(task, "needs 0 <= a < b <= " + std::to_string(scene.frames) + " (the scene's frames)");
  // A direct simulation of a level (options.system.direct) steps like the preview: own momentum.
  const bool refining = l >= 1 && !options.system.direct;
  if (refining && !inputs.below) fail(task, "a refinement level needs the frames of the level below");
  const bool horizontal = inputs.own_before.has_value() && inputs.own_start.has_value();
  if (inputs.own_before.has_value() != inputs.own_start.has_value()) fail(task, "own frames come in pairs (a-1 and a)");
  if (!refining && a > 0 && !horizontal) fail(task, "the preview (or a direct run) continues only from its own frames a-1 and a");
  if (inputs.stitch_frames < 0) fail(task, "stitch_frames must be >= 0");
  if (inputs.stitch_frames > 0 && (!horizontal || !inputs.stitch_target))
    fail(task, "a stitch continues from own frames a-1 and a toward a target");
  const int seam = inputs.stitch_seam < 0 ? a : inputs.stitch_seam;
  if (inputs.stitch_frames > 0 && seam > a) fail(task, "the stitch's seam " + std::to_string(seam) + " is after the start");

  SceneSystem sys = build_level_system(scene, hierarchy, l, options.system);
  const Eigen::Index n = sys.x0.size();
  const double h = scene.time_step;
  // The finest level stops only on convergence (PD 4.6, DESIGN.md): its Newton cap is raised
  // tenfold rather than removed, so a step that cannot converge still ends (flagged unconverged)
  // instead of hanging the task.
  SolverSettings solver = scene.solver;
  if (l == hierarchy.finest() && !options.system.direct) solver.max_newton_iterations *= kFinestIterationFactor;
  LevelStepper stepper(sys, solver, h);
  LevelTaskReport report;

  // Level l-1's frames, checked for size as they come.
  const SceneLevel* below_level = refining ? &hierarchy.levels[static_cast<std::size_t>(l - 1)] : nullptr;
  const Eigen::VectorXd below_v0 = refining ? initial_velocity(scene, hierarchy, l - 1) : Eigen::VectorXd();
  const auto below = [&](int t) -> Eigen::VectorXd {
    Eigen::VectorXd x = inputs.below(t < 0 ? 0 : t);
    if (x.size() != 3 * below_level->rest.V.rows())
      fail(task, "frame " + std::to_string(t) + " of level " + std::to_string(l - 1) + " has " +
                     std::to_string(x.size() / 3) + " vertices, the level " + std::to_string(below_level->rest.V.rows()));
    if (t < 0) x -= h * below_v0;  // x_{l-1}^{-1} from the initial velocity
    return x;
  };

  // The start state (x_l^a, v_l^a).
  Eigen::VectorXd x, v;
  if (a == 0) {
    x = sys.x0;
    v = sys.v0;
    sink(stepper.initial_frame());
  } else if (horizontal) {
    if (inputs.own_before->size() != n || inputs.own_start->size() != n)
      fail(task, "the level's own frames need " + std::to_string(n / 3) + " vertices");
    x = *inputs.own_start;
    v = (*inputs.own_start - *inputs.own_before) / h;
    if (inputs.own_kappa) sys.contact.restore_kappa(*inputs.own_kappa);
  } else {
    const Eigen::VectorXd xa = below(a), xb = below(a - 1);
    const UpsamplingLevel up = upsampling_level(scene, hierarchy, l - 1);
    const Positions coarse = as_rows(xa);
    try {
      x = stacked(safe_upsample(up, coarse, below_level->to_next->apply(coarse), options.upsampling, &report.upsampling));
    } catch (const std::invalid_argument& e) {
      // A check inside safe upsampling refused one of its own intermediate states (seen: relax_gaps
      // finding a touching pair in cube-impact-sheet's impact, level 0 -> 1 at frames 30 and 31).
      // Like every refusal it depends only on the frames, so it is one: the farm continues the
      // subset horizontally instead of failing the job on every worker.
      throw UpsamplingFailed(std::string("safe upsampling: ") + e.what());
    }
    // The contact promise, checked where safe upsampling breaks it: a crossing in the start state
    // would be kept by every step after it (the barrier only keeps apart what is apart).
    if (up.contact)
      if (const int crossing = count_self_intersections(as_rows(x), hierarchy.levels[static_cast<std::size_t>(l)].rest.F);
          crossing > 0)
        throw UpsamplingFailed("safe upsampling: the upsampled state intersects itself (" + std::to_string(crossing) +
                               " face pairs); the level cannot start from it");
    v = below_level->to_next->U_stacked() * ((xa - xb) / h);
    report.vertical_start = true;
  }

  // The stitch's guide (LevelTaskInputs::stitch_target), a term of the level's potential only here.
  GuideTerm* guide = nullptr;
  if (inputs.stitch_frames > 0) {
    auto term = std::make_unique<GuideTerm>(sys.inertia->masses());
    guide = term.get();
    sys.ip.add_term(std::move(term));
  }

  // The start offset (kLevelStartFrames), from the levels' initial positions rather than the level
  // below's stored frame 0 (a task resumed or continued within the first frames is not sent frame 0),
  // kept per vertex in the frame of its coarse face (ShellProlongation::vertex_rotations at frame 0)
  // so that it turns with the level below.
  Positions start_offset;
  if (refining && a < kLevelStartFrames) {
    const Positions below0 = as_rows(level_initial_positions(scene, hierarchy, l - 1));
    start_offset = as_rows(level_initial_positions(scene, hierarchy, l)) - below_level->to_next->apply(below0);
    const std::vector<Mat3> q0 = below_level->to_next->vertex_rotations(below0);
    for (Eigen::Index i = 0; i < start_offset.rows(); ++i)
      start_offset.row(i) = (q0[static_cast<std::size_t>(i)].transpose() * start_offset.row(i).transpose()).transpose();
  }

  Eigen::VectorXd x_hat;
  for (int t = a; t < b; ++t) {
    if (guide && t + 1 <= seam + inputs.stitch_frames)  // after the stitch the guide keeps its last target, at weight 0
      guide->set_guide(inputs.stitch_target(t + 1), stitch_weight(double(t + 1 - seam) / inputs.stitch_frames));
    else if (guide && t == seam + inputs.stitch_frames)
      guide->set_weight(0.0);
    StepInput in;
    if (refining) {
      // PD eq. 5: the momentum of level l-1, prolonged.
      const Eigen::VectorXd now = below(t), before = below(t - 1);
      x_hat = stacked(below_level->to_next->apply(as_rows(now))) + below_level->to_next->U_stacked() * (now - before);
      if (t < kLevelStartFrames) {
        const double keep = 1.0 - smootherstep(double(t + 1) / kLevelStartFrames);
        const std::vector<Mat3> q = below_level->to_next->vertex_rotations(as_rows(now));
        for (Eigen::Index i = 0; i < start_offset.rows(); ++i)
          x_hat.segment<3>(3 * i) += keep * (q[static_cast<std::size_t>(i)] * start_offset.row(i).transpose());
      }
      in.inertia_target = &x_hat;
    }
    FrameRecord r = stepper.step(t, x, v, in);
    if (!r.newton.converged) ++report.unconverged_steps;
    sink(r);
  }
  return report;
}

}  // namespace pd
