// pd_bench_farm_load: the scheduler under farm-scale load (docs/performance.md, "Farm load"). Many
// lightweight simulated workers, one DEALER socket each, served by one or a few threads (epoll over
// their sockets, bench/farm_load_workers.cpp), connect to a running pd-scheduler and speak the worker protocol
// (protocol/protocol.h) without solving anything:
//   Hello -> Welcome; a heartbeat every heartbeat_ms with a ping (the scheduler answers at once with
//   pong = ping: the round trip is timed); a hierarchy task is answered at once with HierarchyDone
//   carrying a real hierarchy file built here once for the scene (so the scheduler's hash and level
//   checks pass); a level task with FrameReports of the level's rest positions (recorded frames, the
//   right vertex count, stat "solve_seconds"), paced so that all workers together send --rate
//   frames per second, then TaskDone. A refinement task sends frame t + 1 only once the level
//   below's frame t has arrived as a BelowFrame, as a solver would. CancelTask ends the attempt.
// The program also submits the jobs itself over the clients endpoint (SubmitJob) and keeps enough
// of them unfinished for every worker during the run (a job is finished when its every task was
// done here), then lets the submitted jobs end, checks with StatusRequest that each is done with
// all frames stored and with WorkersRequest that none of its workers is "lost", and prints one JSON
// object with the figures. Exit 0 when nothing was lost or refused and every job ended done, 1
// otherwise, 2 for bad options, a scheduler that does not answer or a serving thread that failed.
//
// Lost leases: a Welcome not asked for, or Refused "unknown worker" (the scheduler dropped the
// worker; it says Hello again); the scheduler's log (--scheduler-log) is also searched for
// worker_lost events. The scheduler's CPU time (utime + stime, per thread too) and VmHWM come from
// /proc/<--scheduler-pid>; frames stored per second in the window from its log's frame_stored lines.
//
//   pd_bench_farm_load --workers-endpoint tcp://127.0.0.1:7400 --clients-endpoint tcp://127.0.0.1:7401
//       --workers 500 --seconds 60 --rate 2000 --scheduler-pid 1234 --scheduler-log sched.log
// bench/farm_load.sh starts the scheduler and runs this.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <zmq.hpp>

#include "farm/messaging.h"
#include "farm/task_graph.h"
#include "farm_load_workers.h"

namespace {

using namespace pd;
using namespace pd::farm_load;
using nlohmann::json;
using protocol::Parts;

double wall_now() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

// Requests on the clients endpoint, pipelined: all sent, then the replies read in order.
class Client {
 public:
  explicit Client(const std::string& endpoint) : ctx_(1), socket_(ctx_, zmq::socket_type::dealer) {
    farm::configure_socket(socket_);
    socket_.connect(endpoint);
  }
  std::vector<protocol::Reply> call(const std::vector<protocol::Request>& requests, std::chrono::seconds timeout) {
    for (const protocol::Request& r : requests) farm::send_parts(socket_, protocol::encode(r));
    std::vector<protocol::Reply> replies;
    for (std::size_t k = 0; k < requests.size(); ++k) {
      std::optional<Parts> parts = farm::recv_parts_within(socket_, timeout);
      if (!parts)
        throw std::runtime_error("the scheduler did not answer within " + std::to_string(timeout.count()) + " s");
      replies.push_back(protocol::decode_reply(*parts));
    }
    return replies;
  }

 private:
  zmq::context_t ctx_;
  zmq::socket_t socket_;
};

// The jobs this program submits and how many tasks finish each.
class Jobs {
 public:
  Jobs(const Options& o, const Recording& rec) : rec_(rec), submit_rate_(o.submit_rate) {
    spec_.scene = rec.source;
    spec_.preview_only = o.preview_only;
    spec_.levels = rec.levels;
    spec_.subsets = o.subsets;
    spec_.frames = rec.frames;
    spec_.preview_chunk = std::min(o.preview_chunk, rec.frames);
    farm::GraphOptions g;
    g.frames = rec.frames;
    g.levels = rec.levels;
    g.subsets = o.subsets;
    g.preview_chunk = spec_.preview_chunk;
    g.preview_only = o.preview_only;
    tasks_per_job_ = farm::job_tasks(g).size();
    // Tasks of one job that can hold a worker at once: the preview chain is sequential.
    const int parallel = o.preview_only ? 1 : 1 + (rec.levels - 1) * std::min(o.subsets, rec.frames);
    target_ = o.jobs > 0 ? o.jobs : static_cast<int>(std::ceil(1.2 * o.workers / parallel));
    fixed_ = o.jobs > 0;
  }

