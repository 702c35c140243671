#pragma once
// pd-scheduler's Slurm workers (docs/deploy.md, "Slurm"): submits pd-workers as Slurm job arrays
// (sbatch with the --slurm-script), follows their Slurm states (squeue every poll period), drains
// and cancels them (scancel), and keeps a target number running while work remains (submitting a
// replacement when one ends). Its state is the SlurmStore (farm.sqlite), so a restarted scheduler
// goes on following the jobs the earlier one submitted.
//
// The Slurm commands run on the scheduler's thread, each bounded by kSlurmCommandTimeout: a
// slurmctld that does not answer stalls the scheduler for at most that long per call (the workers'
// liveness allows 3 heartbeats, so keep the timeout below that when heartbeats are short; every
// call is logged with its duration).
#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "protocol/protocol.h"
#include "store/slurm_store.h"
#include "util/subprocess.h"

namespace pd::scheduler {

struct SlurmOptions {
  std::string script;          // --slurm-script: the job script; "" disables Slurm
  std::string worker_binary;   // --slurm-worker: the pd-worker the script starts
  std::string connect;         // --slurm-connect: the workers endpoint as compute nodes reach it
  std::string server_key_file, worker_key_file;  // --slurm-server-key / --slurm-worker-key (CURVE)
  std::string log_dir;         // --slurm-log-dir: the array tasks' log files
  std::string job_name = "pd-worker";  // --slurm-job-name
  double poll_seconds = 10.0;          // --slurm-poll
  double scheduler_timeout_s = 300.0;  // --slurm-scheduler-timeout, given to every Slurm worker
};

// Checks and completes the Slurm options at start, before anything is created; InputError naming
// the option. Without a script every other --slurm-* option is refused (it would do nothing). With
// one: the pd-worker defaults to the one beside `own_executable`, the log folder to
// FARM_DIR/slurm, paths become absolute (compute nodes start in other folders), and with CURVE
// (`curve`) both key options are required and read, without it both refused. `workers_endpoint`:
// the configured one; a wildcard address needs --slurm-connect.
void complete_slurm_options(SlurmOptions& slurm, const std::string& farm_dir, const std::string& workers_endpoint,
                            const std::string& own_executable, bool curve);

constexpr std::chrono::milliseconds kSlurmCommandTimeout{10000};
// A replacement that ends this soon after its submission without ever becoming a worker counts as
// a quick death; after kMaxQuickDeaths in a row the keep target is set to 0 (logged), so that a
// broken script or a full partition does not make the scheduler submit jobs for ever.
constexpr double kQuickDeathSeconds = 60.0;
constexpr int kMaxQuickDeaths = 3;
// Ended Slurm workers are shown by pd workers for this long, then forgotten.
constexpr double kForgetEndedSeconds = 3600.0;

class SlurmPool {
 public:
  // Logs one event (kind, message), as Scheduler::event does.
  using EventSink = std::function<void(const std::string& kind, const std::string& message)>;
  // Whether the pd-worker named `name` is running a task now (false when not connected).
  using Busy = std::function<bool(const std::string& name)>;

  SlurmPool(const SlurmOptions& options, const std::string& store_path, EventSink event);

  bool enabled() const { return !options_.script.empty(); }

  // pd workers add --slurm: one sbatch call; InputError (the client gets its message) when Slurm is
  // not enabled, the request is bad or sbatch fails.
  protocol::SlurmAccepted add(const protocol::AddSlurmWorkers& m, double now);
  // pd workers remove --slurm: InputError when no active Slurm worker matches.
  protocol::SlurmAccepted remove(const protocol::RemoveSlurmWorkers& m, const Busy& busy, double now);

  // A worker said hello with Hello.slurm_job = id.
  void worker_joined(const std::string& id, const std::string& name, double now);
  // The worker `name` was lost. Slurm's state of a job this scheduler submitted comes from squeue;
  // one it did not submit (external) is not polled, so it ends here ("ENDED").
  void worker_lost(const std::string& name, double now);
  // The Slurm job of worker `name`, if it is one, draining (it must take no new task).
  bool draining(const std::string& name) const;
  // A draining worker's task ended (or it was idle): cancel its Slurm job now.
  void cancel_drained(const std::string& name, double now);

  // Called every loop turn; polls squeue once per poll period (or at once after poll_soon()), updates
  // the states, cancels draining workers that are idle, and submits replacements for the keep target
  // while `work_remains`.
  void tick(double now, const std::function<bool()>& work_remains, const Busy& busy);
  void poll_soon() { next_poll_ = 0.0; }

  // pd workers: the Slurm part of the reply.
  void fill(protocol::WorkersReply& reply, double now) const;

 private:
  std::string submit(const protocol::AddSlurmWorkers& m, bool replacement, double now);
  // Runs one Slurm command (bounded by kSlurmCommandTimeout); a failure (result.failure non-empty)
  // is logged as slurm_error with its duration.
  CommandResult slurm_command(const std::vector<std::string>& argv);
  void scancel(const std::vector<std::string>& ids, const std::string& why);
  void poll(double now);
  void keep_target(double now, bool work_remains);

  SlurmOptions options_;
  SlurmStore store_;
  EventSink event_;
  double next_poll_ = 0.0;
  int quick_deaths_ = 0;
};

}  // namespace pd::scheduler
