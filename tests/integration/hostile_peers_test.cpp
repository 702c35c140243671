// Hostile peers driven by hand on pd-scheduler's sockets (the generated fuzz is fuzz_test.cpp): a
// peer that never said hello, a registered idle one and one holding a running attempt send reports
// about attempts, tasks and jobs that are not theirs, out of order or forged (a frame of another
// attempt, a task_done before any frame, claims on every task); clients ask about jobs that do not
// exist; raw ZMTP peers declare oversized frames and never-ending messages; a worker sends as its
// hierarchy a file on which HDF5 crashes. Each is refused naming its reason, and the scheduler keeps
// serving.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <map>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "farm/messaging.h"
#include "farm/scene_source.h"
#include "farm/task_graph.h"
#include "protocol/protocol.h"
#include "store/frame_store.h"
#include "support/farm.h"
#include "support/fuzz_messages.h"
#include "support/zmtp_peer.h"
#include "support/process.h"
#include "support/test_paths.h"
#include "util/process_setup.h"

namespace pd {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using protocol::Parts;
using test::FarmTest;
using Clock = std::chrono::steady_clock;

constexpr int kFrames = 20;  // the job the hostile peers talk about while it runs

// A peer on the workers socket driven by hand: each report sent, the reason of the refusal it got.
class HandPeer {
 public:
  HandPeer(zmq::context_t& ctx, const std::string& endpoint, const std::string& id)
      : socket_(ctx, zmq::socket_type::dealer) {
    farm::configure_socket(socket_);
    socket_.set(zmq::sockopt::routing_id, id);
    socket_.connect(endpoint);
  }
  zmq::socket_t& socket() { return socket_; }

  // The reason of the next Refused after sending parts (other commands are kept for wait_for), or
  // "(no answer)" after 5 s.
  std::string refusal(const Parts& parts) {
    farm::send_parts(socket_, parts);
    const auto deadline = Clock::now() + 5s;
    while (Clock::now() < deadline) {
      const std::optional<Parts> p = farm::recv_parts_within(socket_, 200ms);
      if (!p) continue;
      protocol::Command c = protocol::decode_command(*p);
      if (const auto* r = std::get_if<protocol::Refused>(&c)) return r->reason;
      seen_.push_back(std::move(c));
    }
    return "(no answer)";
  }

  // The next command of type T (those of other types are dropped), nullopt after `timeout`.
  template <typename T>
  std::optional<T> wait_for(std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    for (;;) {
      while (!seen_.empty()) {
        protocol::Command c = std::move(seen_.front());
        seen_.pop_front();
        if (auto* t = std::get_if<T>(&c)) return std::move(*t);
      }
      if (Clock::now() >= deadline) return std::nullopt;
      if (std::optional<Parts> p = farm::recv_parts_within(socket_, 200ms))
        seen_.push_back(protocol::decode_command(*p));
    }
  }

