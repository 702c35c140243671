// The farm end to end: real pd-scheduler and pd-worker processes on loopback port-0 endpoints, driven
// with the pd client as a user drives them (tests/support/process.h starts, bounds and stops them).
// Checked: a K = 1 job gives the frames of `pd simulate --mode progressive` bit for bit; a killed
// worker changes no frame; pd refine; queueing and cancelling; bad input; `pd run`. Jobs with time
// subsets (K >= 2) are tested in subsets_test.cpp.
//
// Frames: cube-trampoline's full 200 for K = 1 (the job on two workers with its reference `pd
// simulate` beside it: about 30 s on the 2-core machine); fewer where only the farm's mechanics are
// checked.
#include <gtest/gtest.h>

#include <dirent.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "farm/messaging.h"
#include "protocol/protocol.h"
#include "store/frame_store.h"
#include "support/intersection_checker.h"
#include "support/farm.h"
#include "support/process.h"
#include "support/test_paths.h"
#include "util/process_setup.h"

namespace pd {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using test::Args;
using test::Farm;
using test::FarmTest;
using test::fetch;
using test::job_status;
using test::kCommand;
using test::kLongJob;
using test::kShortJob;
using test::parse_json;
using test::scene_path;
using test::submit;
using test::wait_until_done;
using test::same_bits;
using test::expect_identical_frames;
using test::finish_reference;
using test::start_reference;
using test::expect_complete_and_intersection_free;
using test::expect_every_level_complete;
using test::run_beside_reference;
using test::task_workers;

constexpr int kFullFrames = 200;  // scenes/cube-trampoline.json's own count
// One subset: the cube's fall, its bounce off the trampoline (frames ~45-55) and its flight after;
// the scene's 200 frames took 80 s here and run through no farm code that 80 frames do not.
constexpr int kOneSubsetFrames = 80;


TEST_F(FarmTest, TwoWorkersOneSubsetGiveTheFramesOfPdSimulateBitForBitAndIntersectionFree) {
  Farm& farm = start_farm(2, "farm_k1");
  const std::string ref_path = farm.dir() + "/ref.h5";
  const int64_t job = run_beside_reference(farm, scene_path("cube-trampoline.json"), kOneSubsetFrames, 1);

  const json status = job_status(farm, job);
  expect_every_level_complete(status, kOneSubsetFrames);
  EXPECT_EQ(status.at("levels").size(), 3u);
  const std::set<std::string> workers = task_workers(status);
  EXPECT_TRUE(workers.count("w1") && workers.count("w2")) << "tasks ran on: " << status.at("tasks").dump();

  const FrameReader got(farm.dir() + "/job.h5"), want(ref_path);
  ASSERT_EQ(got.num_levels(), 3);
  ASSERT_EQ(got.num_levels(), want.num_levels());
  ASSERT_EQ(got.num_frames(), kOneSubsetFrames + 1);
  ASSERT_EQ(got.num_frames(), want.num_frames());
  for (int l = 0; l < got.num_levels(); ++l) expect_identical_frames(got, want, l, 0, kOneSubsetFrames);
  expect_complete_and_intersection_free(got);
}

// Polls `condition` every 100 ms for at most `timeout`; true once it held.
template <typename F>
bool eventually(std::chrono::milliseconds timeout, F condition) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    if (condition()) return true;
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(100ms);
  }
}