  void submit(Client& client, int count) {
    std::vector<protocol::Request> requests(static_cast<std::size_t>(count), protocol::Request{spec_});
    for (protocol::Reply& r : client.call(requests, std::chrono::seconds(30))) {
      if (auto* s = std::get_if<protocol::Submitted>(&r)) open_.insert(s->job), all_.push_back(s->job);
      else if (auto* e = std::get_if<protocol::ErrorReply>(&r))
        throw std::runtime_error("submit refused: " + e->message);
    }
  }
  // Forgets the jobs whose every task was done; tops the unfinished ones up to the target, at most
  // --submit-rate jobs per second: each job's file costs the scheduler tens of ms in one piece (the
  // hierarchy read back, the job file created and fsynced) when its hierarchy task reports, and a
  // burst of them would stall its loop for seconds.
  void keep_up(Client& client, Shared& shared, bool more) {
    for (auto it = open_.begin(); it != open_.end();)
      it = shared.tasks_done_of(*it) >= tasks_per_job_ ? open_.erase(it) : std::next(it);
    const auto now = Clock::now();
    allowance_ = std::min(allowance_ + submit_rate_ * seconds_between(last_, now), std::max(1.0, submit_rate_));
    last_ = now;
    const int missing = std::min(target_ - static_cast<int>(open_.size()), static_cast<int>(allowance_));
    if (!more || missing <= 0) return;
    submit(client, missing);
    allowance_ -= missing;
  }
  // More unfinished jobs (by a tenth), unless --jobs fixed their number.
  void grow() {
    if (!fixed_) target_ += std::max(1, target_ / 10);
  }

  int target() const { return target_; }
  std::size_t open() const { return open_.size(); }
  const std::vector<int64_t>& all() const { return all_; }
  int frames_per_job() const { return (rec_.frames + 1) * (spec_.preview_only ? 1 : rec_.levels); }
  int levels_asked() const { return spec_.preview_only ? 1 : rec_.levels; }

 private:
  const Recording& rec_;
  protocol::SubmitJob spec_;
  std::size_t tasks_per_job_ = 0;
  int target_ = 0;
  bool fixed_ = false;
  double submit_rate_;  // jobs/s
  double allowance_ = 1;  // jobs that may be submitted now
  Clock::time_point last_ = Clock::now();
  std::set<int64_t> open_;
  std::vector<int64_t> all_;
};

// /proc figures of a process (the scheduler, this program).
struct CpuTimes {
  double user = 0, system = 0;  // s
};
std::optional<CpuTimes> cpu_times(const std::string& stat_path, std::string* comm = nullptr) {
  std::ifstream in(stat_path);
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t open = stat.find('('), close = stat.rfind(')');
  if (open == std::string::npos || close == std::string::npos) return std::nullopt;
  if (comm) *comm = stat.substr(open + 1, close - open - 1);
  std::istringstream fields(stat.substr(close + 2));
  std::string skip;
  for (int k = 0; k < 11; ++k) fields >> skip;  // state .. cmajflt; then utime stime (clock ticks)
  double u = 0, s = 0;
  if (!(fields >> u >> s)) return std::nullopt;
  const double tick = static_cast<double>(sysconf(_SC_CLK_TCK));
  return CpuTimes{u / tick, s / tick};
}
// Per thread: "comm/tid" -> times.
std::map<std::string, CpuTimes> thread_times(int pid) {
  std::map<std::string, CpuTimes> out;
  std::error_code ec;
  const std::string dir = "/proc/" + std::to_string(pid) + "/task";
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    std::string comm;
    if (auto t = cpu_times(e.path().string() + "/stat", &comm)) out[comm + "/" + e.path().filename().string()] = *t;
  }
  return out;
}
double status_mb(int pid, const std::string& key) {  // VmHWM, VmRSS: kB in the file
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key + ":", 0) == 0) return std::stod(line.substr(key.size() + 1)) / 1024.0;
  return NAN;
}

