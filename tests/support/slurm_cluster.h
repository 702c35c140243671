#pragma once
// A real single-node Slurm cluster for the farm's integration tests: munged, slurmctld and slurmd
// (Debian's munge and slurm-wlm 22.05) started in the foreground in a folder of the test's, on
// ports found free, with their own munge key and socket, so that nothing of the machine's own Slurm
// or munge (/etc/slurm, /etc/munge, /run/munge) is read or touched. The node's and the controller's
// addresses are 127.0.0.1; slurmd listens there only, slurmctld (22.05) on every address. Jobs run without
// cgroups (proctrack/linuxproc: a job's processes are the slurmstepd's descendants, found through
// /proc), so scancel kills every process a job started that stayed its descendant (a process that
// daemonizes, i.e. is re-parented to init, escapes, as with any linuxproc cluster).
//
// Everything the cluster starts is stopped by stop() or the destructor: the jobs are cancelled, the
// daemons terminated, and any slurmstepd or job process of this cluster still there is killed.
//
// Folder layout (all under `dir`): slurm.conf, plugstack.conf (empty, so /etc/slurm's is not
// read), munge/ (key, pid, seed; 0700), munge-socket/ (0755), state/ (StateSaveLocation),
// spool/ (SlurmdSpoolDir), log/ (the daemons' log files and stderr).
#include <sys/types.h>

#include <chrono>
#include <string>
#include <vector>

#include "support/process.h"

namespace pd::test {

class SlurmCluster {
 public:
  // "" when this machine can start a cluster, else why not: a binary missing (named), not root
  // (slurmd launches every job step through setuid/setgroups, munged and slurmd refuse to serve
  // other users' jobs otherwise), no host name. Tests skip with GTEST_SKIP() << reason only then.
  static std::string unavailable_reason();

  // Writes a munge key, slurm.conf and plugstack.conf under `dir` (which must exist), starts
  // munged, slurmctld and slurmd (foreground), and returns once sinfo shows the node idle, at most
  // 30 s. Throws std::runtime_error with the daemons' log tails when it cannot (everything started
  // is stopped first). `cpus`: the node's CPUs, one core each (0: this machine's hardware threads).
  explicit SlurmCluster(const std::string& dir, int cpus = 0);
  ~SlurmCluster();  // stop()
  SlurmCluster(const SlurmCluster&) = delete;
  SlurmCluster& operator=(const SlurmCluster&) = delete;

  // Cancels every job, waits (at most 15 s) for squeue to show none and for this cluster's
  // slurmstepd processes to end, terminates slurmd, slurmctld and munged, then SIGKILLs any
  // process of this cluster still there (cluster_processes()). Idempotent; never throws.
  void stop();

  // The environment a Slurm client command (sbatch, squeue, scancel, sinfo, scontrol) needs to
  // talk to this cluster: SLURM_CONF=<dir>/slurm.conf (slurm.conf names the munge socket, so the
  // clients need nothing else for munge). Jobs submitted with it inherit it (sbatch --export=ALL).
  const EnvAdditions& env() const { return env_; }

  // argv run with env() to its end, at most `timeout`. A bare argv[0] ("sbatch") is looked up in
  // /usr/bin, /usr/sbin, /bin (run() does not search PATH).
  RunResult command(std::vector<std::string> argv, std::chrono::milliseconds timeout) const;

  const std::string& dir() const { return dir_; }
  std::string partition() const { return "pdtest"; }
  const std::string& node_name() const { return node_; }
  int cpus() const { return cpus_; }

  // The daemons' log files and stderr (their last lines each), for failure messages.
  std::string log_tails() const;

  // Seconds from the constructor's start to the node showing idle.
  double startup_seconds() const { return startup_seconds_; }

  // The processes that stop() had to SIGKILL after the daemons were terminated (each "pid cmdline");
  // empty after a clean stop.
  const std::vector<std::string>& killed_at_stop() const { return killed_at_stop_; }

  // The live (not zombie) processes of the cluster in `dir`, found through /proc: munged, slurmctld,
  // slurmd, slurmstepd with `dir` on their command line or a file of `dir` open (their log), the
  // descendants of those slurmstepd, and any process whose environment has SLURM_JOB_ID and
  // SLURM_CONF=<dir>/slurm.conf (a job process whose slurmstepd is gone). Never the caller itself.
  static std::vector<pid_t> cluster_processes(const std::string& dir);
  // "munged", "slurmctld" (also for its slurmscriptd), "slurmd" or "slurmstepd" when process `pid`
  // runs that binary, else "" (also when it is gone).
  static std::string daemon_name(pid_t pid);

 private:
  void start();  // the constructor's work; throws
  void write_config(int ctld_port, int slurmd_port) const;
  void wait_for_munge_socket(std::chrono::milliseconds timeout);
  void wait_for_idle_node(std::chrono::milliseconds timeout);
  void throw_if_a_daemon_ended();
  void cancel_jobs_and_wait();

  std::string dir_, node_, conf_;
  int cpus_ = 0;
  EnvAdditions env_;
  Process munged_, slurmctld_, slurmd_;
  bool stopped_ = false;
  double startup_seconds_ = 0.0;
  std::vector<std::string> killed_at_stop_;
};

}  // namespace pd::test