// A worker killed mid-job (SIGKILL, no goodbye): after 3 missed heartbeats the scheduler takes its
// attempt back; the remaining worker, held by a refinement task waiting for the lost task's frames,
// is taken back too (preempted) so it can run that task first. The job still ends done with the
// frames of the uninterrupted run, bit for bit.
TEST_F(FarmTest, AWorkerKilledMidJobIsReplacedAndTheFramesStayThoseOfTheUninterruptedRun) {
  constexpr int kFrames = 120;
  Farm& farm = start_farm(2, "farm_lost");
  const std::string scene = scene_path("cube-trampoline.json"), ref_path = farm.dir() + "/ref.h5";
  const int64_t job = submit(farm, {scene, "--frames", std::to_string(kFrames), "--preview-chunk", "30"});
  // Kill w1 once the preview is under way beyond its first chunk and level 1 runs beside it.
  const bool under_way = eventually(60s, [&] {
    const json s = job_status(farm, job);
    return s.at("levels").at(0).at("frames_done").get<int>() > 40 && s.at("levels").at(1).at("frames_done").get<int>() > 1;
  });
  ASSERT_TRUE(under_way) << job_status(farm, job).dump();
  json before = job_status(farm, job);
  std::string victim;
  for (const json& t : before.at("tasks"))
    if (t.at("state") == "running" && t.at("level") == 0) victim = t.at("worker").get<std::string>();
  // The preview (0.5 s in all) can end between two polls on a loaded machine: then the worker of any
  // running task is the victim (the job must still end with the uninterrupted run's frames, but the
  // preemption of a refinement task waiting for the lost preview is not exercised this time).
  if (victim.empty()) {
    std::printf("the preview ended between two polls: killing the worker of a refinement task instead\n");
    for (const json& t : before.at("tasks"))
      if (t.at("state") == "running") victim = t.at("worker").get<std::string>();
  }
  ASSERT_FALSE(victim.empty()) << "no task running: " << before.dump();
  farm.kill_worker(victim == "w1" ? 1 : 2);
  test::Process ref = start_reference(scene, ref_path, kFrames);
  wait_until_done(farm, job, kShortJob);
  fetch(farm, job, farm.dir() + "/job.h5");
  finish_reference(ref, ref_path, kShortJob);

  const json status = job_status(farm, job);
  expect_every_level_complete(status, kFrames);
  int retried = 0;
  for (const json& t : status.at("tasks")) retried += t.at("attempts").get<int>() > 1;
  EXPECT_GE(retried, 1) << "no task was attempted twice: " << status.dump();
  const FrameReader got(farm.dir() + "/job.h5"), want(ref_path);
  for (int l = 0; l < got.num_levels(); ++l) expect_identical_frames(got, want, l, 0, kFrames);
}

// A preview-only job ends done with level 0 alone; pd refine then adds the refinement levels, which
// run from the stored preview and give the frames of one progressive run bit for bit.
TEST_F(FarmTest, RefiningAFinishedPreviewAddsTheLevelsAndGivesTheFramesOfOneProgressiveRun) {
  constexpr int kFrames = 30;
  Farm& farm = start_farm(2, "farm_refine");
  const std::string scene = scene_path("cube-trampoline.json"), ref_path = farm.dir() + "/ref.h5";
  const int64_t job = submit(farm, {scene, "--frames", std::to_string(kFrames), "--preview-only"});
  wait_until_done(farm, job, kShortJob);
  const json preview = job_status(farm, job);
  EXPECT_TRUE(preview.at("preview_only").get<bool>());
  ASSERT_EQ(preview.at("levels").size(), 1u) << preview.dump();
  expect_every_level_complete(preview, kFrames);

  const test::RunResult refine = farm.pd({"refine", std::to_string(job)});
  ASSERT_EQ(refine.exit_code, 0) << refine.describe();
  const test::RunResult again = farm.pd({"refine", std::to_string(job)});
  EXPECT_EQ(again.exit_code, 2) << "a second refine must be refused: " << again.describe();
  test::Process ref = start_reference(scene, ref_path, kFrames);
  wait_until_done(farm, job, kShortJob);
  fetch(farm, job, farm.dir() + "/job.h5");
  finish_reference(ref, ref_path, kShortJob);
  const json refined = job_status(farm, job);
  EXPECT_FALSE(refined.at("preview_only").get<bool>());
  ASSERT_EQ(refined.at("levels").size(), 3u) << refined.dump();
  expect_every_level_complete(refined, kFrames);
  const FrameReader got(farm.dir() + "/job.h5"), want(ref_path);
  for (int l = 0; l < got.num_levels(); ++l) expect_identical_frames(got, want, l, 0, kFrames);
}