// Figures from the scheduler's log (one JSON event per line).
struct LogFigures {
  int64_t frames_in_window = 0, workers_lost = 0, send_failed = 0;
};
LogFigures read_log(const std::string& path, double since, double window_start, double window_end) {
  LogFigures f;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    const bool frame = line.find("\"frame_stored\"") != std::string::npos;
    const bool lost = line.find("\"worker_lost\"") != std::string::npos;
    const bool failed = line.find("\"send_failed\"") != std::string::npos;
    if (!frame && !lost && !failed) continue;
    double t = 0;
    try {
      t = json::parse(line).at("time").get<double>();
    } catch (const json::exception&) {
      continue;
    }
    if (frame && t >= window_start && t < window_end) ++f.frames_in_window;
    if (lost && t >= since) ++f.workers_lost;
    if (failed && t >= since) ++f.send_failed;
  }
  return f;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, std::floor(p * static_cast<double>(v.size()))))];
}

// CPU time of a process over the window, per thread and in all, from /proc.
struct CpuSnapshot {
  Clock::time_point at;
  CpuTimes all;
  std::map<std::string, CpuTimes> threads;
};
CpuSnapshot snapshot(int pid) {
  CpuSnapshot s;
  s.at = Clock::now();
  if (pid <= 0) return s;
  if (auto t = cpu_times("/proc/" + std::to_string(pid) + "/stat")) s.all = *t;
  s.threads = thread_times(pid);
  return s;
}

json process_figures(int pid, const CpuSnapshot& a, const CpuSnapshot& b) {
  if (pid <= 0) return nullptr;
  const double wall = seconds_between(a.at, b.at);
  json threads = json::object();
  for (const auto& [name, t] : b.threads) {
    auto before = a.threads.find(name);
    const CpuTimes t0 = before == a.threads.end() ? CpuTimes{} : before->second;
    threads[name] = {{"cpu_percent", 100 * (t.user + t.system - t0.user - t0.system) / wall},
                     {"user_percent", 100 * (t.user - t0.user) / wall}};
  }
  const double user = b.all.user - a.all.user, system = b.all.system - a.all.system;
  return {{"cpu_seconds", user + system}, {"cpu_percent", 100 * (user + system) / wall},
          {"user_seconds", user},        {"system_seconds", system},
          {"threads", threads},          {"vm_hwm_mb", status_mb(pid, "VmHWM")},
          {"vm_rss_mb", status_mb(pid, "VmRSS")}};
}

// The scheduler's view at the end: each job done with every frame stored, none of our workers lost.
struct FinalCheck {
  int64_t jobs_done = 0, frames_stored = 0;
  std::vector<std::string> problems;  // the first few
  protocol::WorkersReply workers;
};
FinalCheck final_check(Client& client, const Jobs& jobs) {
  FinalCheck c;
  const auto replies = client.call({protocol::StatusRequest{0}, protocol::WorkersRequest{}}, std::chrono::seconds(60));
  const auto* status = std::get_if<protocol::StatusReply>(&replies[0]);
  const auto* workers = std::get_if<protocol::WorkersReply>(&replies[1]);
  if (!status || !workers) throw std::runtime_error("unexpected reply to a status or workers request");
  std::map<int64_t, const protocol::JobStatus*> by_id;
  for (const protocol::JobStatus& j : status->jobs) by_id[j.id] = &j;
  auto problem = [&](const std::string& p) {
    if (c.problems.size() < 5) c.problems.push_back(p);
  };
  for (int64_t id : jobs.all()) {
    auto it = by_id.find(id);
    if (it == by_id.end()) {
      problem("job " + std::to_string(id) + " is not listed");
      continue;
    }
    const protocol::JobStatus& j = *it->second;
    int stored = 0, complete = 0;
    for (const protocol::LevelProgress& l : j.levels) {
      if (l.level >= jobs.levels_asked()) continue;
      stored += l.frames_done;
      complete += l.frames_done == l.frames_total;
    }
    c.frames_stored += stored;
    if (j.state == protocol::JobState::done && complete == jobs.levels_asked()) ++c.jobs_done;
    else problem("job " + std::to_string(id) + " is " + protocol::to_string(j.state) + " with " +
                 std::to_string(stored) + " of " + std::to_string(jobs.frames_per_job()) + " frames " + j.reason);
  }
  c.workers = *workers;
  return c;
}

