// pd run: the embedded farm. One scheduler and N workers on this machine (local_farm.h) run one job:
// submit, show progress, fetch the job file, stop everything. Ctrl-C (SIGINT) or SIGTERM stops the
// farm and exits 130; any error stops it too (LocalFarm's destructor).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "commands.h"
#include "farm_client.h"
#include "local_farm.h"
#include "output_files.h"
#include "progress.h"
#include "stop_signals.h"
#include "util/input_error.h"
#include "util/parallel.h"

namespace pd::cli {
namespace {

namespace fs = std::filesystem;

void throw_if_stop_requested() {
  if (StopSignals::received() != 0) throw Interrupted();
}

// Sleeps `total`, in short steps so that a stop request ends it early.
void sleep_unless_stopped(std::chrono::milliseconds total) {
  const auto end = std::chrono::steady_clock::now() + total;
  while (std::chrono::steady_clock::now() < end) {
    throw_if_stop_requested();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  throw_if_stop_requested();
}

// The farm folder: --keep-farm DIR as given (created if missing, left in place), or a fresh temporary
// folder removed when the command ends, however it ends.
class FarmFolder {
 public:
  explicit FarmFolder(const std::string& keep) : keep_(!keep.empty()) {
    if (keep_) {
      path_ = keep;
      return;
    }
    std::string pattern = (fs::temp_directory_path() / "pd-run-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("cannot create a temporary farm folder");
    path_ = pattern;
  }
  ~FarmFolder() {
    std::error_code ec;
    if (!keep_) fs::remove_all(path_, ec);
  }
  FarmFolder(const FarmFolder&) = delete;
  FarmFolder& operator=(const FarmFolder&) = delete;
  const std::string& path() const { return path_; }

 private:
  bool keep_;
  std::string path_;
};

// Progress of the job on stderr. A terminal gets a header and one line per level, redrawn in place; a
// file or pipe gets one line per level when that level is complete, and nothing else.
class RunProgress {
 public:
  RunProgress() : tty_(isatty(fileno(stderr)) != 0) {}

  void show(const protocol::JobStatus& j) {
    if (!tty_) {
      for (const protocol::LevelProgress& l : j.levels) {
        if (l.frames_total <= 0 || l.frames_done < l.frames_total) continue;
        if (l.level < static_cast<int>(reported_.size()) && reported_[static_cast<std::size_t>(l.level)]) continue;
        if (l.level >= static_cast<int>(reported_.size())) reported_.resize(static_cast<std::size_t>(l.level) + 1);
        reported_[static_cast<std::size_t>(l.level)] = true;
        std::fprintf(stderr, "level %d done: %d frames, %d vertices, %s after submission\n", l.level, l.frames_total,
                     l.vertices, format_duration(j.elapsed_seconds).c_str());
      }
      return;
    }
    if (lines_ > 0) std::fprintf(stderr, "\033[%dA", lines_);  // back to the first line of the last drawing
    std::string eta = job_finished(j.state) ? "" : "  ETA " + format_duration(j.eta_seconds);
    std::fprintf(stderr, "\rjob %lld %s  %s%s\033[K\n", static_cast<long long>(j.id),
                 protocol::to_string(j.state).c_str(), format_duration(j.elapsed_seconds).c_str(), eta.c_str());
    for (const protocol::LevelProgress& l : j.levels) {
      const int width = 30;
      const int filled = l.frames_total > 0 ? std::min(width, width * l.frames_done / l.frames_total) : 0;
      const std::string vertices = l.vertices > 0 ? "  " + std::to_string(l.vertices) + " vertices" : "";
      std::fprintf(stderr, "\rlevel %d [%s%s] %d/%d%s\033[K\n", l.level, std::string(filled, '#').c_str(),
                   std::string(width - filled, '.').c_str(), l.frames_done, l.frames_total, vertices.c_str());
    }
    lines_ = 1 + static_cast<int>(j.levels.size());
    std::fflush(stderr);
  }

  bool tty() const { return tty_; }

 private:
  bool tty_;
  int lines_ = 0;
  std::vector<bool> reported_;
};

// Stops the command when the scheduler is gone, or every worker is (the job could never finish); a
// single lost worker is told and the job continues on the others.
void check_children(LocalFarm& farm) {
  for (const ChildExit& e : farm.poll_exits()) {
    const std::string tail = tail_of_file(e.log, 10);
    const std::string log = tail.empty() ? "" : "\n" + e.log + " ends with:\n" + tail;
    if (e.is_scheduler) throw std::runtime_error(e.description + log);
    if (farm.running_workers() == 0)
      throw std::runtime_error("every pd-worker has exited; the last: " + e.description + log);
    std::fprintf(stderr, "pd: warning: %s; the job goes on with %d worker%s%s\n", e.description.c_str(),
                 farm.running_workers(), farm.running_workers() == 1 ? "" : "s", log.c_str());
  }
}

protocol::JobStatus job_status(FarmClient& client, int64_t job) {
  protocol::StatusReply reply = client.request_as<protocol::StatusReply>(protocol::StatusRequest{job});
  for (protocol::JobStatus& j : reply.jobs)
    if (j.id == job) return std::move(j);
  throw InputError("farm " + client.endpoint() + ": the status reply does not list job " + std::to_string(job));
}

// Runs the job on a started farm until it ends; returns the exit code (0: done and fetched).
int run_job(const RunArgs& args, const protocol::SubmitJob& submit, LocalFarm& farm) {
  FarmClient client(farm.clients_endpoint());
  const int64_t job = client.request_as<protocol::Submitted>(submit).job;
  RunProgress progress;
  protocol::JobStatus status;
  for (;;) {
    throw_if_stop_requested();
    check_children(farm);
    status = job_status(client, job);
    progress.show(status);
    if (job_finished(status.state)) break;
    sleep_unless_stopped(std::chrono::milliseconds(500));
  }
  if (status.state != protocol::JobState::done) {
    std::fprintf(stderr, "pd: job %lld %s%s%s\n", static_cast<long long>(job),
                 protocol::to_string(status.state).c_str(), status.reason.empty() ? "" : ": ", status.reason.c_str());
    return 1;
  }
  FarmClient fetcher(farm.clients_endpoint(), std::chrono::seconds(60));
  const std::size_t bytes = fetch_to_file(fetcher, job, args.out);
  if (progress.tty()) {
    std::fprintf(stderr, "wrote %s (%.1f MB) in %s\n", args.out.c_str(), bytes / 1e6,
                 format_duration(status.elapsed_seconds).c_str());
  }
  return 0;
}

}  // namespace

int run(const RunArgs& args) {
  // Everything that can be refused is checked before a process is started.
  check_scene_files(args.scene);
  check_output_file(args.out, "--out", {args.scene});
  protocol::SubmitJob submit;
  submit.scene = read_job_scene(args.scene, args.levels);
  submit.preview_only = args.preview_only;
  submit.levels = args.levels;
  submit.subsets = args.subsets;
  submit.stitch = args.stitch;
  submit.frames = args.frames;
  submit.hessian = args.hessian;
  check_output_path(args.out);
  if (args.workers < 1) throw InputError("--workers: must be >= 1, got " + std::to_string(args.workers));
  const FarmBinaries binaries = find_farm_binaries();

  const StopSignals signals(0);  // no SA_RESTART: waits return EINTR
  FarmFolder folder(args.keep_farm);
  LocalFarm farm(binaries);
  farm.set_stop_flag(StopSignals::flag());
  try {
    // The workers share this machine: by default each gets an equal share of its cores.
    const int threads = args.threads > 0 ? args.threads : std::max(1, effective_element_threads() / args.workers);
    farm.start(folder.path(), args.workers, threads);
    const int code = run_job(args, submit, farm);
    farm.stop();
    return code;
  } catch (const Interrupted&) {
    farm.stop();
    std::fprintf(stderr, "\npd: interrupted; the farm was stopped\n");
    return 130;
  } catch (const InputError&) {
    throw;  // main prints it (exit 2); the farm stops as `farm` goes out of scope
  } catch (const std::runtime_error& e) {
    farm.stop();
    std::fprintf(stderr, "pd: error: %s\n", e.what());
    if (args.keep_farm.empty())
      std::fprintf(stderr, "pd: (the farm folder is removed; --keep-farm DIR keeps its logs)\n");
    return 1;
  }
}

}  // namespace pd::cli
