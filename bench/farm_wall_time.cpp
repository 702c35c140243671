// Wall time of the farm against one process (docs/farm.md, "Performance"): on one scene, in one run,
//   pd simulate --mode progressive                 (one process, the levels one after the other)
//   a farm job with 1 worker,  K = 1               (the same work through the scheduler)
//   a farm job with 2 workers, K = 1               (levels pipelined a frame or so apart)
//   a farm job with 2 workers, K = 2               (two time subsets per refinement level)
// Each farm is a fresh pd-scheduler on port-0 loopback endpoints and pd-worker processes started
// here (tests/support/process.h), measured from `pd submit` to the scheduler's "job_done" event.
//
// Per run: wall time and its ratio to pd simulate; the sum of every stored frame's solve_seconds
// (from the frame file: the solver's own time, whichever process ran it); the time from `pd submit`
// to the first solved preview frame (level 0 frame 1; read from the scheduler's "frame_stored" log
// line as it appears, polled every 20 ms); the scheduler's CPU time per stored frame (utime + stime
// from /proc, the cost of handling, writing and forwarding each frame); and the farm's overhead per
// frame: (wall - sum of solve_seconds) of the 1-worker job minus the same for pd simulate, over the
// frames stored (both build the same hierarchy, which cancels).
//
//   pd_bench_farm                                    # bench/scenes/cube-trampoline-large.json, 50 frames
//   pd_bench_farm --scene scenes/cube-trampoline.json --frames 200
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "store/frame_store.h"
#include "support/process.h"

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