// nullopt when the run should go on, else the exit code (--help: 0, a bad option: 2).
std::optional<int> parse_options(int argc, char** argv, Options& o) {
  CLI::App app{"pd_bench_farm_load: many simulated workers and their jobs against one pd-scheduler"};
  app.add_option("--workers-endpoint", o.workers_endpoint, "The scheduler's worker endpoint")->required();
  app.add_option("--clients-endpoint", o.clients_endpoint, "The scheduler's client endpoint")->required();
  app.add_option("--workers", o.workers, "Simulated workers")->check(CLI::Range(1, 5000))->capture_default_str();
  app.add_option("--threads", o.threads, "Threads serving them")->check(CLI::Range(1, 16))->capture_default_str();
  app.add_option("--seconds", o.seconds, "Measured window, s")->check(CLI::Range(1.0, 3600.0))->capture_default_str();
  app.add_option("--warmup", o.warmup, "From the first submission to the window, s")->capture_default_str();
  app.add_option("--rate", o.rate, "Frames per second, all workers together")->check(CLI::Range(1.0, 1e6))
      ->capture_default_str();
  app.add_option("--heartbeat-ms", o.heartbeat_ms, "Heartbeat period until the Welcome gives the scheduler's")
      ->check(CLI::Range(50, 60000))->capture_default_str();
  app.add_option("--scene", o.scene, "Scene of the jobs")->capture_default_str();
  app.add_option("--frames", o.frames, "Frames per job (0: the scene's)")->capture_default_str();
  app.add_option("--levels", o.levels, "Hierarchy levels per job (0: the scene's)")->capture_default_str();
  app.add_option("--subsets", o.subsets, "Time subsets K per refinement level")->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--preview-chunk", o.preview_chunk, "Frames per preview task")->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_flag("--preview-only", o.preview_only, "Jobs without refinement levels");
  app.add_option("--submit-rate", o.submit_rate, "Jobs submitted per second at most")
      ->check(CLI::Range(0.1, 1000.0))->capture_default_str();
  app.add_option("--jobs", o.jobs, "Unfinished jobs kept (0: enough for every worker, grown when workers idle)")
      ->capture_default_str();
  app.add_option("--drain-seconds", o.drain_seconds, "Bound on the wait for the jobs to end after the window, s")
      ->capture_default_str();
  app.add_option("--scheduler-pid", o.scheduler_pid, "The scheduler's pid (CPU time and VmHWM from /proc)");
  app.add_option("--scheduler-log", o.scheduler_log, "The scheduler's stderr (worker_lost, frame_stored events)");
  app.add_option("--rtt-csv", o.rtt_csv, "Writes every round trip of the window here: seconds since its start, ms");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "pd_bench_farm_load: error: %s\nRun with --help for more information.\n", e.what());
    return 2;
  }
  return std::nullopt;
}

struct Window {
  Clock::time_point start, end;
  double wall_start = 0, wall_end = 0;  // the same instants, s since the Unix epoch
  CpuSnapshot before, after;            // the scheduler's
  CpuSnapshot self_before, self_after;  // this program's
  double idle_sum = 0;  // fraction of workers without an attempt, summed over 0.1 s samples
  int idle_samples = 0;
};