 private:
  zmq::socket_t socket_;
  std::deque<protocol::Command> seen_;
};

Parts with_version(Parts parts, int v) {
  json h = json::parse(parts[0]);
  h["v"] = v;
  parts[0] = h.dump();
  return parts;
}

protocol::FrameReport frame_of(int64_t attempt, int64_t task, int level, int frame, int vertices) {
  protocol::FrameReport f;
  f.attempt = attempt;
  f.task = task;
  f.level = level;
  f.frame = frame;
  f.positions.assign(3 * static_cast<std::size_t>(vertices), 0.5);
  return f;
}

std::string not_running(const std::string& what, int64_t attempt, int64_t task) {
  return what + " for attempt " + std::to_string(attempt) + " of task " + std::to_string(task) +
         ", which is not this worker's running attempt";
}

// Named hostile cases: what was sent and the reason given; each reason must contain a given part.
struct Cases {
  std::vector<std::pair<std::string, std::string>> list;
  void expect(const std::string& name, const std::string& reason, const std::string& part) {
    EXPECT_NE(reason.find(part), std::string::npos) << name << ": expected '" << part << "' in '" << reason << "'";
    list.emplace_back(name, reason);
  }
};

// Before hello, then registered and idle: nothing a peer says about attempts it was never given counts.
void unregistered_and_idle_cases(HandPeer& p, const protocol::Hello& hello, protocol::HierarchyDone done, int v0,
                                 Cases& c) {
  c.expect("hello of protocol version 1", p.refusal(with_version(protocol::encode(hello), 1)),
           "malformed report: hello: protocol version 1, this program speaks " +
               std::to_string(protocol::kProtocolVersion));
  c.expect("a command on the workers socket", p.refusal(protocol::encode(protocol::Welcome{1, 1000})),
           "welcome: not a worker report (it is a scheduler command)");
  c.expect("a request on the workers socket", p.refusal(protocol::encode(protocol::StatusRequest{0})),
           "status: not a worker report (it is a client request)");
  c.expect("a frame before hello", p.refusal(protocol::encode(frame_of(1, 1, 0, 1, v0))),
           protocol::kUnknownWorkerReason);
  c.expect("a task_done before hello", p.refusal(protocol::encode(protocol::TaskDone{1, 1, 0, false, 1.0})),
           protocol::kUnknownWorkerReason);
  farm::send_parts(p.socket(), protocol::encode(hello));
  ASSERT_TRUE(p.wait_for<protocol::Welcome>(10s)) << "no welcome";
  c.expect("a frame for an attempt never given", p.refusal(protocol::encode(frame_of(999, 999, 0, 1, v0))),
           not_running("frame", 999, 999));
  c.expect("a task_done for an attempt never given",
           p.refusal(protocol::encode(protocol::TaskDone{999, 999, 0, false, 1.0})),
           not_running("task_done", 999, 999));
  c.expect("a task_failed for an attempt never given",
           p.refusal(protocol::encode(protocol::TaskFailed{999, 999, "no"})), not_running("task_failed", 999, 999));
  done.attempt = done.task = 999;
  c.expect("a hierarchy_done for an attempt never given", p.refusal(protocol::encode(done)),
           not_running("hierarchy_done", 999, 999));
}

// Another registered peer claims every task of the job under every attempt id 1..64 (a frame of
// the task's level and size, and a task_done): the number refused as not its attempt.
int claims_refused(HandPeer& q, const json& tasks, const std::vector<int>& vertices, int* claims) {
  int refused = 0;
  for (const json& t : tasks) {
    const int64_t task = t.at("id");
    const int level = t.at("level");
    for (int64_t attempt = 1; attempt <= 64; ++attempt) {
      *claims += 2;
      refused += q.refusal(protocol::encode(frame_of(attempt, task, level, 1, vertices[level]))) ==
                 not_running("frame", attempt, task);
      refused += q.refusal(protocol::encode(protocol::TaskDone{attempt, task, 0, false, 1.0})) ==
                 not_running("task_done", attempt, task);
    }
  }
  return refused;
}

// The peer's own running attempt of a level-0 task: each bad frame refused for what is wrong with it;
// then a task_done before any frame, which fails the task.
void running_task_cases(HandPeer& p, const protocol::AssignTask& task, const std::vector<int>& vertices, Cases& c) {
  const int64_t a = task.attempt, t = task.task;
  const int v0 = vertices[0];
  c.expect("a frame of the wrong size", p.refusal(protocol::encode(frame_of(a, t, 0, 1, 1))),
           "frame with 1 vertices, level 0 has " + std::to_string(v0));
  c.expect("a frame of another level", p.refusal(protocol::encode(frame_of(a, t, 1, 1, vertices[1]))),
           "frame of level 1 for a task of level 0");
  c.expect("a frame after the task's last", p.refusal(protocol::encode(frame_of(a, t, 0, task.last + 1, v0))),
           "frame " + std::to_string(task.last + 1) + " outside the task's frames");
  protocol::FrameReport f = frame_of(a, t, 0, 1, v0);
  f.center_of_mass.assign(30, 0.0);
  c.expect("centres of mass for 10 objects", p.refusal(protocol::encode(f)), "center_of_mass with 10 objects");
  f.center_of_mass.clear();
  f.stats = {{"a/b", 1.0}};
  c.expect("a statistic named a/b", p.refusal(protocol::encode(f)), "invalid statistic name 'a/b'");
  f.stats = {{"gap", 1.0}, {"gap", 2.0}};
  c.expect("a statistic given twice", p.refusal(protocol::encode(f)), "statistic given twice");
  c.expect("a task_done before any frame", p.refusal(protocol::encode(protocol::TaskDone{a, t, 0, false, 1.0})),
           "reported done with 0 of " + std::to_string(task.last - task.first + 1) + " frames stored");
  c.expect("a frame for the attempt that failed", p.refusal(protocol::encode(frame_of(a, t, 0, 1, v0))),
           not_running("frame", a, t));
}

// The clients socket: each bad request gets an ErrorReply naming why.
void client_cases(zmq::context_t& ctx, const test::Farm& farm, int64_t failed_job, Cases& c) {
  zmq::socket_t client(ctx, zmq::socket_type::dealer);
  farm::configure_socket(client);
  client.connect(farm.clients());
  auto error_of = [&](const Parts& request) -> std::string {
    farm::send_parts(client, request);
    const std::optional<Parts> reply = farm::recv_parts_within(client, 5s);
    if (!reply) return "(no answer)";
    const protocol::Reply r = protocol::decode_reply(*reply);
    const auto* e = std::get_if<protocol::ErrorReply>(&r);
    return e ? e->message : "(a " + protocol::message_type(*reply) + " reply)";
  };
  c.expect("a worker report on the clients socket",
           error_of(protocol::encode(protocol::Hello{"x", "fuzz", 1, "fuzzhost", "", blas_kernel_in_use()})),
           "malformed request: hello: not a client request (it is a worker report)");
  c.expect("a status request of the next protocol version",
           error_of(with_version(protocol::encode(protocol::StatusRequest{0}), protocol::kProtocolVersion + 1)),
           "malformed request: status: protocol version " + std::to_string(protocol::kProtocolVersion + 1));
  c.expect("a status for a job never submitted", error_of(protocol::encode(protocol::StatusRequest{999})),
           "no job 999");
  c.expect("a cancel for a job never submitted", error_of(protocol::encode(protocol::CancelJob{999})), "no job 999");
  c.expect("a refine of a job that has its levels", error_of(protocol::encode(protocol::RefineJob{failed_job, 1})),
           "already has its refinement levels");
  // A stitch wider than the farm allows (the client refuses it first; the scheduler too).
  protocol::SubmitJob wide;
  wide.scene = farm::read_scene_source(test::scene_path("cube-trampoline.json"));
  wide.subsets = 2;
  wide.stitch = farm::kMaxStitchFrames + 1;
  c.expect("a submit with a stitch over the limit", error_of(protocol::encode(wide)),
           "submit: stitch: must be <= " + std::to_string(farm::kMaxStitchFrames) + ", got " +
               std::to_string(farm::kMaxStitchFrames + 1));
}

// Below libzmq: a frame declaring more than ZMQ_MAXMSGSIZE (kMaxMessageBytes) drops the connection
// before any of it is read; so does a greeting naming a security mechanism that does not exist.
void zmtp_cases(const std::string& endpoint, Cases& c) {
  {
    test::RawZmtpPeer raw(endpoint, 5000);
    raw.send_frame("not json", false);
    const std::optional<Parts> answer = raw.recv_message(5000);
    ASSERT_TRUE(answer) << "no answer over the hand-made ZMTP connection";
    const protocol::Command cmd = protocol::decode_command(*answer);
    ASSERT_TRUE(std::holds_alternative<protocol::Refused>(cmd));
    c.expect("'not json' over hand-made ZMTP", std::get<protocol::Refused>(cmd).reason,
             "malformed report: message: part 0 is not JSON");
    raw.send_frame_header(protocol::kMaxMessageBytes + 1, false);
    EXPECT_TRUE(raw.closed_by_peer(5000)) << "a frame over the size limit did not drop the connection";
  }
  test::RawZmtpPeer evil(endpoint, 5000, false);
  std::string greeting(64, '\0');
  greeting[0] = '\xff';
  greeting[9] = '\x7f';
  greeting[10] = 3;
  greeting.replace(12, 4, "EVIL");
  evil.send_raw(greeting);
  EXPECT_TRUE(evil.closed_by_peer(5000)) << "a greeting with an unknown mechanism did not drop the connection";
}

// Random bytes without a greeting: libzmq reads a first byte other than 0xff as a ZMTP/1.0 peer and
// the rest as frames, so some of it reaches the scheduler as messages (refused); it must go on serving.
void send_tcp_garbage(const std::string& endpoint, uint64_t seed) {
  test::RawZmtpPeer garbage(endpoint, 5000, false);
  std::string bytes(65536, '\0');
  std::mt19937_64 rng(seed);
  for (char& b : bytes) b = static_cast<char>(rng() & 0xff);
  bytes[0] = 'G';
  try {
    garbage.send_raw(bytes);
  } catch (const std::runtime_error&) {
    // the scheduler may reset the connection before all of it is written
  }
  garbage.closed_by_peer(1000);
}

// A genuine hierarchy_done for `scene` (attempt and task 0, to be filled in): the hierarchy `pd
// hierarchy` builds into the farm's folder, with its hash, levels and vertex counts.
protocol::HierarchyDone genuine_hierarchy(const test::Farm& farm, const std::string& scene) {
  const std::string hierarchy = farm.dir() + "/hierarchy.h5";
  const test::RunResult built =
      test::run({PD_BINARY, "hierarchy", scene, "--out", hierarchy, "--json"}, test::kCommand);
  EXPECT_EQ(built.exit_code, 0) << built.describe();
  const json h = test::parse_json(built);
  std::vector<int> vertices;
  for (const json& l : h.at("levels")) vertices.push_back(l.at("vertices"));
  return protocol::HierarchyDone{0, 0, h.at("hash"), static_cast<int>(vertices.size()), vertices,
                                 test::read_file_text(hierarchy)};
}

// The out-of-order cases, each refused naming its reason, on a farm with no worker of its own: two
// hand-driven peers, one given the job's real tasks (it returns a real hierarchy, built with `pd
// hierarchy`), one claiming them. Then the clients socket, and ZMTP frames libzmq would not send.
TEST_F(FarmTest, OutOfOrderAndForgedReportsAreRefusedNamingTheReasonAndTheSchedulerKeepsServing) {
  test::FarmOptions options;
  options.workers = 0;
  options.heartbeat_ms = 5000;  // the hand-driven peers are silent between cases: 15 s before they are lost
  test::Farm& farm = start_farm(options, "fuzz_order");
  const std::string scene = test::scene_path("cube-trampoline.json");
  protocol::HierarchyDone done = genuine_hierarchy(farm, scene);
  const std::vector<int> vertices = done.vertices;
  ASSERT_EQ(vertices.size(), 3u);

  zmq::context_t ctx(1);
  Cases cases;
  HandPeer p(ctx, farm.workers_endpoint(), "order-p");
  unregistered_and_idle_cases(p, protocol::Hello{"order-p", "fuzz", 1, "fuzzhost", "", blas_kernel_in_use()}, done, vertices[0], cases);
  if (HasFatalFailure()) return;

  const int64_t job = test::submit(farm, {scene, "--frames", std::to_string(kFrames), "--subsets", "1"});
  const std::optional<protocol::AssignTask> first = p.wait_for<protocol::AssignTask>(10s);
  ASSERT_TRUE(first && first->kind == protocol::TaskKind::hierarchy) << "the hierarchy task was not given to order-p";
  cases.expect("a frame for a running hierarchy task",
               p.refusal(protocol::encode(frame_of(first->attempt, first->task, 0, 1, vertices[0]))),
               "a frame for a task that solves no frames");
  done.attempt = first->attempt;
  done.task = first->task + 100;
  cases.expect("a hierarchy_done naming another task", p.refusal(protocol::encode(done)),
               not_running("hierarchy_done", first->attempt, first->task + 100));
  done.task = first->task;
  farm::send_parts(p.socket(), protocol::encode(done));
  const std::optional<protocol::AssignTask> level = p.wait_for<protocol::AssignTask>(10s);
  ASSERT_TRUE(level && level->kind == protocol::TaskKind::level && level->level == 0)
      << "the preview task was not given to order-p after its hierarchy";
  EXPECT_FALSE(level->hierarchy_blob.has_value()) << "the hierarchy was sent back to the peer that built it";

  HandPeer q(ctx, farm.workers_endpoint(), "order-q");
  farm::send_parts(q.socket(), protocol::encode(protocol::Hello{"order-q", "fuzz", 1, "fuzzhost", "", blas_kernel_in_use()}));
  ASSERT_TRUE(q.wait_for<protocol::Welcome>(10s)) << "no welcome for order-q";
  int claims = 0;
  EXPECT_EQ(claims_refused(q, test::job_status(farm, job).at("tasks"), vertices, &claims), 4 * 64 * 2);
  EXPECT_EQ(claims, 4 * 64 * 2);  // the hierarchy, preview and two refinement tasks, attempts 1..64

  running_task_cases(p, *level, vertices, cases);  // order-p's attempt survived the claims
  const json status = test::job_status(farm, job);
  // The task_done before any frame failed order-p's attempt (a soft failure: the task is ready again
  // for another worker), so the job still runs.
  EXPECT_EQ(status.at("state"), "running") << status.dump();
  EXPECT_EQ(status.at("levels").at(0).at("frames_done"), 0) << "a refused frame was stored: " << status.dump();
  zmtp_cases(farm.workers_endpoint(), cases);
  Cases client_side;
  client_cases(ctx, farm, job, client_side);

  // Every refusal on the workers socket is in the log with its reason, and nothing else was refused.
  const std::vector<json> refused = test::log_events(farm.scheduler_log(), "report_refused");
  int logged = 0;
  for (const auto& [name, reason] : cases.list) {
    std::printf("workers socket: %-44s -> %s\n", name.c_str(), reason.substr(0, 150).c_str());
    logged +=
        std::any_of(refused.begin(), refused.end(), [&](const json& e) { return e.value("message", "") == reason; });
  }
  for (const auto& [name, reason] : client_side.list)
    std::printf("clients socket: %-44s -> %s\n", name.c_str(), reason.c_str());
  EXPECT_EQ(cases.list.size(), 20u);
  EXPECT_EQ(client_side.list.size(), 6u);
  EXPECT_EQ(logged, static_cast<int>(cases.list.size())) << "refusals missing from the log";
  EXPECT_EQ(refused.size(), cases.list.size() + static_cast<std::size_t>(claims)) << "refusals not accounted for";

  send_tcp_garbage(farm.workers_endpoint(), test::fuzz_seed());
  const test::RunResult workers = farm.pd({"workers", "--json"});
  ASSERT_EQ(workers.exit_code, 0) << workers.describe();
  EXPECT_EQ(test::parse_json(workers).at("workers").size(), 2u) << workers.out;
}

// A worker sends, as its hierarchy, a file that crashes HDF5's reader (SIGSEGV in H5F__accum_read,
// fuzz/known_hdf5_bugs) under the genuine hash: the scheduler reads worker files in a child process
// first, so the child dies, the attempt fails naming the signal, and the scheduler goes on serving.
TEST_F(FarmTest, AHierarchyFileThatCrashesHdf5FailsItsAttemptAndNotTheScheduler) {
  test::FarmOptions options;
  options.workers = 0;
  options.heartbeat_ms = 5000;
  test::Farm& farm = start_farm(options, "fuzz_hdf5_crash");
  const std::string scene = test::scene_path("cube-trampoline.json");
  protocol::HierarchyDone crafted = genuine_hierarchy(farm, scene);
  ASSERT_FALSE(crafted.vertices.empty());
  zmq::context_t ctx(1);
  HandPeer p(ctx, farm.workers_endpoint(), "crash-p");
  farm::send_parts(p.socket(), protocol::encode(protocol::Hello{"crash-p", "fuzz", 1, "fuzzhost", "", blas_kernel_in_use()}));
  ASSERT_TRUE(p.wait_for<protocol::Welcome>(10s)) << "no welcome";
  const int64_t job = test::submit(farm, {scene, "--frames", "4"});
  const std::optional<protocol::AssignTask> task = p.wait_for<protocol::AssignTask>(10s);
  ASSERT_TRUE(task && task->kind == protocol::TaskKind::hierarchy);
  crafted.attempt = task->attempt;
  crafted.task = task->task;
  crafted.blob = test::read_file_text(test::source_dir() + "/fuzz/known_hdf5_bugs/frame_file/h5f_accum_read_segv.h5");
  farm::send_parts(p.socket(), protocol::encode(crafted));
  json status;
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  do {
    std::this_thread::sleep_for(100ms);
    status = test::job_status(farm, job);  // the scheduler answers: it is alive
  } while (status.at("state") != "failed" && std::chrono::steady_clock::now() < deadline);
  ASSERT_EQ(status.at("state"), "failed") << status.dump();
  EXPECT_NE(status.at("reason").get<std::string>().find("the hierarchy file could not be read"), std::string::npos)
      << status.dump();
#if !defined(__SANITIZE_ADDRESS__)  // AddressSanitizer catches the SIGSEGV itself and exits 1
  EXPECT_NE(status.at("reason").get<std::string>().find("killed by signal 11"), std::string::npos) << status.dump();
#endif
  EXPECT_TRUE(farm.scheduler().running());
}

}  // namespace
}  // namespace pd