namespace {

struct Row {
  std::string what;
  double wall = 0.0;         // s
  double solve_sum = 0.0;    // s, sum of solve_seconds over every stored frame of every level
  int frames_stored = 0;     // over every level (frame 0 included)
  double first_preview = NAN;    // s from submit to level 0 frame 1 stored
  double scheduler_cpu = NAN;    // s
};

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

void sum_solve_seconds(const std::string& file, Row& row) {
  const pd::FrameReader r(file);
  for (int l = 0; l < r.num_levels(); ++l) {
    for (const uint8_t d : r.done(l)) row.frames_stored += d;
    for (const double s : r.stat(l, "solve_seconds"))
      if (std::isfinite(s)) row.solve_sum += s;
  }
}

// utime + stime of a live process, s (fields 14 and 15 of /proc/<pid>/stat, in clock ticks).
double cpu_seconds(pid_t pid) {
  const std::string stat = pd::test::read_file_text("/proc/" + std::to_string(pid) + "/stat");
  const size_t close = stat.rfind(')');
  if (close == std::string::npos) return NAN;
  unsigned long utime = 0, stime = 0;
  // After "pid (comm) ": state ppid pgrp session tty tpgid flags minflt cminflt majflt cmajflt utime stime
  if (std::sscanf(stat.c_str() + close + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %lu %lu", &utime, &stime) != 2)
    return NAN;
  return double(utime + stime) / double(sysconf(_SC_CLK_TCK));
}

pd::test::RunResult must(const pd::test::RunResult& r) {
  if (r.exit_code != 0) throw std::runtime_error(r.describe());
  return r;
}

Row run_simulate(const std::string& scene, int frames, const std::string& dir) {
  Row row;
  row.what = "pd simulate --mode progressive";
  const std::string out = dir + "/simulate.h5";
  const auto t0 = Clock::now();
  must(pd::test::run({PD_BINARY, "simulate", scene, "--mode", "progressive", "--frames", std::to_string(frames),
                      "--quiet", "--out", out},
                     std::chrono::hours(2)));
  row.wall = seconds_since(t0);
  sum_solve_seconds(out, row);
  return row;
}

// Lines of `path` from byte `offset` on that are complete; advances offset past them.
std::vector<std::string> new_lines(const std::string& path, size_t& offset) {
  const std::string text = pd::test::read_file_text(path);
  std::vector<std::string> lines;
  for (size_t nl; offset < text.size() && (nl = text.find('\n', offset)) != std::string::npos; offset = nl + 1)
    lines.push_back(text.substr(offset, nl - offset));
  return lines;
}

Row run_farm(const std::string& scene, int frames, int workers, int subsets, const std::string& dir) {
  Row row;
  row.what = "farm, " + std::to_string(workers) + " worker" + (workers > 1 ? "s" : "") + ", K = " +
             std::to_string(subsets);
  const std::string tag = dir + "/farm-w" + std::to_string(workers) + "-k" + std::to_string(subsets);
  const std::string log = tag + ".scheduler.log", out = tag + ".scheduler.out";
  pd::test::Process scheduler;
  scheduler.start({PD_SCHEDULER_BINARY, "--dir", tag, "--workers-endpoint", "tcp://127.0.0.1:0", "--clients-endpoint",
                   "tcp://127.0.0.1:0"},
                  {}, out, log);
  const auto line = pd::test::read_first_line(out, 20s, &scheduler);
  if (!line) throw std::runtime_error("pd-scheduler did not start:\n" + pd::test::file_tail(log));
  const json listening = json::parse(*line);
  const std::string clients = listening.at("clients").get<std::string>();
  const std::string workers_endpoint = listening.at("workers").get<std::string>();
  std::vector<pd::test::Process> procs(static_cast<size_t>(workers));
  for (int k = 0; k < workers; ++k)
    procs[k].start({PD_WORKER_BINARY, "--connect", workers_endpoint, "--name", "w" + std::to_string(k + 1), "--scratch",
                    tag + ".scratch" + std::to_string(k + 1)},
                   {},
                   tag + ".worker" + std::to_string(k + 1) + ".log", tag + ".worker" + std::to_string(k + 1) + ".log");
  // Measured from submission with every worker registered, as a job on a farm already running.
  for (const auto deadline = Clock::now() + 20s;;) {
    const json w = json::parse(must(pd::test::run({PD_BINARY, "workers", "--json", "--farm", clients}, 30s)).out);
    if (static_cast<int>(w.at("workers").size()) == workers) break;
    if (Clock::now() > deadline) throw std::runtime_error("workers did not register:\n" + pd::test::file_tail(log));
    std::this_thread::sleep_for(50ms);
  }
  size_t offset = 0;
  new_lines(log, offset);  // skip the start-up events
  const auto t0 = Clock::now();
  const std::string job = std::to_string(
      json::parse(must(pd::test::run({PD_BINARY, "submit", scene, "--frames", std::to_string(frames), "--subsets",
                                      std::to_string(subsets), "--json", "--farm", clients},
                                     60s))
                      .out)
          .at("job")
          .get<long long>());
  for (bool done = false; !done;) {
    if (!scheduler.running()) throw std::runtime_error("pd-scheduler exited:\n" + pd::test::file_tail(log));
    for (const std::string& l : new_lines(log, offset)) {
      const json e = json::parse(l, nullptr, false);
      if (e.is_discarded()) continue;
      const std::string ev = e.value("event", "");
      if (ev == "frame_stored" && std::isnan(row.first_preview) && e.value("message", "") == "level 0 frame 1")
        row.first_preview = seconds_since(t0);
      if (ev == "job_done") done = true;
      if (ev == "job_failed" || ev == "task_failed") throw std::runtime_error("job failed: " + l);
    }
    if (!done) std::this_thread::sleep_for(20ms);
  }
  row.wall = seconds_since(t0);
  row.scheduler_cpu = cpu_seconds(scheduler.pid());
  const json status = json::parse(must(pd::test::run({PD_BINARY, "status", job, "--json", "--farm", clients}, 30s)).out);
  if (status.at("jobs").at(0).at("state") != "done") throw std::runtime_error("job not done: " + status.dump());
  must(pd::test::run({PD_BINARY, "fetch", job, "--out", tag + ".h5", "--farm", clients}, 120s));
  for (pd::test::Process& p : procs) p.terminate();
  scheduler.terminate();
  sum_solve_seconds(tag + ".h5", row);
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  std::string scene = std::string(PD_SOURCE_DIR) + "/bench/scenes/cube-trampoline-large.json";
  int frames = 50;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--scene" && i + 1 < argc) scene = argv[++i];
    else if (a == "--frames" && i + 1 < argc) frames = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: pd_bench_farm [--scene FILE] [--frames N]\n");
      return 2;
    }
  }
  if (frames < 1) {
    std::fprintf(stderr, "pd_bench_farm: error: --frames must be >= 1\n");
    return 2;
  }
  char tmpl[] = "/tmp/pd_bench_farm_XXXXXX";
  const std::string dir = mkdtemp(tmpl);
  std::printf("scene %s, %d frames, work folder %s, %u hardware threads\n", scene.c_str(), frames, dir.c_str(),
              std::thread::hardware_concurrency());
  std::fflush(stdout);
  try {
    std::vector<Row> rows;
    rows.push_back(run_simulate(scene, frames, dir));
    for (const auto& [w, k] : std::vector<std::pair<int, int>>{{1, 1}, {2, 1}, {2, 2}}) {
      rows.push_back(run_farm(scene, frames, w, k, dir));
      std::fprintf(stderr, "  %s: %.1f s\n", rows.back().what.c_str(), rows.back().wall);
    }
    const Row& sim = rows[0];
    std::printf("\n| run | wall s | speed-up over pd simulate | sum of solve_seconds s | wall / solve sum | "
                "submit to first preview frame s | scheduler CPU ms/frame |\n| --- | --- | --- | --- | --- | --- | --- |\n");
    for (const Row& r : rows) {
      std::printf("| %s | %.1f | %.2fx | %.1f | %.2f | %s | %s |\n", r.what.c_str(), r.wall, sim.wall / r.wall,
                  r.solve_sum, r.wall / r.solve_sum,
                  std::isnan(r.first_preview) ? "-" : std::to_string(r.first_preview).substr(0, 5).c_str(),
                  std::isnan(r.scheduler_cpu)
                      ? "-"
                      : std::to_string(1e3 * r.scheduler_cpu / r.frames_stored).substr(0, 5).c_str());
    }
    const Row& one = rows[1];
    const double overhead = ((one.wall - one.solve_sum) - (sim.wall - sim.solve_sum)) / one.frames_stored;
    std::printf("\nfarm overhead per stored frame (1 worker, K = 1, against pd simulate): %.1f ms over %d frames\n",
                1e3 * overhead, one.frames_stored);
    std::filesystem::remove_all(dir);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd_bench_farm: error: %s\n(work folder kept: %s)\n", e.what(), dir.c_str());
    return 1;
  }
  return 0;
}