// Until the window's end: keeps the jobs topped up (more of them when workers stay idle) and takes
// the scheduler's CPU times at the window's ends.
void measure(const Options& o, Shared& shared, Client& client, Jobs& jobs, Window& w) {
  bool started = false;
  int idle_turns = 0;
  while (Clock::now() < w.end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    jobs.keep_up(client, shared, true);
    const double idle = 1.0 - static_cast<double>(shared.busy) / o.workers;
    idle_turns = idle > 0.1 ? idle_turns + 1 : 0;
    // 2 s with over a tenth of the workers idle, every job submitted and the scheduler keeping up
    // (round trips under 100 ms; a scheduler behind leaves workers idle however many jobs wait, and
    // more open jobs make its every frame dearer): too few tasks ready.
    if (idle_turns >= 20 && static_cast<int>(jobs.open()) >= jobs.target() && shared.rtt_smoothed_ms < 100) {
      jobs.grow();
      idle_turns = 0;
    }
    if (!started && Clock::now() >= w.start) {
      w.before = snapshot(o.scheduler_pid);
      w.self_before = snapshot(getpid());
      started = true;
    }
    if (started) w.idle_sum += idle, ++w.idle_samples;
  }
  w.after = snapshot(o.scheduler_pid);
  w.self_after = snapshot(getpid());
  if (!started) w.before = w.after, w.self_before = w.self_after;
}

// After the window: no more submissions; waits (bounded) for the open jobs, then for the scheduler
// to agree that every job is done (its reports and our requests travel on different sockets).
FinalCheck drain(const Options& o, Shared& shared, Client& client, Jobs& jobs, double& seconds) {
  const auto t0 = Clock::now();
  const auto bound = std::chrono::duration<double>(o.drain_seconds);
  while (jobs.open() > 0 && Clock::now() - t0 < bound) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    jobs.keep_up(client, shared, false);
  }
  FinalCheck c = final_check(client, jobs);
  for (int k = 0; k < 50 && !c.problems.empty() && jobs.open() == 0; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    c = final_check(client, jobs);
  }
  seconds = seconds_between(t0, Clock::now());
  return c;
}

json rtt_figures(const std::vector<double>& rtt) {
  return {{"samples", rtt.size()},
          {"p50", percentile(rtt, 0.50)},
          {"p90", percentile(rtt, 0.90)},
          {"p99", percentile(rtt, 0.99)},
          {"max", rtt.empty() ? NAN : *std::max_element(rtt.begin(), rtt.end())}};
}

// Everything a run found, for the report.
struct Outcome {
  Window window;
  json scheduler;  // process_figures of the scheduler over the window
  FinalCheck check;
  LogFigures log;
  Tally tally;
  double drain_seconds = 0;
  int64_t connected = 0, listed_lost = 0;  // our workers connected at the end; listed "lost" by the scheduler
};

json report(const Options& o, const Recording& rec, const Jobs& jobs, const Outcome& r) {
  const Tally& t = r.tally;
  const int64_t expected_frames = static_cast<int64_t>(jobs.all().size()) * jobs.frames_per_job();
  json out = {
      {"workers", o.workers}, {"threads", o.threads}, {"seconds", o.seconds}, {"rate_target", o.rate},
      {"scene", o.scene}, {"hierarchy_vertices", rec.vertices},
      {"job", {{"frames", rec.frames}, {"levels", rec.levels}, {"subsets", o.subsets},
               {"preview_chunk", std::min(o.preview_chunk, rec.frames)}, {"preview_only", o.preview_only}}},
      {"connected_at_end", r.connected}, {"leases_lost", t.leases_lost}, {"scheduler_silences", t.scheduler_silences},
      {"log_worker_lost", r.log.workers_lost}, {"log_send_failed", r.log.send_failed},
      {"workers_listed_lost", r.listed_lost},
      {"jobs_submitted", jobs.all().size()}, {"jobs_done", r.check.jobs_done}, {"jobs_target_final", jobs.target()},
      {"problems", r.check.problems}, {"drain_seconds", r.drain_seconds},
      {"frames_sent", t.frames_sent}, {"frames_expected", expected_frames}, {"frames_stored", r.check.frames_stored},
      {"frames_sent_per_second", t.frames_in_window / o.seconds},
      {"frames_sent_per_second_min",
       t.per_second.empty() ? 0 : *std::min_element(t.per_second.begin(), t.per_second.end())},
      {"frames_stored_per_second",
       o.scheduler_log.empty() ? json(nullptr) : json(r.log.frames_in_window / o.seconds)},
      {"tasks_done", t.tasks_done}, {"hierarchies_done", t.hierarchies_done}, {"cancels", t.cancels},
      {"refused", t.refused}, {"refusals", t.refusals}, {"send_blocked", t.send_blocked},
      {"assigned_while_busy", t.assigned_while_busy},
      {"idle_worker_fraction", r.window.idle_samples ? r.window.idle_sum / r.window.idle_samples : NAN},
      {"rtt_ms", rtt_figures(t.rtt_ms)}, {"window_seconds", seconds_between(r.window.before.at, r.window.after.at)},
      {"window_wall_start", r.window.wall_start},
      {"scheduler", r.scheduler},
      {"load_program", {{"max_turn_ms", t.max_turn_ms},
                        {"cpu", process_figures(getpid(), r.window.self_before, r.window.self_after)}}}};
  out["ok"] = r.connected == o.workers && t.leases_lost == 0 && t.scheduler_silences == 0 && r.log.workers_lost == 0 &&
              r.listed_lost == 0 && t.refused == 0 && t.assigned_while_busy == 0 &&
              r.check.jobs_done == static_cast<int64_t>(jobs.all().size()) && r.check.frames_stored == expected_frames;
  return out;
}