TEST_F(FarmTest, SecondJobQueuesThenRunsAndCancellingTheFirstFreesItsWorkersWithinHeartbeats) {
  Farm& farm = start_farm(2, "farm_cancel");
  const std::string scene = scene_path("cube-trampoline.json");
  const int64_t first = submit(farm, {scene, "--frames", std::to_string(kFullFrames)});
  // Both workers on the first job (preview chain and the pipelined level 1), so the second must queue.
  const bool both_busy = eventually(30s, [&] {
    const json w = parse_json(farm.pd({"workers", "--json"})).at("workers");
    return std::count_if(w.begin(), w.end(), [](const json& x) { return x.at("state") == "busy"; }) == 2;
  });
  ASSERT_TRUE(both_busy) << farm.pd({"workers", "--json"}).describe();
  const int64_t second = submit(farm, {scene, "--frames", "20"});
  EXPECT_EQ(job_status(farm, second).at("state"), "queued");
  ASSERT_EQ(job_status(farm, first).at("state"), "running");

  const test::RunResult cancel = farm.pd({"cancel", std::to_string(first)});
  ASSERT_EQ(cancel.exit_code, 0) << cancel.describe();
  const auto t0 = std::chrono::steady_clock::now();
  json cancelled;
  const bool stopped = eventually(10s, [&] {
    cancelled = job_status(farm, first);
    std::set<int64_t> ids;
    for (const json& t : cancelled.at("tasks")) {
      if (t.at("state") == "running") return false;
      ids.insert(t.at("id").get<int64_t>());
    }
    const json w = parse_json(farm.pd({"workers", "--json"})).at("workers");
    const bool busy_on_it = std::any_of(w.begin(), w.end(), [&](const json& x) {
      return x.at("state") == "busy" && ids.count(x.at("task").get<int64_t>());
    });
    return cancelled.at("state") == "cancelled" && !busy_on_it;
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(stopped) << "after 10 s: " << cancelled.dump() << "\n" << farm.pd({"workers", "--json"}).describe();
  std::printf("cancelled job stopped everywhere within %.2f s\n", seconds);
  // No frame is added to a cancelled job: its counts stay put over two heartbeats.
  std::this_thread::sleep_for(2s);
  EXPECT_EQ(job_status(farm, first).at("levels"), cancelled.at("levels"));

  wait_until_done(farm, second, kShortJob);
  expect_every_level_complete(job_status(farm, second), 20);
}

std::string write_text(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

// A free loopback port nobody listens on: bound to port 0, read back, closed.
int unused_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof(addr);
  if (fd < 0 || bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0)
    throw std::runtime_error(std::string("cannot find a free port: ") + std::strerror(errno));
  close(fd);
  return ntohs(addr.sin_port);
}

void expect_usage_error(const test::RunResult& r, const std::string& mention) {
  EXPECT_EQ(r.exit_code, 2) << r.describe();
  EXPECT_NE(r.err.find("pd: error:"), std::string::npos) << r.describe();
  EXPECT_NE(r.err.find(mention), std::string::npos) << "expected '" << mention << "' in: " << r.describe();
}

// The reason of the next `refused` the scheduler sends `peer` after `parts` (welcome and heartbeats
// in between are skipped), or "(no answer)" after 5 s.
std::string refusal_of(zmq::socket_t& peer, const protocol::Parts& parts) {
  farm::send_parts(peer, parts);
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (std::chrono::steady_clock::now() < deadline) {
    const std::optional<protocol::Parts> reply = farm::recv_parts_within(peer, 500ms);
    if (!reply) continue;
    const protocol::Command c = protocol::decode_command(*reply);
    if (const auto* r = std::get_if<protocol::Refused>(&c)) return r->reason;
  }
  return "(no answer)";
}

// A peer on the worker socket that misbehaves: not a message, a report before any hello, a hello
// the store cannot take, a frame for a task it was never given, then silence while registered
// (it is given the hierarchy task and never answers). Each bad message is refused with its reason,
// and the scheduler keeps serving: its own worker runs a job to the end.
TEST_F(FarmTest, BadWorkerMessagesAreRefusedAndTheSchedulerKeepsServing) {
  Farm& farm = start_farm(1, "farm_bad_peer");
  zmq::context_t ctx(1);
  zmq::socket_t peer(ctx, zmq::socket_type::dealer);
  farm::configure_socket(peer);
  peer.connect(farm.workers_endpoint());
  EXPECT_NE(refusal_of(peer, {"not json"}).find("malformed report"), std::string::npos);
  protocol::FrameReport frame;
  frame.attempt = 9;
  frame.task = 1;
  frame.frame = 1;
  frame.positions = {0.0, 0.0, 0.0};
  EXPECT_NE(refusal_of(peer, protocol::encode(frame)).find("send hello first"), std::string::npos);
  protocol::Hello hello;
  hello.name = "intruder";
  hello.host = "nowhere";
  hello.version = "0";
  hello.cores = 0;
  EXPECT_NE(refusal_of(peer, protocol::encode(hello)).find("cores"), std::string::npos);
  hello.cores = 1;
  hello.blas_kernel = "NotTheWorkersKernel";  // the farm's worker runs this machine's pinned kernel
  farm.wait_for_idle_workers(1, kCommand);  // so that the intruder joins second, beside it
  farm::send_parts(peer, protocol::encode(hello));
  EXPECT_NE(refusal_of(peer, protocol::encode(frame)).find("not this worker's running attempt"), std::string::npos);

  const int64_t job = submit(farm, {scene_path("cube-trampoline.json"), "--frames", "10"});
  wait_until_done(farm, job, kShortJob);
  expect_every_level_complete(job_status(farm, job), 10);
  const json workers = parse_json(farm.pd({"workers", "--json"})).at("workers");
  const auto intruder = std::find_if(workers.begin(), workers.end(), [](const json& w) { return w.at("name") == "intruder"; });
  ASSERT_NE(intruder, workers.end()) << workers.dump();
  EXPECT_EQ(intruder->at("state"), "lost");
  // Joined beside a worker on another OpenBLAS kernel: said once, naming both.
  const auto differs = test::log_events(farm.scheduler_log(), "worker_kernel_differs");
  ASSERT_EQ(differs.size(), 1u) << test::read_file_text(farm.scheduler_log());
  const std::string message = differs[0].at("message");
  EXPECT_NE(message.find("NotTheWorkersKernel"), std::string::npos) << message;
  EXPECT_NE(message.find(blas_kernel_in_use()), std::string::npos) << message;
}

// A hello that names a connected worker is refused, whoever sends it: it used to evict that worker's
// session and lose its attempt (issue 47, item 4). The worker runs its job to the end, never lost.
TEST_F(FarmTest, AHelloWithTheNameOfAConnectedWorkerIsRefusedAndTheWorkerKeepsItsAttempt) {
  Farm& farm = start_farm(1, "farm_name_taken");
  constexpr int kFrames = 150;  // the flag: about 10 s on one worker, time enough to catch a running task
  const int64_t job = submit(farm, {scene_path("flag.json"), "--frames", std::to_string(kFrames)});
  std::string name;
  ASSERT_TRUE(eventually(60s, [&] {
    const json status = job_status(farm, job);
    for (const json& t : status.at("tasks"))
      if (t.at("state") == "running" && t.at("kind") == "level") name = t.at("worker").get<std::string>();
    return !name.empty() || status.at("state") == "done";
  }));
  ASSERT_FALSE(name.empty()) << "the job ended before a level task was seen running";
  zmq::context_t ctx(1);
  zmq::socket_t peer(ctx, zmq::socket_type::dealer);
  farm::configure_socket(peer);
  peer.connect(farm.workers_endpoint());
  protocol::Hello hello;
  hello.name = name;
  hello.host = "elsewhere";
  hello.version = "0";
  hello.cores = 1;
  const std::string why = refusal_of(peer, protocol::encode(hello));
  EXPECT_NE(why.find("field 'name': worker '" + name + "' is connected"), std::string::npos) << why;
  wait_until_done(farm, job, kShortJob);
  expect_every_level_complete(job_status(farm, job), kFrames);
  EXPECT_TRUE(test::log_events(farm.scheduler_log(), "worker_lost").empty()) << test::read_file_text(farm.scheduler_log());
  const json done = job_status(farm, job);  // kept: a range-for over a temporary's member reads freed memory
  for (const json& t : done.at("tasks")) EXPECT_EQ(t.at("attempts").get<int>(), 1) << t.dump();
}

TEST_F(FarmTest, BadScenesJobsOptionsAndUnreachableFarmsExitTwoWithClearMessages) {
  Farm& farm = start_farm(0, "farm_bad");
  const std::string dir = farm.dir();
  const std::string broken = write_text(dir + "/broken.json", "{\n  \"time_step\": 0.01,\n  \"frames\": ,\n}\n");
  // A misspelt key in an otherwise valid scene ("thicknes" beside "thickness").
  json scene = json::parse(test::read_file_text(scene_path("cube-trampoline.json")));
  scene["objects"][0]["material"]["thicknes"] = 0.002;
  const std::string bad_key = write_text(dir + "/bad-key.json", scene.dump(2));
  for (const auto& [file, mention] : {std::pair{broken, "broken.json"}, std::pair{bad_key, "thicknes"}}) {
    const test::RunResult sim = test::run({PD_BINARY, "simulate", file, "--out", dir + "/x.h5"}, kCommand);
    const test::RunResult sub = farm.pd({"submit", file});
    EXPECT_EQ(sim.exit_code, 2) << sim.describe();
    expect_usage_error(sub, mention);
    EXPECT_EQ(sub.err, sim.err) << "pd submit and pd simulate differ on " << file;
  }

  expect_usage_error(farm.pd({"status", "999"}), "999");
  expect_usage_error(farm.pd({"cancel", "999"}), "999");
  const std::string valid = scene_path("cube-trampoline.json");
  expect_usage_error(farm.pd({"submit", "--subsets", "0", valid}), "--subsets");
  expect_usage_error(farm.pd({"submit", valid, "--subsets", "2", "--stitch", "1001"}), "--stitch");
  expect_usage_error(farm.pd({"submit", valid, "--frames", "-3"}), "--frames");
  expect_usage_error(farm.pd({"status", "--wait"}), "--wait");

  // The farm endpoint from PD_FARM when --farm is not given.
  const test::RunResult env_ok = test::run({PD_BINARY, "workers", "--json"}, kCommand, {{"PD_FARM", farm.clients()}});
  EXPECT_EQ(env_ok.exit_code, 0) << env_ok.describe();
  const std::string nowhere = "tcp://127.0.0.1:" + std::to_string(unused_port());
  const test::RunResult by_option = test::run({PD_BINARY, "status", "--farm", nowhere}, 30s);
  expect_usage_error(by_option, nowhere);
  EXPECT_LT(by_option.seconds, 10.0) << by_option.describe();
  const test::RunResult by_env = test::run({PD_BINARY, "submit", valid}, 30s, {{"PD_FARM", nowhere}});
  expect_usage_error(by_env, nowhere);
  EXPECT_LT(by_env.seconds, 10.0) << by_env.describe();

  // Nothing that was refused became a job.
  const test::RunResult all = farm.pd({"status", "--json"});
  ASSERT_EQ(all.exit_code, 0) << all.describe();
  EXPECT_TRUE(parse_json(all).at("jobs").empty()) << all.out;
}

// While it lives, this process adopts the orphans of its descendants (PR_SET_CHILD_SUBREAPER), so a
// farm process that `pd run` left behind becomes a child of the test, where it can be seen. On
// destruction it kills and reaps any such process still there, so none outlives the test.
class AdoptOrphans {
 public:
  AdoptOrphans() { prctl(PR_SET_CHILD_SUBREAPER, 1); }
  ~AdoptOrphans() {
    prctl(PR_SET_CHILD_SUBREAPER, 0);
    for (const auto& [pid, name] : children({})) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
  }
  AdoptOrphans(const AdoptOrphans&) = delete;
  AdoptOrphans& operator=(const AdoptOrphans&) = delete;

  // This process's children (pid, command name from /proc/<pid>/stat) but those in `known`,
  // zombies included: a zombie here is a child its parent did not reap.
  static std::vector<std::pair<pid_t, std::string>> children(const std::set<pid_t>& known) {
    return children_of(getpid(), known);
  }
  // The same for the children of `parent`; the name ends with " (state S)", Z for a zombie.
  static std::vector<std::pair<pid_t, std::string>> children_of(pid_t parent, const std::set<pid_t>& known) {
    std::vector<std::pair<pid_t, std::string>> out;
    DIR* proc = opendir("/proc");
    if (!proc) return out;
    while (const dirent* e = readdir(proc)) {
      const pid_t pid = static_cast<pid_t>(std::atoi(e->d_name));
      if (pid <= 0 || known.count(pid)) continue;
      const std::string stat = test::read_file_text("/proc/" + std::string(e->d_name) + "/stat");
      // "pid (comm) state ppid ...": comm may hold spaces and parentheses, so split at the last ')'.
      const size_t open = stat.find('('), close = stat.rfind(')');
      if (open == std::string::npos || close == std::string::npos || close + 2 > stat.size()) continue;
      char state = 0;
      long ppid = 0;
      if (std::sscanf(stat.c_str() + close + 2, "%c %ld", &state, &ppid) != 2 || ppid != parent) continue;
      out.emplace_back(pid, stat.substr(open + 1, close - open - 1) + " (state " + state + ")");
    }
    closedir(proc);
    return out;
  }
};

// A scheduler stopped and started again on the same endpoints: the worker that was connected is told
// it is unknown (or misses 3 heartbeats), says hello again, and takes the new scheduler's work.
TEST(SchedulerRestart, AConnectedWorkerRegistersAgainWithTheNewSchedulerAndRunsItsJob) {
  const std::string dir = test::scratch_dir("farm_restart");
  auto start_scheduler = [&](test::Process& p, const std::string& workers, const std::string& clients,
                             const std::string& tag) -> json {
    const std::string out = dir + "/scheduler-" + tag + ".out";
    p.start({PD_SCHEDULER_BINARY, "--dir", dir + "/farm-" + tag, "--workers-endpoint", workers, "--clients-endpoint",
             clients},
            {}, out, dir + "/scheduler-" + tag + ".log");
    const auto line = test::read_first_line(out, 20s, &p);
    if (!line) throw std::runtime_error("no listening line: " + test::file_tail(dir + "/scheduler-" + tag + ".log"));
    return json::parse(*line);
  };
  test::Process first, second, worker;
  const json listening = start_scheduler(first, "tcp://127.0.0.1:0", "tcp://127.0.0.1:0", "a");
  const std::string workers = listening.at("workers"), clients = listening.at("clients");
  worker.start({PD_WORKER_BINARY, "--connect", workers, "--name", "w1", "--scratch", dir + "/scratch"}, {},
               dir + "/worker.log", dir + "/worker.log");
  auto idle_workers = [&] {
    const test::RunResult r = test::run({PD_BINARY, "workers", "--json", "--farm", clients}, kCommand);
    if (r.exit_code != 0) return 0L;
    const json w = parse_json(r).at("workers");
    return static_cast<long>(std::count_if(w.begin(), w.end(), [](const json& x) { return x.at("state") == "idle"; }));
  };
  ASSERT_TRUE(eventually(20s, [&] { return idle_workers() == 1; })) << test::file_tail(dir + "/worker.log");
  ASSERT_EQ(first.terminate(10s), 0);
  // A fresh farm folder (restarting on the same folder fails its unfinished jobs; none here).
  start_scheduler(second, workers, clients, "b");
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(eventually(40s, [&] { return idle_workers() == 1; })) << test::file_tail(dir + "/worker.log");
  std::printf("the worker registered with the new scheduler after %.1f s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  const test::RunResult sub = test::run(
      {PD_BINARY, "submit", scene_path("cube-trampoline.json"), "--frames", "5", "--farm", clients}, kCommand);
  ASSERT_EQ(sub.exit_code, 0) << sub.describe();
  const test::RunResult wait = test::run(
      {PD_BINARY, "status", "1", "--wait", "--interval", "0.2", "--farm", clients}, kShortJob);
  EXPECT_EQ(wait.exit_code, 0) << wait.describe() << test::file_tail(dir + "/worker.log");
  worker.terminate(5s);
  EXPECT_EQ(second.terminate(10s), 0);
  if (!::testing::Test::HasFailure()) std::filesystem::remove_all(dir);
}

TEST(PdRun, TwoWorkersTwentyFramesMatchPdSimulateBitForBitAndLeaveNoFarmProcess) {
  constexpr int kFrames = 20;
  const std::string dir = test::scratch_dir("pd_run"), scene = scene_path("cube-trampoline.json");
  const std::string out = dir + "/run.h5", ref_path = dir + "/ref.h5";
  const AdoptOrphans adopt;  // declared before `ref`, so it outlives it
  test::Process ref = start_reference(scene, ref_path, kFrames);
  const test::RunResult r =
      test::run({PD_BINARY, "run", scene, "--workers", "2", "--out", out, "--frames", std::to_string(kFrames)},
                kShortJob, {{"PD_SCHEDULER_BIN", PD_SCHEDULER_BINARY}, {"PD_WORKER_BIN", PD_WORKER_BINARY}});
  ASSERT_EQ(r.exit_code, 0) << r.describe();
  // pd has been reaped; any other child of ours now is one of pd's that it did not stop and reap.
  std::string left;
  for (const auto& [pid, name] : AdoptOrphans::children({ref.pid()})) left += std::to_string(pid) + " " + name + "; ";
  EXPECT_TRUE(left.empty()) << "left behind by pd run: " << left;
  finish_reference(ref, ref_path, kShortJob);

  const FrameReader got(out), want(ref_path);
  ASSERT_EQ(got.num_levels(), want.num_levels());
  ASSERT_EQ(got.num_frames(), kFrames + 1);
  ASSERT_EQ(got.num_frames(), want.num_frames());
  for (int l = 0; l < got.num_levels(); ++l) expect_identical_frames(got, want, l, 0, kFrames);
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

// Kills `parent` outright (SIGKILL: no destructor, no handler runs) once it has `count` children, and
// returns whether all of them then ended within 20 s (this test process adopts them: AdoptOrphans
// must be alive). Their --exit-with-parent makes the kernel stop them when their parent dies.
bool children_end_with_their_killed_parent(test::Process& parent, std::size_t count, std::string& report) {
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  std::vector<std::pair<pid_t, std::string>> kids;
  while ((kids = AdoptOrphans::children_of(parent.pid(), {})).size() < count && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(50ms);
  if (kids.size() < count) {
    report = "the parent had " + std::to_string(kids.size()) + " children, not " + std::to_string(count);
    return false;
  }
  std::this_thread::sleep_for(500ms);  // started and past their option parsing
  kill(parent.pid(), SIGKILL);
  parent.wait_for_exit(10s);
  std::set<pid_t> pids;
  for (const auto& [pid, name] : kids) pids.insert(pid);
  const auto end = std::chrono::steady_clock::now() + 20s;
  while (std::chrono::steady_clock::now() < end) {
    std::string alive;
    for (const auto& [pid, name] : AdoptOrphans::children({}))
      if (pids.count(pid) && name.find("(state Z)") == std::string::npos) alive += std::to_string(pid) + " " + name + "; ";
    if (alive.empty()) return true;
    report = "still running: " + alive;
    std::this_thread::sleep_for(100ms);
  }
  return false;
}

// pd run killed outright: its scheduler and two workers stop with it.
TEST(PdRun, AKilledPdRunTakesItsSchedulerAndWorkersWithIt) {
  const std::string dir = test::scratch_dir("pd_run_killed");
  const AdoptOrphans adopt;
  test::Process run;
  run.start({PD_BINARY, "run", scene_path("flag.json"), "--workers", "2", "--out", dir + "/run.h5", "--frames", "2000"},
            {{"PD_SCHEDULER_BIN", PD_SCHEDULER_BINARY}, {"PD_WORKER_BIN", PD_WORKER_BINARY}}, dir + "/run.out",
            dir + "/run.err");
  std::string report;
  EXPECT_TRUE(children_end_with_their_killed_parent(run, 3, report)) << report;
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

// A test process killed outright (a signal, ctest's timeout): the farm its test started (a scheduler
// and two workers, tests/support/farm.h) stops with it. The killed process runs one of this binary's
// own farm tests.
TEST(TestFarm, AKilledTestProcessTakesItsFarmWithIt) {
  const std::string dir = test::scratch_dir("test_killed");
  const AdoptOrphans adopt;
  test::Process child;
  child.start({"/proc/self/exe", "--gtest_filter=FarmTest.AStitchedSeamDoesNotPopWhereTheUnstitchedSeamDoes"}, {},
              dir + "/child.out", dir + "/child.err");
  std::string report;
  EXPECT_TRUE(children_end_with_their_killed_parent(child, 3, report)) << report;
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

// pd-worker's numeric options are refused in one short line naming the range (CLI11's
// NonNegativeNumber printed DBL_MAX's 309 digits as the upper bound of --fail-level).
TEST(WorkerCli, BadNumericOptionsAreOneShortLineNamingTheRange) {
  const struct {
    std::vector<std::string> args;
    std::string expected;
  } cases[] = {{{"--fail-level", "-3"}, "--fail-level: Value -3 not in range 0 to 19"},
               {{"--fail-level", "x"}, "--fail-level: Value x not in range 0 to 19"},
               {{"--refuse-vertical-starts-before", "0"}, "--refuse-vertical-starts-before: Value 0 not in range 1 to 10000000"},
               {{"--threads", "1,2"}, "--threads: Value 1,2 not in range 0 to 4096"}};
  for (const auto& c : cases) {
    std::vector<std::string> argv = {PD_WORKER_BINARY, "--connect", "tcp://127.0.0.1:1"};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const test::RunResult r = test::run(argv, kCommand);
    EXPECT_EQ(r.exit_code, 2) << r.describe();
    EXPECT_EQ(r.err.rfind("pd-worker: error: " + c.expected + "\n", 0), 0u) << r.describe();
    EXPECT_LT(r.err.size(), 200u) << r.describe();
  }
}

}  // namespace
}  // namespace pd
