#include "support/farm.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <thread>

#include "support/intersection_checker.h"
#include "support/test_paths.h"

namespace pd::test {

using namespace std::chrono_literals;
using nlohmann::json;

std::string scene_path(const std::string& name) { return source_dir() + "/scenes/" + name; }

json parse_json(const RunResult& r) {
  try {
    return json::parse(r.out);
  } catch (const json::exception& e) {
    throw std::runtime_error(std::string("not JSON (") + e.what() + "): " + r.describe());
  }
}

Farm::Farm(const std::string& dir, const FarmOptions& options) : dir_(dir), options_(options) {
  start_scheduler();
  for (int k = 1; k <= options.workers; ++k) add_worker(options.worker_args);
  if (options.wait_for_workers) wait_for_idle_workers(options.workers, 20s);
}

int Farm::add_worker(const Args& args, const EnvAdditions& env) {
  const int k = static_cast<int>(workers_.size()) + 1;
  const std::string name = "w" + std::to_string(k);
  worker_logs_.push_back(dir_ + "/worker-" + name + ".log");
  workers_.emplace_back();
  // --scratch inside the test's folder: the default /tmp/pd-worker-<pid> outlives a killed worker.
  // --exit-with-parent: a test process killed outright (a signal, ctest's timeout) takes its farm with it.
  Args argv = {PD_WORKER_BINARY, "--connect", workers_endpoint_, "--name", name, "--scratch", dir_ + "/scratch-" + name,
               "--exit-with-parent", std::to_string(getpid())};
  argv.insert(argv.end(), args.begin(), args.end());
  workers_.back().start(argv, env, worker_logs_.back(), worker_logs_.back());
  return k;
}

void Farm::start_scheduler() {
  const bool restart = !logs_.empty();
  const std::string out = dir_ + "/scheduler" + (restart ? "." + std::to_string(logs_.size()) : "") + ".out";
  logs_.push_back(dir_ + "/scheduler" + (restart ? "." + std::to_string(logs_.size()) : "") + ".log");
  Args argv = {PD_SCHEDULER_BINARY,
               "--dir",
               dir_ + "/farm",
               "--workers-endpoint",
               restart ? workers_endpoint_ : "tcp://127.0.0.1:0",
               "--clients-endpoint",
               restart ? clients_ : "tcp://127.0.0.1:0",
               "--heartbeat-ms",
               std::to_string(options_.heartbeat_ms),
               "--exit-with-parent",
               std::to_string(getpid())};
  argv.insert(argv.end(), options_.scheduler_args.begin(), options_.scheduler_args.end());
  scheduler_ = Process();
  scheduler_.start(argv, options_.scheduler_env, out, logs_.back());
  const auto line = read_first_line(out, 20s, &scheduler_);
  if (!line) throw std::runtime_error("pd-scheduler printed no first line; its log:\n" + file_tail(logs_.back()));
  const json listening = json::parse(*line);
  if (listening.at("event") != "listening") throw std::runtime_error("first line is not 'listening': " + *line);
  if (listening.at("dir") != dir_ + "/farm") throw std::runtime_error("first line names another dir: " + *line);
  workers_endpoint_ = listening.at("workers").get<std::string>();
  clients_ = listening.at("clients").get<std::string>();
}

RunResult Farm::pd(Args args, std::chrono::milliseconds timeout) const {
  args.insert(args.begin(), PD_BINARY);
  args.insert(args.end(), {"--farm", clients_});
  args.insert(args.end(), options_.client_args.begin(), options_.client_args.end());
  return run(args, timeout);
}

void Farm::kill_worker(int k) {
  Process& w = worker(k);
  ::kill(w.pid(), SIGKILL);
  w.wait_for_exit(10s);
}

void Farm::kill_scheduler() {
  ::kill(scheduler_.pid(), SIGKILL);
  scheduler_.wait_for_exit(10s);
}

int Farm::stop() {
  for (Process& w : workers_) w.terminate(5s);
  return scheduler_.terminate(10s);
}

std::string Farm::log_tails() const {
  std::string s;
  for (const std::string& log : logs_) {
    std::string events, line;
    std::ifstream in(log);
    int frames = 0;
    while (std::getline(in, line))
      if (line.find("\"frame_stored\"") == std::string::npos) events += line + "\n";
      else ++frames;
    const std::string tail = events.size() > 6000 ? "...\n" + events.substr(events.size() - 6000) : events;
    s += "---- " + log + " (" + std::to_string(frames) + " frame_stored lines left out)\n" + tail;
  }
  for (const std::string& w : worker_logs_) s += "---- " + w + " (tail)\n" + file_tail(w, 15);
  return s;
}

void Farm::wait_for_idle_workers(int n, std::chrono::milliseconds timeout) const {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::string last;
  for (;;) {
    const RunResult r = pd({"workers", "--json"});
    last = r.describe();
    if (r.exit_code == 0) {
      const json j = parse_json(r);
      const auto idle = std::count_if(j.at("workers").begin(), j.at("workers").end(),
                                      [](const json& w) { return w.at("state") == "idle"; });
      if (idle == n) return;
    }
    if (std::chrono::steady_clock::now() >= deadline)
      throw std::runtime_error("the workers did not all register as idle in time; last: " + last);
    std::this_thread::sleep_for(100ms);
  }
}

Farm& FarmTest::start_farm(int workers, const std::string& tag) {
  FarmOptions o;
  o.workers = workers;
  return start_farm(o, tag);
}

Farm& FarmTest::start_farm(const FarmOptions& options, const std::string& tag) {
  dirs_.push_back(scratch_dir(tag));
  farms_.push_back(std::make_unique<Farm>(dirs_.back(), options));
  return *farms_.back();
}

void FarmTest::TearDown() {
  for (auto& farm : farms_) {
    EXPECT_EQ(farm->stop(), 0) << "pd-scheduler did not exit 0 on SIGTERM";
    if (HasFailure()) std::printf("%s", farm->log_tails().c_str());
  }
  farms_.clear();
  // Kept for a look when the test failed; the frame files are megabytes otherwise left in /tmp.
  for (const std::string& d : dirs_) {
    if (HasFailure()) std::printf("kept %s\n", d.c_str());
    else std::filesystem::remove_all(d);
  }
}

int64_t submit(const Farm& farm, Args args) {
  args.insert(args.begin(), "submit");
  args.push_back("--json");
  const RunResult r = farm.pd(args);
  if (r.exit_code != 0) throw std::runtime_error("pd submit failed: " + r.describe());
  return parse_json(r).at("job").get<int64_t>();
}

json job_status(const Farm& farm, int64_t job) {
  const RunResult r = farm.pd({"status", std::to_string(job), "--json"});
  if (r.exit_code != 0) throw std::runtime_error("pd status failed: " + r.describe());
  const json jobs = parse_json(r).at("jobs");
  if (jobs.size() != 1 || jobs[0].at("id") != job) throw std::runtime_error("status lists other jobs: " + r.out);
  return jobs[0];
}

void wait_until_done(const Farm& farm, int64_t job, std::chrono::milliseconds timeout) {
  const RunResult r = farm.pd({"status", std::to_string(job), "--wait", "--interval", "0.2"}, timeout);
  if (r.exit_code != 0) throw std::runtime_error("job " + std::to_string(job) + " did not end done: " + r.describe());
}

void fetch(const Farm& farm, int64_t job, const std::string& out) {
  const RunResult r = farm.pd({"fetch", std::to_string(job), "--out", out}, 60s);
  if (r.exit_code != 0) throw std::runtime_error("pd fetch failed: " + r.describe());
}

Process start_reference(const std::string& scene, const std::string& out, int frames) {
  Process p;
  // The reference for the farm's frames: a farm task that stops steps at the Newton cap still ends
  // done, so the reference accepts them too (pd simulate would otherwise exit 3).
  p.start({PD_BINARY, "simulate", scene, "--mode", "progressive", "--frames", std::to_string(frames), "--quiet",
           "--allow-unconverged", "--out", out},
          {}, out + ".log", out + ".log");
  return p;
}

void finish_reference(Process& p, const std::string& out, std::chrono::milliseconds timeout) {
  const auto code = p.wait_for_exit(timeout);
  if (code != 0)
    throw std::runtime_error("pd simulate " + (code ? "exited " + std::to_string(*code) : "timed out") + ":\n" +
                             file_tail(out + ".log"));
}

bool same_bits(const Positions& a, const Positions& b) {
  return a.rows() == b.rows() && std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

void expect_identical_frames(const FrameReader& a, const FrameReader& b, int level, int first, int last) {
  ASSERT_EQ(a.num_vertices(level), b.num_vertices(level)) << "level " << level;
  ASSERT_EQ(a.faces(level), b.faces(level)) << "level " << level;
  int differing = 0;
  for (int t = first; t <= last; ++t) {
    if (same_bits(a.frame(level, t), b.frame(level, t))) continue;
    if (++differing <= 3) ADD_FAILURE() << a.path() << " and " << b.path() << ": level " << level << " frame " << t
                                        << " differs";
  }
  EXPECT_EQ(differing, 0) << "level " << level << ": frames " << first << ".." << last << " differing";
}

std::vector<json> log_events(const std::string& log_path, const std::string& kind) {
  std::vector<json> events;
  std::ifstream in(log_path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] != '{') continue;
    try {
      json j = json::parse(line);
      if (j.value("event", "") == kind) events.push_back(std::move(j));
    } catch (const json::exception&) {
      // a line cut by a SIGKILL
    }
  }
  return events;
}