void write_rtt_csv(const std::string& path, const Tally& t) {
  std::ofstream csv(path);
  csv << "seconds,rtt_ms\n";
  for (std::size_t k = 0; k < t.rtt_ms.size(); ++k) csv << t.rtt_at[k] << "," << t.rtt_ms[k] << "\n";
  if (!csv) throw std::runtime_error(path + ": cannot write");
}

int run(const Options& o) {
  const double since = wall_now();
  const Recording rec = record(o);
  Shared shared;
  ShardSet shards(o, rec, shared);
  const auto connect_by = Clock::now() + std::chrono::seconds(30);
  while (shared.welcomed < o.workers && Clock::now() < connect_by)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  if (shared.welcomed < o.workers)
    throw std::runtime_error(std::to_string(shared.welcomed) + " of " + std::to_string(o.workers) +
                             " simulated workers welcomed within 30 s (" + o.workers_endpoint + ")");
  Client client(o.clients_endpoint);
  Jobs jobs(o, rec);
  Outcome r;
  Window& w = r.window;
  w.start = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.warmup));
  w.end = w.start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.seconds));
  w.wall_start = wall_now() + seconds_between(Clock::now(), w.start);
  w.wall_end = w.wall_start + o.seconds;
  shared.window_end = Shared::ns(w.end);
  shared.window_start = Shared::ns(w.start);
  measure(o, shared, client, jobs, w);
  r.scheduler = process_figures(o.scheduler_pid, w.before, w.after);
  r.check = drain(o, shared, client, jobs, r.drain_seconds);
  if (!o.scheduler_log.empty()) r.log = read_log(o.scheduler_log, since, w.wall_start, w.wall_end);
  shards.stop();  // closes no socket yet: the scheduler loses our workers only when the program exits
  if (!shards.errors().empty()) throw std::runtime_error("a serving thread failed: " + shards.errors());
  r.tally = shards.sum();
  if (!o.rtt_csv.empty()) write_rtt_csv(o.rtt_csv, r.tally);
  std::map<int64_t, bool> ours;  // worker id -> connected at the end
  for (const SimWorker* sw : shards.workers()) ours[sw->id] = sw->welcomed && !sw->silent;
  for (const auto& [id, live] : ours) r.connected += live;
  for (const protocol::WorkerStatus& ws : r.check.workers.workers)
    r.listed_lost += ours.count(ws.id) && ws.state == "lost";
  const json out = report(o, rec, jobs, r);
  std::printf("%s\n", out.dump(2).c_str());
  return out.at("ok").get<bool>() ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (std::optional<int> code = parse_options(argc, argv, o)) return *code;
  o.threads = std::min(o.threads, o.workers);
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd_bench_farm_load: error: %s\n", e.what());
    return 2;
  }
}

