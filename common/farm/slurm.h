#pragma once
// Workers started by Slurm (docs/deploy.md, "Slurm"): what pd-scheduler runs and reads when it
// starts pd-workers as a Slurm job array and follows them. Pure functions of text: the commands are
// run by util/subprocess.h, the state is kept in store/slurm_store.h.
//
// The job script (deploy/slurm/pd-worker.sbatch) is run as
//   sbatch --parsable --array=0-(N-1) --job-name=NAME --output=LOG_DIR/NAME-%A_%a.log --chdir=LOG_DIR
//          [site options]
//          SCRIPT PD_WORKER [pd-worker options]
// so that the script stays a thin, site-editable wrapper: it receives the pd-worker binary and its
// whole command line as arguments (no comma-separated --export values to escape), and each array
// task's pd-worker finds its own Slurm job id in the environment (worker/main.cpp).
//
// Slurm job ids here are text: "<array job>_<array task>" for an array task, "<job>" for a job.
#include <string>
#include <vector>

#include "protocol/protocol.h"

namespace pd::farm {

// Limits on AddSlurmWorkers (one request; the keep target is bounded the same way).
constexpr int kMaxSlurmWorkersPerRequest = 1000;
constexpr int kMaxSlurmCpus = 4096;

// Checks an AddSlurmWorkers request field by field; throws InputError naming the field and the
// allowed form ("--time: expected minutes, M:S, H:M:S, D-H, D-H:M or D-H:M:S, got '1h'").
// partition: 1..64 of [A-Za-z0-9_.-]; time_limit: Slurm's formats or "" (the script's); memory:
// digits with an optional K, M, G or T, or ""; cpus: 0 (the script's) .. kMaxSlurmCpus.
void check_slurm_request(const protocol::AddSlurmWorkers& m);

// "123" or "123_4" (what pd workers remove --slurm takes).
bool valid_slurm_job_id(const std::string& id);

// What one sbatch call needs.
struct SbatchCall {
  std::string script;       // the job script
  std::string job_name;     // --job-name (also how squeue finds this farm's jobs)
  std::string log_dir;      // --output=LOG_DIR/NAME-%A_%a.log (must not hold '%')
  std::vector<std::string> worker_command;  // PD_WORKER and its options, after the script
  protocol::AddSlurmWorkers request;
};

// The argv of the sbatch call (argv[0] = "sbatch"); InputError for a log_dir or job name holding
// '%' (sbatch would read it as a pattern) or a request check_slurm_request refuses.
std::vector<std::string> sbatch_argv(const SbatchCall& call);

// The job id of `sbatch --parsable`'s output ("123" or "123;cluster", then a newline); InputError
// quoting the output when it holds none.
std::string parse_sbatch_job_id(const std::string& output);

// The array task ids "<job>_0" .. "<job>_<count-1>".
std::vector<std::string> array_task_ids(const std::string& job, int count);

// One line of `squeue --noheader --array --states=all --format=%i|%T|%r`.
struct SlurmJobState {
  std::string id;      // "123_4"
  std::string state;   // PENDING, RUNNING, COMPLETED, CANCELLED, TIMEOUT, ...
  std::string reason;  // "None", "Resources", ...
};
// The argv of that squeue call for the jobs named `job_name`.
std::vector<std::string> squeue_argv(const std::string& job_name);
// Parses its output; lines that are not "id|state|reason" are skipped (squeue prints nothing else).
// A pending array whose tasks squeue still shows folded ("123_[2-5]", "123_[1,3]") is unfolded.
std::vector<SlurmJobState> parse_squeue(const std::string& output);

// Whether a Slurm job in this state can still run or runs (PENDING, RUNNING, CONFIGURING,
// SUSPENDED, REQUEUED, REQUEUE_HOLD, RESIZING, SIGNALING, STAGE_OUT; and "SUBMITTED", ours for a job
// not polled yet). Every other state is an end: COMPLETING (its processes are being ended),
// COMPLETED, CANCELLED, TIMEOUT, FAILED, NODE_FAIL, PREEMPTED, OUT_OF_MEMORY, BOOT_FAIL, DEADLINE,
// "GONE" (no longer listed by squeue) and "ENDED" (a job not submitted by the scheduler whose
// worker was lost).
bool slurm_state_active(const std::string& state);

}  // namespace pd::farm
