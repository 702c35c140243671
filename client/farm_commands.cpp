// The farm's client commands: pd submit, status, fetch, cancel, refine, requeue, workers. Each sends requests
// to the scheduler's client endpoint (farm_client.h) and prints the replies; nothing runs here.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "farm/curve.h"
#include "farm/slurm.h"
#include "farm_client.h"
#include "output_files.h"
#include "progress.h"
#include "util/input_error.h"

namespace pd::cli {
namespace {

using protocol::JobState;
using protocol::JobStatus;
using protocol::TaskKind;
using protocol::TaskState;
using protocol::TaskStatus;

void print_json(const nlohmann::json& j) { std::printf("%s\n", j.dump().c_str()); }

void print_text_block(const std::string& text) {
  std::fputs(text.c_str(), stdout);
  if (text.empty() || text.back() != '\n') std::fputc('\n', stdout);
}

// "[#########.......]": `width` cells, filled in proportion to done / total.
std::string bar(int done, int total, int width = 16) {
  const double frac = total > 0 ? std::clamp(double(done) / total, 0.0, 1.0) : 0.0;
  const int filled = static_cast<int>(std::floor(frac * width));
  return "[" + std::string(filled, '#') + std::string(width - filled, '.') + "]";
}

// "1 frame", "31 frames".
std::string counted(int n, const std::string& noun) { return std::to_string(n) + " " + noun + (n == 1 ? "" : "s"); }

std::string task_range(const TaskStatus& t) {
  if (t.kind == TaskKind::hierarchy) return "hierarchy";
  return "level " + std::to_string(t.level) + " (" + std::to_string(t.first) + ", " + std::to_string(t.last) + "]";
}

// One job: a header, one line per level, then the running tasks and those that failed or are blocked.
void print_job(const JobStatus& j) {
  std::string header = "job " + std::to_string(j.id) + "  " + j.name + "  " + protocol::to_string(j.state);
  if (j.state == JobState::failed && !j.reason.empty()) header += ": " + j.reason;
  if (j.preview_only) header += "  (preview only)";
  header += "  elapsed " + format_duration(j.elapsed_seconds);
  if (!job_finished(j.state)) header += "  ETA " + format_duration(j.eta_seconds);
  std::printf("%s\n", header.c_str());
  if (!j.seams.empty()) {
    const std::string stitch = j.stitch >= 2 ? "each stitched over " + std::to_string(j.stitch) + " frames" : "not stitched";
    std::printf("  seams (K = %d, %s):\n", j.subsets, stitch.c_str());
    for (const std::string& s : j.seams) std::printf("    %s\n", s.c_str());
  }
  for (const protocol::LevelProgress& l : j.levels) {
    const std::string vertices = l.vertices > 0 ? std::to_string(l.vertices) + " vertices" : "hierarchy not built yet";
    std::printf("  level %d  %s  %d/%d frames  %s\n", l.level, bar(l.frames_done, l.frames_total).c_str(),
                l.frames_done, l.frames_total, vertices.c_str());
  }
  for (const TaskStatus& t : j.tasks) {
    const std::string what = "  task " + std::to_string(t.id) + " " + task_range(t);
    if (t.state == TaskState::running) {
      const std::string frames = t.kind == TaskKind::level ? ": " + counted(t.frames_done, "frame") + "," : ",";
      std::printf("%s%s on %s%s\n", what.c_str(), frames.c_str(), t.worker.empty() ? "?" : t.worker.c_str(),
                  t.horizontal ? " (continuing horizontally: its vertical start was refused)" : "");
    } else if (t.horizontal && t.state == TaskState::waiting) {
      std::printf("%s: waits for level %d's frame %d (its vertical start was refused)\n", what.c_str(), t.level,
                  t.first);
    } else if (t.state == TaskState::failed || t.state == TaskState::blocked) {
      const std::string attempts = t.state == TaskState::failed ? " after " + counted(t.attempts, "attempt") : "";
      std::printf("%s: %s%s%s%s\n", what.c_str(), protocol::to_string(t.state).c_str(), attempts.c_str(),
                  t.reason.empty() ? "" : ": ", t.reason.c_str());
    }
  }
}

void print_status(const protocol::StatusReply& reply, bool json) {
  if (json) {
    print_text_block(protocol::to_json_text(reply));
    return;
  }
  if (reply.jobs.empty()) std::printf("no jobs\n");
  for (const JobStatus& j : reply.jobs) print_job(j);
}

bool all_finished(const protocol::StatusReply& reply) {
  return std::all_of(reply.jobs.begin(), reply.jobs.end(), [](const JobStatus& j) { return job_finished(j.state); });
}

// --wait's exit code: 0 when the job is done, 1 (with the reason on stderr) when it failed or was cancelled.
int wait_exit_code(const protocol::StatusReply& reply, int64_t job) {
  const auto it = std::find_if(reply.jobs.begin(), reply.jobs.end(), [&](const JobStatus& j) { return j.id == job; });
  if (it == reply.jobs.end()) throw InputError("the scheduler's status reply does not list job " + std::to_string(job));
  if (it->state == JobState::done) return 0;
  std::fprintf(stderr, "pd: job %lld %s%s%s\n", static_cast<long long>(job), protocol::to_string(it->state).c_str(),
               it->reason.empty() ? "" : ": ", it->reason.c_str());
  return 1;
}

// A client of the farm that --farm names, with the CURVE keys of --server-key and --key.
FarmClient farm_client_for(const std::string& farm, const FarmKeyFiles& keys,
                           std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
  return FarmClient(farm_endpoint(farm), timeout, farm::read_client_keys(keys.server_key, keys.key));
}

std::string padded(const std::string& s, std::size_t width) {
  return s.size() >= width ? s : s + std::string(width - s.size(), ' ');
}

}  // namespace

int submit(const SubmitArgs& args) {
  check_scene_files(args.scene);
  protocol::SubmitJob job;
  job.scene = read_job_scene(args.scene, args.levels);  // a bad scene stops here, as in pd simulate
  job.preview_only = args.preview_only;
  job.levels = args.levels;
  job.subsets = args.subsets;
  job.stitch = args.stitch;
  job.priority = args.priority;
  job.frames = args.frames;
  job.preview_chunk = args.preview_chunk;
  job.hessian = args.hessian;
  FarmClient client = farm_client_for(args.farm, args.keys);
  const protocol::Submitted submitted = client.request_as<protocol::Submitted>(job);
  if (args.json) print_json({{"job", submitted.job}});
  else std::printf("%lld\n", static_cast<long long>(submitted.job));
  return 0;
}

int status(const StatusArgs& args) {
  if (args.wait && args.job == 0) throw InputError("--wait: needs a JOB (the job to wait for)");
  FarmClient client = farm_client_for(args.farm, args.keys);  // one socket for every poll of a --watch or --wait loop
  const bool tty = isatty(fileno(stdout)) != 0;
  const auto interval = std::chrono::duration<double>(args.interval);
  for (;;) {
    const protocol::StatusReply reply = client.request_as<protocol::StatusReply>(protocol::StatusRequest{args.job});
    const bool ended = all_finished(reply);
    if (args.watch) {
      // A terminal shows the latest snapshot in place; a file or pipe gets every snapshot in turn.
      if (tty) std::printf("\033[H\033[2J");
      if (tty && !args.json)
        std::printf("farm %s, every %gs (Ctrl-C to stop)\n\n", client.endpoint().c_str(), args.interval);
      print_status(reply, args.json);
      if (!tty && !ended) std::printf("\n");
      std::fflush(stdout);
    } else if (!args.wait || ended) {
      print_status(reply, args.json);
    }
    if (ended || (!args.watch && !args.wait)) return args.wait ? wait_exit_code(reply, args.job) : 0;
    std::this_thread::sleep_for(interval);
  }
}

int fetch(const FetchArgs& args) {
  check_output_file(args.out, "--out", {});  // no FIFO or device (the rename would replace it)
  check_output_path(args.out);
  // A whole job file (up to protocol::kMaxMessageBytes) may take longer than a status reply.
  FarmClient client = farm_client_for(args.farm, args.keys, std::chrono::seconds(60));
  const std::size_t bytes = fetch_to_file(client, args.job, args.out);
  if (args.json) print_json({{"job", args.job}, {"file", args.out}, {"bytes", bytes}});
  return 0;
}

int cancel(const JobActionArgs& args) {
  FarmClient client = farm_client_for(args.farm, args.keys);
  const auto accepted = client.request_as<protocol::Accepted>(protocol::CancelJob{args.job});
  if (args.json) print_json({{"job", accepted.job}, {"message", accepted.message}});
  else std::printf("job %lld: %s\n", static_cast<long long>(accepted.job),
                   accepted.message.empty() ? "cancelled" : accepted.message.c_str());
  return 0;
}

int refine(const JobActionArgs& args) {
  FarmClient client = farm_client_for(args.farm, args.keys);
  const auto accepted = client.request_as<protocol::Accepted>(protocol::RefineJob{args.job, args.subsets, args.stitch});
  if (args.json) print_json({{"job", accepted.job}, {"message", accepted.message}});
  else std::printf("job %lld: %s\n", static_cast<long long>(accepted.job),
                   accepted.message.empty() ? "refinement levels added" : accepted.message.c_str());
  return 0;
}

int requeue(const JobActionArgs& args) {
  FarmClient client = farm_client_for(args.farm, args.keys);
  const auto accepted = client.request_as<protocol::Accepted>(protocol::RequeueJob{args.job});
  if (args.json) print_json({{"job", accepted.job}, {"message", accepted.message}});
  else std::printf("job %lld: %s\n", static_cast<long long>(accepted.job), accepted.message.c_str());
  return 0;
}

namespace {

// Prints rows as columns two spaces apart, the first row a header.
void print_table(const std::vector<std::vector<std::string>>& rows) {
  std::vector<std::size_t> width(rows[0].size(), 0);
  for (const auto& row : rows)
    for (std::size_t c = 0; c < row.size(); ++c) width[c] = std::max(width[c], row[c].size());
  for (const auto& row : rows) {
    std::string line;
    for (std::size_t c = 0; c < row.size(); ++c) line += c + 1 < row.size() ? padded(row[c], width[c] + 2) : row[c];
    std::printf("%s\n", line.c_str());
  }
}

void print_workers(const protocol::WorkersReply& reply) {
  if (reply.workers.empty()) std::printf("no workers\n");
  if (!reply.workers.empty()) {
    std::vector<std::vector<std::string>> rows = {
        {"id", "name", "host", "state", "task", "cores", "tasks done", "seen", "slurm job"}};
    for (const protocol::WorkerStatus& w : reply.workers)
      rows.push_back({std::to_string(w.id), w.name, w.host, w.state, w.task != 0 ? std::to_string(w.task) : "-",
                      std::to_string(w.cores), std::to_string(w.tasks_done),
                      format_duration(w.seen_seconds_ago) + " ago", w.slurm_job.empty() ? "-" : w.slurm_job});
    print_table(rows);
  }
  if (reply.slurm.empty() && reply.slurm_keep == 0) return;
  std::printf("\nslurm workers (keep %d)\n", reply.slurm_keep);
  if (reply.slurm.empty()) return;
  std::vector<std::vector<std::string>> rows = {{"slurm job", "state", "worker", "submitted", "note"}};
  for (const protocol::SlurmWorkerStatus& s : reply.slurm) {
    std::string note = s.reason == "None" ? "" : s.reason;
    if (s.draining) note += std::string(note.empty() ? "" : ", ") + "draining";
    if (s.replacement) note += std::string(note.empty() ? "" : ", ") + "replacement";
    rows.push_back({s.slurm_job, s.state, s.worker.empty() ? "-" : s.worker,
                    format_duration(s.submitted_seconds_ago) + " ago", note});
  }
  print_table(rows);
}

}  // namespace

int workers(const WorkersArgs& args) {
  // Checked here too, so that a bad value is answered before the scheduler is asked.
  if (args.action == WorkersArgs::Action::add) farm::check_slurm_request(args.add);
  if (args.action == WorkersArgs::Action::remove && !farm::valid_slurm_job_id(args.remove.slurm_job))
    throw InputError("--slurm: expected a Slurm job id (123) or array task id (123_4), got '" +
                     args.remove.slurm_job.substr(0, 40) + "'");
  // sbatch and scancel run in the scheduler, bounded by its own 10 s limit per call.
  FarmClient client = farm_client_for(args.farm, args.keys,
                                      args.action == WorkersArgs::Action::list ? std::chrono::seconds(5)
                                                                               : std::chrono::seconds(30));
  if (args.action != WorkersArgs::Action::list) {
    const auto accepted = args.action == WorkersArgs::Action::add
                              ? client.request_as<protocol::SlurmAccepted>(args.add)
                              : client.request_as<protocol::SlurmAccepted>(args.remove);
    if (args.json) {
      print_json({{"slurm_job", accepted.slurm_job}, {"tasks", accepted.tasks}, {"message", accepted.message}});
    } else {
      std::printf("%s\n", accepted.message.c_str());
      for (const std::string& t : accepted.tasks) std::printf("  %s\n", t.c_str());
    }
    return 0;
  }
  const auto reply = client.request_as<protocol::WorkersReply>(protocol::WorkersRequest{});
  if (args.json) print_text_block(protocol::to_json_text(reply));
  else print_workers(reply);
  return 0;
}

}  // namespace pd::cli
