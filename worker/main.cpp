// pd-worker: connects to a pd-scheduler, takes one task at a time, solves it, streams frames back.
// Several per machine are normal (one per core). Needs nothing but the scheduler's endpoint: the
// scene, the hierarchy and the input frames all come over the wire.
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <string>

#include <CLI/CLI.hpp>

#include "farm/curve.h"
#include "farm/messaging.h"
#include "util/input_error.h"
#include "util/parallel.h"
#include "util/parent_watch.h"
#include "util/process_setup.h"
#include "worker/worker.h"

namespace {

std::atomic<bool> g_stop{false};

void on_signal(int) { g_stop = true; }

// "<array job>_<array task>" (or "<job>") from the variables Slurm sets in a batch job; "" elsewhere.
std::string slurm_job_from_environment() {
  const char* array_job = std::getenv("SLURM_ARRAY_JOB_ID");
  const char* array_task = std::getenv("SLURM_ARRAY_TASK_ID");
  if (array_job && array_task && *array_job && *array_task) return std::string(array_job) + "_" + array_task;
  const char* job = std::getenv("SLURM_JOB_ID");
  return job ? job : "";
}

}  // namespace

int main(int argc, char** argv) {
  pd::configure_numerical_libraries(argv);
  CLI::App app{"pd-worker: solves progressive-dynamics tasks for a pd-scheduler"};
  pd::worker::WorkerOptions options;
  app.add_option("--connect", options.endpoint, "The scheduler's worker endpoint, e.g. tcp://127.0.0.1:7400")
      ->required();
  app.add_option("--name", options.name, "Name shown by pd workers (default host:pid)");
  app.add_option("--scratch", options.scratch_dir, "Folder for received scene files (default /tmp/pd-worker-<pid>)");
  app.add_option("--fail-level", options.fail_level,
                 "Fault injection for tests: every task of this level fails with an 'injected failure' message")
      ->check(CLI::Range(0, 19));  // levels 0..19 (a job has at most 20); not NonNegativeNumber, whose
                                   // message prints DBL_MAX's 309 digits
  app.add_flag("--refuse-vertical-starts", options.refuse_vertical_starts,
               "Fault injection for tests: every vertical start fails as a refused safe upsampling");
  app.add_option("--refuse-vertical-starts-before", options.refuse_vertical_starts_before,
                 "Fault injection for tests: vertical starts at frames before F fail as refused safe upsamplings")
      ->check(CLI::Range(1, 10'000'000));  // a job's frames
  double max_memory_gib = 0.0;
  app.add_option("--max-memory", max_memory_gib,
                 "The most memory a task may need, GiB (default: what the machine, ulimit -v and the cgroup leave "
                 "this process); a level task needing more is refused before it starts, so another worker takes it")
      ->check(CLI::Range(1e-6, 1e6));
  app.add_option("--server-key", options.server_key_file,
                 "The scheduler's public key file (its PREFIX.pub); with --key, for a scheduler beyond loopback");
  app.add_option("--key", options.key_file, "This worker's key pair (PREFIX.key from pd keys); with --server-key");
  app.add_option("--scheduler-timeout", options.scheduler_timeout_s,
                 "Exit (code 3) once nothing has come from the scheduler for this many seconds (0: retry for ever; "
                 "the Slurm job script sets it, so that no allocation waits for a scheduler that is gone)")
      ->check(CLI::Range(0.0, 1e7));
  int parent = 0;
  app.add_option("--exit-with-parent", parent, "Stop as on SIGTERM when process PID, the one that started this one, ends, however it ends (pd run and the tests pass their own pid)")
      ->check(CLI::Range(1, 1 << 30));
  int threads = 0;
  app.add_option("--threads", threads,
                 "Threads for the element loops of a task (default 0: every core this process may use, i.e. "
                 "its CPU affinity, which Slurm sets); the frames are the same bit for bit for every count")
      ->check(CLI::Range(0, 4096));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "pd-worker: error: %s\nRun with --help for more information.\n", e.what());
    return 2;
  }
  pd::set_element_threads(threads);
  options.max_memory_bytes = max_memory_gib * 1024.0 * 1024.0 * 1024.0;
  const std::string pid = std::to_string(getpid());
  options.slurm_job = slurm_job_from_environment();
  if (options.name.empty() && !options.slurm_job.empty()) options.name = "slurm-" + options.slurm_job;
  if (options.name.empty()) {
    char host[256] = {};
    gethostname(host, sizeof host - 1);
    options.name = std::string(host) + ":" + pid;
  }
  // A default scratch folder is this process's own and goes with it; a given one is left as it is.
  const bool own_scratch = options.scratch_dir.empty();
  if (own_scratch) options.scratch_dir = "/tmp/pd-worker-" + pid;
  if (options.endpoint.rfind("tcp://", 0) != 0 && options.endpoint.rfind("ipc://", 0) != 0) {
    std::fprintf(stderr, "pd-worker: error: --connect: expected tcp://HOST:PORT or ipc://PATH, got '%s'\n",
                 options.endpoint.c_str());
    return 2;
  }
  try {
    options.curve = pd::farm::read_client_keys(options.server_key_file, options.key_file);
  } catch (const pd::InputError& e) {
    std::fprintf(stderr, "pd-worker: error: %s\n", e.what());
    return 2;
  }
  if (!options.curve && !pd::farm::is_loopback_endpoint(options.endpoint)) {
    // Not refused: a tunnel can make a loopback scheduler reachable at another address.
    std::fprintf(stderr,
                 "pd-worker %s: no --server-key/--key for %s: a pd-scheduler beyond loopback admits CURVE workers "
                 "only, and this one will get no answer from it\n",
                 options.name.c_str(), options.endpoint.c_str());
  }
  struct sigaction sa = {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  int code = 1;
  try {
    if (parent > 0) pd::exit_with_parent(parent, SIGTERM);
    code = pd::worker::run_worker(options, g_stop);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd-worker: error: %s\n", e.what());
  }
  std::error_code ignored;
  if (own_scratch) std::filesystem::remove_all(options.scratch_dir, ignored);
  return code;
}
