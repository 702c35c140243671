// pd-scheduler: the farm's one scheduler. Owns FARM_DIR (farm.sqlite, jobs/<job>.h5), binds a
// ROUTER for workers and one for clients (loopback by default; any other address only with CURVE
// keys, scheduler/security.h), prints the bound endpoints as one JSON line on stdout (so a script or
// `pd run` can use port 0), and logs one JSON line per event on stderr.
// `pd-scheduler --generate-keys PREFIX` only writes a key pair (farm/curve.h) and exits.

#include <atomic>
#include <csignal>
#include <memory>
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "farm/curve.h"
#include "scheduler/job_files.h"
#include "scheduler/scheduler.h"
#include "scheduler/security.h"
#include "util/input_error.h"
#include "util/parent_watch.h"
#include "util/subprocess.h"

namespace {

std::atomic<bool> g_stop{false};

std::atomic<bool> g_reload_keys{false};

void on_signal(int) { g_stop = true; }
void on_hangup(int) { g_reload_keys = true; }  // SIGHUP: reload --authorized-keys (systemd's ExecReload)

// --check-hierarchy: exit 0 when the file is a hierarchy with that hash and level count, 2 with the
// reason on stderr when not. Its memory is capped first (4 GiB of address space): a crafted file
// that makes HDF5 allocate without end fails here, not in the scheduler.
int check_hierarchy(const std::string& file, const std::string& hash, int levels) {
  pd::cap_address_space(std::size_t{4} << 30);
  try {
    pd::scheduler::check_hierarchy_file(file, hash, levels);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd-scheduler: error: %s\n", e.what());
    return 2;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pd-scheduler: dispatches progressive-dynamics jobs to pd-worker processes"};
  pd::scheduler::SchedulerOptions options;
  std::string generate_prefix;
  app.add_option("--dir", options.dir,
                 "Farm folder: farm.sqlite and jobs/<job>.h5 (created when missing); required unless --generate-keys");
  app.add_option("--workers-endpoint", options.workers_endpoint,
                 "Where workers connect (port 0: a free port, printed on start)")
      ->capture_default_str();
  app.add_option("--clients-endpoint", options.clients_endpoint,
                 "Where pd clients connect (port 0: a free port, printed on start)")
      ->capture_default_str();
  app.add_option("--heartbeat-ms", options.heartbeat_ms, "Heartbeat period; 3 missed ones lose a worker")
      ->check(CLI::Range(50, 60000))
      ->capture_default_str();
  app.add_option("--key", options.key_file,
                 "CURVE key pair of this scheduler (PREFIX.key from --generate-keys); needed beyond loopback");
  app.add_option("--authorized-keys", options.authorized_keys_file,
                 "Public keys of the workers and clients to admit, one per line; needed with --key");
  pd::scheduler::SlurmOptions& slurm = options.slurm;
  app.add_option("--slurm-script", slurm.script,
                 "Job script for `pd workers add --slurm` (deploy/slurm/pd-worker.sbatch); without it, no Slurm")
      ->check(CLI::ExistingFile);
  app.add_option("--slurm-worker", slurm.worker_binary,
                 "The pd-worker the script starts on compute nodes (default: the one beside this pd-scheduler)");
  app.add_option("--slurm-connect", slurm.connect,
                 "The workers endpoint as compute nodes reach it (default: --workers-endpoint as bound)");
  app.add_option("--slurm-server-key", slurm.server_key_file,
                 "With --key: this scheduler's public key file (PREFIX.pub), given to Slurm workers");
  app.add_option("--slurm-worker-key", slurm.worker_key_file,
                 "With --key: the key pair Slurm workers use (PREFIX.key; its public key in --authorized-keys)");
  app.add_option("--slurm-log-dir", slurm.log_dir, "Folder of the Slurm workers' logs (default FARM_DIR/slurm)");
  app.add_option("--slurm-job-name", slurm.job_name, "Slurm job name of this farm's workers")->capture_default_str();
  app.add_option("--slurm-poll", slurm.poll_seconds, "Seconds between squeue polls")
      ->check(CLI::Range(0.2, 3600.0))
      ->capture_default_str();
  app.add_option("--slurm-scheduler-timeout", slurm.scheduler_timeout_s,
                 "Seconds a Slurm worker waits for a silent scheduler before it exits (pd-worker --scheduler-timeout)")
      ->check(CLI::Range(1.0, 1e7))
      ->capture_default_str();
  // The scheduler runs itself with these to read a hierarchy file a worker sent (job_files.h,
  // check_hierarchy_in_child); not for users.
  std::string check_file, check_hash;
  int check_levels = 0;
  app.add_option("--check-hierarchy", check_file, "Internal: check this hierarchy file, print why not, exit")
      ->group("");
  app.add_option("--hash", check_hash, "Internal: with --check-hierarchy")->group("");
  app.add_option("--levels", check_levels, "Internal: with --check-hierarchy")->group("");
  int parent = 0;
  app.add_option("--exit-with-parent", parent, "Stop as on SIGTERM when process PID, the one that started this one, ends, however it ends (pd run and the tests pass their own pid)")
      ->check(CLI::Range(1, 1 << 30));
  app.add_option("--generate-keys", generate_prefix,
                 "Write a new key pair to PREFIX.key (mode 0600) and PREFIX.pub, then exit");
  try {
    app.parse(argc, argv);
    if (!check_file.empty()) return check_hierarchy(check_file, check_hash, check_levels);
    if (generate_prefix.empty() && options.dir.empty()) throw CLI::RequiredError("--dir");
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "pd-scheduler: error: %s\nRun with --help for more information.\n", e.what());
    return 2;
  }
  try {
    if (!generate_prefix.empty()) {
      const pd::farm::CurveKeyPair pair = pd::farm::generate_key_pair();
      pd::farm::write_key_pair(generate_prefix, pair);
      std::printf("wrote %s.key (the scheduler's --key; keep it private) and %s.pub (for workers' and clients' "
                  "--server-key)\npublic key: %s\n",
                  generate_prefix.c_str(), generate_prefix.c_str(), pair.public_key.c_str());
      return 0;
    }
    // Before the farm folder or its database is created: a refused start leaves nothing behind.
    pd::scheduler::check_security_options(options);
    pd::scheduler::complete_slurm_options(options.slurm, options.dir, options.workers_endpoint, "/proc/self/exe",
                                          !options.key_file.empty());
  } catch (const pd::InputError& e) {
    std::fprintf(stderr, "pd-scheduler: error: %s\n", e.what());
    return 2;
  }
  struct sigaction sa = {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  struct sigaction hup = {};
  hup.sa_handler = on_hangup;
  sigaction(SIGHUP, &hup, nullptr);
  std::unique_ptr<pd::scheduler::Scheduler> scheduler;
  try {
    if (parent > 0) pd::exit_with_parent(parent, SIGTERM);
    scheduler = std::make_unique<pd::scheduler::Scheduler>(options);
  } catch (const pd::InputError& e) {
    std::fprintf(stderr, "pd-scheduler: error: %s\n", e.what());
    return 2;
  } catch (const zmq::error_t& e) {
    std::fprintf(stderr, "pd-scheduler: error: cannot bind %s or %s: %s\n", options.workers_endpoint.c_str(),
                 options.clients_endpoint.c_str(), e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd-scheduler: error: %s\n", e.what());
    return 1;
  }
  try {
    const nlohmann::json listening = {{"event", "listening"},
                                      {"workers", scheduler->workers_endpoint()},
                                      {"clients", scheduler->clients_endpoint()},
                                      {"dir", options.dir},
                                      {"curve", !options.key_file.empty()}};
    std::printf("%s\n", listening.dump().c_str());
    std::fflush(stdout);
    scheduler->run(g_stop, &g_reload_keys);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd-scheduler: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
