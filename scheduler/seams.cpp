// pd-scheduler: refinement levels whose seams are placed from the stored preview (farm/seam_placement.h).
//
// A job with K >= 2 time subsets gets its refinement tasks only once its preview (level 0) is stored
// whole: the scheduler then knows where the shot is calm and cuts the levels there. Until then the
// refinement is pending, which the store says without a flag of its own: a job that is not preview
// only, has more than one level and has no task above level 0. K = 1 keeps the levels pipelined
// behind the preview from the start (no seam to place). It costs K >= 2 the overlap of level 1's
// first subset with the preview, the cheapest level (about 2 % of the flag's work).
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "farm/seam_placement.h"
#include "farm/task_graph.h"
#include "scheduler/scheduler.h"

namespace pd::scheduler {

bool Scheduler::refinement_pending(const JobRow& job) const {
  if (job.spec.preview_only || job.spec.levels < 2) return false;
  for (const TaskRow& t : store_->tasks(job.id))
    if (t.level >= 1) return false;
  return true;
}

std::vector<int> Scheduler::place_job_seams(const JobRow& job) {
  // Each preview frame read once, from the store (positions and statistics together): the profile
  // asks for frame t's positions and then its contact pairs.
  std::optional<FrameData> d;
  const farm::PreviewProfile p = farm::preview_profile(
      job.spec.frames,
      [&](int t) {
        d = store_->frame_data(job.id, {0, t});
        if (!d) throw std::logic_error("seams: preview frame " + std::to_string(t) + " is not stored");
        return Positions(Eigen::Map<const Positions>(d->positions.data(), Eigen::Index(d->positions.size() / 3), 3));
      },
      [&](int) {
        for (const auto& [name, value] : d->stats)
          if (name == "contact_active_pairs") return value;
        return std::numeric_limits<double>::quiet_NaN();
      });
  std::vector<int> seams;
  std::vector<std::string> reasons;
  std::string why;
  for (const farm::PlacedSeam& s : farm::place_seams(p, job.spec.subsets)) {
    seams.push_back(s.frame);
    reasons.push_back(s.reason);
    why += (why.empty() ? "" : "; ") + s.reason;
  }
  store_->set_seams(job.id, reasons);
  event("seams_placed", job.id, 0, 0, why);
  return seams;
}

void Scheduler::add_pending_refinement(const JobRow& job) {
  if (job.state == protocol::JobState::failed || job.state == protocol::JobState::cancelled) return;
  if (!refinement_pending(job) || store_->frames_stored(job.id)[0] != job.spec.frames + 1) return;
  farm::GraphOptions g;
  g.frames = job.spec.frames;
  g.levels = job.spec.levels;
  g.subsets = job.spec.subsets;
  g.preview_chunk = job.spec.preview_chunk;
  g.stitch = job.spec.stitch;
  const std::vector<NewTask> tasks =
      farm::refinement_tasks(g, job.spec.subsets >= 2 ? place_job_seams(job) : std::vector<int>{});
  store_->add_tasks(job.id, tasks);
  event("job_refined", job.id, 0, 0,
        std::to_string(tasks.size()) + " refinement tasks, K = " + std::to_string(job.spec.subsets) +
            ", seams placed from the stored preview");
}

}  // namespace pd::scheduler