// Largest vertex distance (m) between the files over frames first..last of `level`.
double max_vertex_deviation(const FrameReader& a, const FrameReader& b, int level, int first, int last) {
  double worst = 0.0;
  for (int t = first; t <= last; ++t) worst = std::max(worst, (a.frame(level, t) - b.frame(level, t)).rowwise().norm().maxCoeff());
  return worst;
}

// Every frame of every level stored, and none intersecting (independent CGAL check).
void expect_complete_and_intersection_free(const FrameReader& r) {
  for (int l = 0; l < r.num_levels(); ++l) {
    const std::vector<uint8_t> done = r.done(l);
    EXPECT_EQ(std::count(done.begin(), done.end(), uint8_t{1}), r.num_frames()) << r.path() << " level " << l;
    const Faces faces = r.faces(l);
    for (int t = 0; t < r.num_frames(); ++t) {
      if (!done[t]) continue;
      const IntersectionReport rep = find_intersections(r.frame(l, t), faces);
      EXPECT_EQ(rep.intersecting_pairs, 0) << r.path() << " level " << l << " frame " << t;
      EXPECT_TRUE(rep.degenerate_faces.empty()) << r.path() << " level " << l << " frame " << t;
    }
  }
}

void expect_every_level_complete(const nlohmann::json& job, int frames) {
  EXPECT_EQ(job.at("state"), "done");
  for (const nlohmann::json& l : job.at("levels")) {
    EXPECT_EQ(l.at("frames_total"), frames + 1) << l.dump();
    EXPECT_EQ(l.at("frames_done"), l.at("frames_total")) << l.dump();
  }
}

// Submits `scene` for `frames` frames in `subsets` time subsets with its reference pd simulate
// (progressive, one process) running beside it, waits for both, and fetches the job's frames:
// DIR/job.h5 and DIR/ref.h5, DIR the farm's folder. Returns the job id.
int64_t run_beside_reference(Farm& farm, const std::string& scene, int frames, int subsets) {
  const std::string ref_path = farm.dir() + "/ref.h5";
  const int64_t job = submit(farm, {scene, "--frames", std::to_string(frames), "--subsets", std::to_string(subsets)});
  test::Process ref = start_reference(scene, ref_path, frames);
  wait_until_done(farm, job, kLongJob);
  fetch(farm, job, farm.dir() + "/job.h5");
  finish_reference(ref, ref_path, kLongJob);
  return job;
}


std::set<std::string> task_workers(const nlohmann::json& job) {
  std::set<std::string> names;
  for (const nlohmann::json& t : job.at("tasks")) names.insert(t.at("worker").get<std::string>());
  return names;
}

}  // namespace pd::test
