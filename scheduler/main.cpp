// pd-scheduler: the farm's one scheduler. Owns FARM_DIR (farm.sqlite, jobs/<job>.h5), binds a
// ROUTER for workers and one for clients (loopback by default), prints the bound endpoints as one
// JSON line on stdout (so a script or `pd run` can use port 0), and logs one JSON line per event
// on stderr.
#include <atomic>
#include <csignal>
#include <memory>
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "farm/messaging.h"
#include "scheduler/scheduler.h"

namespace {

std::atomic<bool> g_stop{false};

void on_signal(int) { g_stop = true; }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pd-scheduler: dispatches progressive-dynamics jobs to pd-worker processes"};
  pd::scheduler::SchedulerOptions options;
  app.add_option("--dir", options.dir, "Farm folder: farm.sqlite and jobs/<job>.h5 (created when missing)")->required();
  app.add_option("--workers-endpoint", options.workers_endpoint,
                 "Where workers connect (port 0: a free port, printed on start)")
      ->capture_default_str();
  app.add_option("--clients-endpoint", options.clients_endpoint,
                 "Where pd clients connect (port 0: a free port, printed on start)")
      ->capture_default_str();
  app.add_option("--heartbeat-ms", options.heartbeat_ms, "Heartbeat period; 3 missed ones lose a worker")
      ->check(CLI::Range(50, 60000))
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "pd-scheduler: error: %s\nRun with --help for more information.\n", e.what());
    return 2;
  }
  for (const std::string* e : {&options.workers_endpoint, &options.clients_endpoint}) {
    if (!pd::farm::is_loopback_endpoint(*e)) {
      std::fprintf(stderr,
                   "pd-scheduler: error: %s is not a loopback address; binding beyond loopback needs CURVE keys, "
                   "which this version does not support yet\n",
                   e->c_str());
      return 2;
    }
  }
  struct sigaction sa = {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::unique_ptr<pd::scheduler::Scheduler> scheduler;
  try {
    scheduler = std::make_unique<pd::scheduler::Scheduler>(options);
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
                                      {"dir", options.dir}};
    std::printf("%s\n", listening.dump().c_str());
    std::fflush(stdout);
    scheduler->run(g_stop);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd-scheduler: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
