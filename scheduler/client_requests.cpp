// pd-scheduler: the answer to each client request (protocol/protocol.h, "Requests").
#include <algorithm>
#include <ctime>
#include <filesystem>
#include <limits>

#include "farm/job_limits.h"
#include "farm/messaging.h"
#include "farm/scene_source.h"
#include "farm/task_graph.h"
#include "progressive/level_system.h"
#include "scene/scene_animation.h"
#include "scheduler/scheduler.h"
#include "util/input_error.h"

namespace pd::scheduler {

namespace {

protocol::ErrorReply error(const std::string& message) { return protocol::ErrorReply{message}; }

}  // namespace

void Scheduler::on_client_message(const std::string& identity, const protocol::Parts& parts) {
  protocol::Reply reply;
  try {
    protocol::Request request = protocol::decode_request(parts);
    reply = std::visit([&](auto& m) { return serve(m); }, request);
  } catch (const protocol::ProtocolError& e) {
    event("request_refused", 0, 0, 0, e.what(), false);
    reply = error(std::string("malformed request: ") + e.what());
  } catch (const std::exception& e) {  // the store refused (an id out of range, say)
    reply = error(e.what());
  }
  try {
    if (!farm::send_parts_to(clients_, identity, protocol::encode(reply)))
      event("reply_failed", 0, 0, 0, "client queue full, reply dropped", false);
  } catch (const zmq::error_t& e) {
    event("reply_failed", 0, 0, 0, e.what(), false);  // the client went away
  }
}

protocol::Reply Scheduler::serve(protocol::SubmitJob& m) {
  // The scene is parsed here too (the client checked it already): the farm runs only scenes it can read.
  const std::string scratch = options_.dir + "/scratch/submit";
  Scene scene;
  try {
    std::filesystem::remove_all(scratch);
    scene = farm::scene_from_source(m.scene, scratch);
    parse_level_hessian(m.hessian);
  } catch (const std::exception& e) {
    return error(e.what());
  }
  if (m.subsets < 1) return error("submit: subsets: must be >= 1, got " + std::to_string(m.subsets));
  if (m.stitch > farm::kMaxStitchFrames)
    return error("submit: stitch: must be <= " + std::to_string(farm::kMaxStitchFrames) + ", got " + std::to_string(m.stitch));
  if (m.levels < 0 || m.frames < 0 || m.preview_chunk < 0)
    return error("submit: levels, frames and preview_chunk must be >= 0 (0 = the scene's)");
  NewJob job;
  job.name = scene.name;
  job.scene = m.scene;
  job.frames = m.frames > 0 ? m.frames : scene.frames;
  try {
    check_animations_cover(scene, job.frames);
  } catch (const InputError& e) {
    return error(e.what());
  }
  job.levels = m.levels > 0 ? m.levels : scene.hierarchy.levels;
  job.subsets = m.subsets;
  job.priority = m.priority;
  job.preview_only = m.preview_only;
  job.preview_chunk = m.preview_chunk > 0 ? m.preview_chunk : farm::default_preview_chunk(job.frames);
  job.hessian = m.hessian;
  job.stitch = m.stitch;
  farm::GraphOptions g;
  g.frames = job.frames;
  g.levels = job.levels;
  g.subsets = job.subsets;
  g.preview_chunk = job.preview_chunk;
  g.stitch = job.stitch;
  // K >= 2: the refinement levels are added once the preview is stored, with seams placed from it
  // (seams.cpp); K = 1 pipelines them behind the preview from the start.
  const bool deferred = !job.preview_only && job.subsets >= 2 && job.levels >= 2;
  std::vector<NewTask> tasks;
  try {
    // The whole job's size (its deferred refinement and a later pd refine included), before any of it
    // is made (farm/job_limits.h).
    int64_t vertices = 0;
    for (const SceneObject& o : scene.objects) vertices += o.rest.num_vertices();
    farm::check_job_size("submit", g, false, vertices, scene.hierarchy.ratio, farm::free_bytes_at(options_.dir));
    g.preview_only = job.preview_only || deferred;
    tasks = farm::job_tasks(g);
  } catch (const std::invalid_argument& e) {
    return error(e.what());
  }  // an InputError of check_job_size becomes the error reply in on_client_message, like any other
  const int64_t id = store_->add_job(job, tasks);
  event("job_submitted", id, 0, 0,
        job.name + ": " + std::to_string(job.frames) + " frames, " + std::to_string(job.levels) + " levels, K = " +
            std::to_string(job.subsets) + (job.preview_only ? ", preview only" : "") + ", priority " +
            std::to_string(job.priority) + ", " + std::to_string(tasks.size()) + " tasks" +
            (deferred ? " (the refinement levels follow the preview, with seams placed from it)" : ""));
  return protocol::Submitted{id};
}

protocol::Reply Scheduler::serve(protocol::RefineJob& m) {
  const std::optional<JobRow> job = store_->find_job(m.job);
  if (!job) return error("no job " + std::to_string(m.job));
  if (!job->spec.preview_only) return error("job " + std::to_string(m.job) + " already has its refinement levels");
  if (job->state == protocol::JobState::failed || job->state == protocol::JobState::cancelled)
    return error("job " + std::to_string(m.job) + " is " + protocol::to_string(job->state) + ": nothing to refine");
  if (m.subsets < 1) return error("refine: subsets: must be >= 1, got " + std::to_string(m.subsets));
  if (m.stitch > farm::kMaxStitchFrames)
    return error("refine: stitch: must be <= " + std::to_string(farm::kMaxStitchFrames) + ", got " + std::to_string(m.stitch));
  if (job->spec.levels < 2) return error("job " + std::to_string(m.job) + " has one level: nothing to refine");
  farm::GraphOptions g;
  g.frames = job->spec.frames;
  g.levels = job->spec.levels;
  g.subsets = m.subsets;
  g.preview_chunk = job->spec.preview_chunk;
  g.stitch = m.stitch;
  // Its frames' storage was checked at submit, for every level. A refusal (InputError) is the error
  // reply (on_client_message).
  farm::check_job_size("refine", g, true, 0, 2.0, std::numeric_limits<double>::infinity());
  store_->set_subsets(m.job, m.subsets, m.stitch);
  store_->set_preview_only(m.job, false);
  if (m.subsets >= 2) {
    // Pending until the preview is stored whole (now, if it is): seams are placed from it (seams.cpp).
    add_pending_refinement(store_->job(m.job));
    if (refinement_pending(store_->job(m.job)))
      return protocol::Accepted{m.job, "the refinement levels (K = " + std::to_string(m.subsets) +
                                           ") are added once the preview is stored, with seams placed from it"};
    int added = 0;
    for (const TaskRow& t : store_->tasks(m.job)) added += t.level >= 1 ? 1 : 0;
    return protocol::Accepted{m.job, "added " + std::to_string(added) + " refinement tasks, seams placed from the preview"};
  }
  const std::vector<NewTask> tasks = farm::refinement_tasks(g);
  store_->add_tasks(m.job, tasks);
  event("job_refined", m.job, 0, 0, std::to_string(tasks.size()) + " refinement tasks, K = " + std::to_string(m.subsets));
  return protocol::Accepted{m.job, "added " + std::to_string(tasks.size()) + " refinement tasks"};
}

protocol::JobStatus Scheduler::job_status(const JobRow& job) {
  protocol::JobStatus js;
  js.id = job.id;
  js.name = job.spec.name;
  js.state = job.state;
  js.reason = job.reason;
  js.priority = job.spec.priority;
  js.frames = job.spec.frames;
  js.subsets = job.spec.subsets;
  js.stitch = job.spec.stitch;
  js.seams = job.seams;
  js.preview_only = job.spec.preview_only;
  js.elapsed_seconds = (job.finished > 0 ? job.finished : unix_now()) - job.submitted;
  const std::vector<int> stored = store_->frames_stored(job.id);
  const JobFile* f = files_.find(job.id);
  const int solved_levels = job.spec.preview_only ? 1 : job.spec.levels;
  double remaining = 0.0;
  bool known = true;
  for (int l = 0; l < solved_levels; ++l) {
    protocol::LevelProgress p;
    p.level = l;
    p.frames_done = l < static_cast<int>(stored.size()) ? stored[l] : 0;
    p.frames_total = job.spec.frames + 1;
    p.vertices = f ? f->vertices[l] : 0;
    js.levels.push_back(p);
    auto it = step_seconds_.find({job.id, l});
    if (it == step_seconds_.end() || it->second.second == 0) known = known && p.frames_done == p.frames_total;
    else remaining += (p.frames_total - p.frames_done) * it->second.first / it->second.second;
  }
  std::map<int64_t, std::string> names;
  for (const WorkerRow& w : store_->workers()) names[w.id] = w.name;
  int running = 0;
  for (const TaskRow& t : store_->tasks(job.id)) {
    protocol::TaskStatus ts;
    ts.id = t.id;
    ts.kind = t.kind;
    ts.level = t.level;
    ts.first = t.first;
    ts.last = t.last;
    ts.state = t.state;
    ts.reason = t.reason;
    ts.attempts = t.attempts;
    ts.horizontal = !t.stitch && store_->continues_horizontally(t.id);
    ts.stitch = t.stitch;
    ts.worker = t.worker ? names[t.worker] : "";
    if (const std::optional<farm::FrameRange> own = farm::produced_frames(as_new_task(t)))
      ts.frames_done = static_cast<int>(store_->stored_frames(job.id, own->level, own->first, own->last).size());
    else
      ts.frames_done = t.state == protocol::TaskState::done ? 1 : 0;
    running += t.state == protocol::TaskState::running;
    js.tasks.push_back(ts);
  }
  // ETA: the remaining frames' measured mean step cost, shared by the tasks running now. Rough:
  // pipelined levels overlap, so it overestimates a job whose levels all run at once.
  const bool ended = job.state == protocol::JobState::done || job.state == protocol::JobState::failed ||
                     job.state == protocol::JobState::cancelled;
  js.eta_seconds = ended ? 0.0 : (known ? remaining / std::max(1, running) : -1.0);
  return js;
}

protocol::Reply Scheduler::serve(protocol::StatusRequest& m) {
  protocol::StatusReply r;
  if (m.job != 0) {
    const std::optional<JobRow> job = store_->find_job(m.job);
    if (!job) return error("no job " + std::to_string(m.job));
    r.jobs.push_back(job_status(*job));
  } else {
    for (const JobRow& job : store_->jobs()) r.jobs.push_back(job_status(job));
  }
  return r;
}

protocol::Reply Scheduler::serve(protocol::FetchRequest& m) {
  if (!store_->find_job(m.job)) return error("no job " + std::to_string(m.job));
  if (!files_.find(m.job)) return error("job " + std::to_string(m.job) + " has no frame file yet (its hierarchy is being built)");
  protocol::FetchReply r;
  r.job = m.job;
  try {
    r.blob = files_.read_bytes(m.job);
  } catch (const InputError& e) {
    return error(e.what());
  }
  event("job_fetched", m.job, 0, 0, std::to_string(r.blob.size()) + " bytes", false);
  return r;
}

protocol::Reply Scheduler::serve(protocol::CancelJob& m) {
  const std::optional<JobRow> job = store_->find_job(m.job);
  if (!job) return error("no job " + std::to_string(m.job));
  if (job->state == protocol::JobState::done || job->state == protocol::JobState::failed ||
      job->state == protocol::JobState::cancelled)
    return error("job " + std::to_string(m.job) + " is already " + protocol::to_string(job->state));
  store_->cancel_job(m.job);
  cancel_attempts_of_job(m.job, "job cancelled");
  event("job_cancelled", m.job, 0, 0, "");
  return protocol::Accepted{m.job, "cancelled"};
}

protocol::Reply Scheduler::serve(protocol::RequeueJob& m) {
  const std::optional<JobRow> job = store_->find_job(m.job);
  if (!job) return error("no job " + std::to_string(m.job));
  if (job->state != protocol::JobState::failed)
    return error("job " + std::to_string(m.job) + " is " + protocol::to_string(job->state) +
                 "; only a failed job can be requeued");
  const int tasks = store_->requeue_job(m.job);
  event("job_requeued", m.job, 0, 0, std::to_string(tasks) + " failed or blocked tasks back to waiting");
  return protocol::Accepted{m.job, "requeued " + std::to_string(tasks) + " tasks"};
}

protocol::Reply Scheduler::serve(protocol::WorkersRequest&) {
  protocol::WorkersReply r;
  std::map<int64_t, const Session*> live;
  for (const auto& [identity, s] : sessions_) live[s.worker] = &s;
  const double now = unix_now();
  for (const WorkerRow& w : store_->workers()) {
    protocol::WorkerStatus ws;
    ws.id = w.id;
    ws.name = w.name;
    ws.host = w.host;
    ws.version = w.version;
    ws.cores = w.cores;
    auto it = live.find(w.id);
    ws.state = it == live.end() ? "lost" : (it->second->attempt ? "busy" : "idle");
    ws.task = it == live.end() ? 0 : it->second->task;
    ws.seen_seconds_ago = now - w.last_seen;
    ws.tasks_done = w.tasks_done;
    r.workers.push_back(ws);
  }
  slurm_->fill(r, now);
  for (protocol::WorkerStatus& ws : r.workers)
    for (const protocol::SlurmWorkerStatus& sw : r.slurm)
      if (sw.worker == ws.name) {
        ws.slurm_job = sw.slurm_job;  // newest first: the Slurm job it runs as now, or ran as last
        break;
      }
  return r;
}

protocol::Reply Scheduler::serve(protocol::AddSlurmWorkers& m) {
  try {
    return slurm_->add(m, unix_now());
  } catch (const InputError& e) {
    return error(e.what());
  }
}

protocol::Reply Scheduler::serve(protocol::RemoveSlurmWorkers& m) {
  try {
    return slurm_->remove(m, [this](const std::string& name) { return worker_busy(name); }, unix_now());
  } catch (const InputError& e) {
    return error(e.what());
  }
}

}  // namespace pd::scheduler
