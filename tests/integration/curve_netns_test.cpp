// CURVE beyond loopback (docs/farm.md, "Authentication"), on a real non-loopback address: a network
// namespace joined to this one by a veth pair that the test creates and removes itself, pd-scheduler
// bound to the root side's 10.x address, pd-workers started inside the namespace with `ip netns exec`,
// the pd client in the root namespace. Checked: without keys the scheduler refuses that address; with
// keys a worker with the right keys registers and runs a job, while a worker with an unlisted key
// pair, one with the wrong server key and one with no keys never register and get no task, and a
// client without keys (or with an unlisted pair) gets no answer.
//
// Needs root (or CAP_NET_ADMIN + CAP_SYS_ADMIN) and iproute2's `ip`; without them the test is
// skipped with the reason printed.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "farm/curve.h"
#include "support/farm.h"
#include "support/process.h"
#include "support/test_paths.h"

namespace pd {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using test::Args;
using test::RunResult;

constexpr auto kIpTimeout = 10s;

// iproute2's ip (test::run does not search PATH); "" when there is none.
std::string ip_binary() {
  for (const char* p : {"/usr/sbin/ip", "/sbin/ip", "/usr/bin/ip", "/bin/ip"})
    if (access(p, X_OK) == 0) return p;
  return "";
}

// A network namespace and a veth pair into it, removed again by the destructor (also after a
// failed assertion or a half-done create()). Names carry the test process's pid, so parallel runs
// on one machine do not collide; so does the /30 subnet, 10.213.<pid % 256>.<4 * (pid / 256 % 64)>.
class NetnsGuard {
 public:
  NetnsGuard() : ip_(ip_binary()), pid_(std::to_string(getpid())) {
    ns_ = "pdtest" + pid_;
    root_if_ = "pdr" + pid_;  // interface names: at most 15 characters
    ns_if_ = "pdn" + pid_;
    const int p = static_cast<int>(getpid());
    const std::string net = "10.213." + std::to_string(p % 256) + ".";
    const int base = 4 * ((p / 256) % 64);
    root_address_ = net + std::to_string(base + 1);
    ns_address_ = net + std::to_string(base + 2);
  }
  ~NetnsGuard() { remove(); }
  NetnsGuard(const NetnsGuard&) = delete;
  NetnsGuard& operator=(const NetnsGuard&) = delete;

  // Creates the namespace and the link; "" when done, else why not (for GTEST_SKIP or a failure).
  std::string create() {
    if (ip_.empty()) return "no ip command (iproute2) in /usr/sbin, /sbin, /usr/bin or /bin";
    if (const std::string e = ip({"netns", "add", ns_}); !e.empty())
      return "cannot create a network namespace (needs root or CAP_SYS_ADMIN): " + e;
    created_ = true;
    const std::vector<Args> steps = {
        {"link", "add", root_if_, "type", "veth", "peer", "name", ns_if_},
        {"link", "set", ns_if_, "netns", ns_},
        {"addr", "add", root_address_ + "/30", "dev", root_if_},
        {"link", "set", root_if_, "up"},
        {"netns", "exec", ns_, ip_, "addr", "add", ns_address_ + "/30", "dev", ns_if_},
        {"netns", "exec", ns_, ip_, "link", "set", ns_if_, "up"},
        {"netns", "exec", ns_, ip_, "link", "set", "lo", "up"},
    };
    for (const Args& step : steps)
      if (const std::string e = ip(step); !e.empty()) return "cannot set up the veth pair: " + e;
    return "";
  }

  // argv run inside the namespace: ip netns exec NS argv...
  Args inside(const Args& argv) const {
    Args a = {ip_, "netns", "exec", ns_};
    a.insert(a.end(), argv.begin(), argv.end());
    return a;
  }
  const std::string& root_address() const { return root_address_; }
  const std::string& ns_address() const { return ns_address_; }

 private:
  // Runs ip ARGS; "" on success, else its description.
  std::string ip(Args args) const {
    args.insert(args.begin(), ip_);
    const RunResult r = test::run(args, kIpTimeout);
    return r.exit_code == 0 ? "" : r.describe();
  }
  void remove() {
    if (!created_) return;
    // Deleting the namespace deletes its end of the pair, which takes the other end with it; the
    // explicit link delete covers a pair whose end never made it into the namespace.
    ip({"netns", "del", ns_});
    ip({"link", "del", root_if_});
    created_ = false;
  }

  std::string ip_, pid_, ns_, root_if_, ns_if_, root_address_, ns_address_;
  bool created_ = false;
};

class CurveNetns : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const std::string why = netns_.create(); !why.empty()) GTEST_SKIP() << "skipped: " << why;
    dir_ = test::scratch_dir("curve_netns");
  }
  void TearDown() override {
    for (test::Process& w : workers_) w.terminate(5s);
    if (scheduler_.started()) {
      EXPECT_EQ(scheduler_.terminate(10s), 0) << "pd-scheduler did not exit 0 on SIGTERM";
    }
    if (dir_.empty()) return;
    if (HasFailure()) {
      for (const auto& e : std::filesystem::directory_iterator(dir_)) {
        if (e.path().extension() == ".log")
          std::printf("---- %s\n%s", e.path().c_str(), test::file_tail(e.path().string(), 30).c_str());
      }
      std::printf("kept %s\n", dir_.c_str());
    } else {
      std::filesystem::remove_all(dir_);
    }
  }

  std::string endpoint(const std::string& address, const std::string& port = "0") const {
    return "tcp://" + address + ":" + port;
  }
  Args scheduler_argv(const std::string& farm_dir) const {
    return {PD_SCHEDULER_BINARY, "--dir", farm_dir, "--workers-endpoint", endpoint(netns_.root_address()),
            "--clients-endpoint", endpoint(netns_.root_address()), "--heartbeat-ms", "1000"};
  }
  // pd-scheduler with `extra`, once it printed its listening line; sets workers_at_ and clients_at_.
  void start_scheduler(const Args& extra) {
    Args argv = scheduler_argv(dir_ + "/farm");
    argv.insert(argv.end(), extra.begin(), extra.end());
    scheduler_.start(argv, {}, dir_ + "/scheduler.out", dir_ + "/scheduler.log");
    const auto line = test::read_first_line(dir_ + "/scheduler.out", 20s, &scheduler_);
    if (!line)
      throw std::runtime_error("pd-scheduler printed no first line:\n" + test::file_tail(dir_ + "/scheduler.log"));
    const json listening = json::parse(*line);
    if (listening.at("event") != "listening" || listening.at("curve") != true)
      throw std::runtime_error("not a CURVE listening line: " + *line);
    workers_at_ = listening.at("workers").get<std::string>();
    clients_at_ = listening.at("clients").get<std::string>();
  }
  // pd-worker NAME inside the namespace, with `keys` (--server-key F --key F, or nothing).
  void start_worker(const std::string& name, const Args& keys) {
    Args argv = {PD_WORKER_BINARY, "--connect", workers_at_, "--name", name, "--scratch", dir_ + "/scratch-" + name};
    argv.insert(argv.end(), keys.begin(), keys.end());
    workers_.emplace_back();
    workers_.back().start(netns_.inside(argv), {}, log_of(name), log_of(name));
  }
  std::string log_of(const std::string& worker) const { return dir_ + "/worker-" + worker + ".log"; }
  // pd ARGS --farm <clients> KEYS.
  RunResult pd(Args args, const Args& keys, std::chrono::milliseconds timeout = test::kCommand) const {
    args.insert(args.begin(), PD_BINARY);
    args.insert(args.end(), {"--farm", clients_at_});
    args.insert(args.end(), keys.begin(), keys.end());
    return test::run(args, timeout);
  }
  // pd keys DIR/NAME, or pd-scheduler --generate-keys DIR/NAME.
  void make_keys(const std::string& name, bool scheduler = false) {
    const RunResult r = test::run(scheduler ? Args{PD_SCHEDULER_BINARY, "--generate-keys", dir_ + "/" + name}
                                            : Args{PD_BINARY, "keys", dir_ + "/" + name},
                                  test::kCommand);
    if (r.exit_code != 0) throw std::runtime_error("key generation failed: " + r.describe());
  }
  Args keys_of(const std::string& server, const std::string& own) const {
    return {"--server-key", dir_ + "/" + server + ".pub", "--key", dir_ + "/" + own + ".key"};
  }

  NetnsGuard netns_;  // first: removed after every process below has been stopped
  std::string dir_;
  test::Process scheduler_;
  std::vector<test::Process> workers_;
  std::string workers_at_, clients_at_;
};

TEST_F(CurveNetns, TheSchedulerRefusesTheNamespaceAddressWithoutKeys) {
  make_keys("server", true);
  const std::string farm = dir_ + "/refused-farm";
  RunResult r = test::run(scheduler_argv(farm), test::kCommand);
  EXPECT_EQ(r.exit_code, 2) << r.describe();
  EXPECT_NE(r.err.find(endpoint(netns_.root_address()) +
                       " is not a loopback address; binding beyond loopback needs --key and --authorized-keys"),
            std::string::npos)
      << r.describe();
  Args half = scheduler_argv(farm);
  half.insert(half.end(), {"--key", dir_ + "/server.key"});
  r = test::run(half, test::kCommand);
  EXPECT_EQ(r.exit_code, 2) << r.describe();
  EXPECT_NE(r.err.find("--key " + dir_ + "/server.key: needs --authorized-keys FILE too"), std::string::npos)
      << r.describe();
  EXPECT_FALSE(std::filesystem::exists(farm)) << "a refused start created its farm folder";
}

TEST_F(CurveNetns, OnlyTheWorkerWithTheRightKeysRegistersAndTakesTasksOverTheNamespaceAddress) {
  make_keys("server", true);
  make_keys("other-server", true);
  for (const char* k : {"good", "stranger", "client"}) make_keys(k);
  {
    std::ofstream authorized(dir_ + "/authorized");
    authorized << "# the farm's workers and clients\n"
               << test::read_file_text(dir_ + "/good.pub") << test::read_file_text(dir_ + "/client.pub");
  }
  start_scheduler({"--key", dir_ + "/server.key", "--authorized-keys", dir_ + "/authorized"});
  ASSERT_EQ(workers_at_.rfind("tcp://" + netns_.root_address() + ":", 0), 0u) << workers_at_;
  start_worker("good", keys_of("server", "good"));
  start_worker("stranger", keys_of("server", "stranger"));          // a pair the scheduler does not list
  start_worker("wrong-server", keys_of("other-server", "good"));    // the right pair, the wrong server key
  start_worker("no-keys", {});
  const Args client = keys_of("server", "client");

  // The good worker registers; wait until it is idle (at most 20 s).
  json listed;
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  for (;;) {
    const RunResult r = pd({"workers", "--json"}, client);
    ASSERT_EQ(r.exit_code, 0) << r.describe();
    listed = test::parse_json(r).at("workers");
    if (listed.size() == 1 && listed[0].at("state") == "idle") break;
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the good worker did not register: " << listed.dump();
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(listed[0].at("name"), "good");

  // A job runs on it, submitted and watched from the root namespace.
  RunResult r = pd({"submit", test::scene_path("cube-trampoline.json"), "--frames", "5", "--preview-only", "--json"},
                   client);
  ASSERT_EQ(r.exit_code, 0) << r.describe();
  const std::string job = std::to_string(test::parse_json(r).at("job").get<int64_t>());
  r = pd({"status", job, "--wait", "--interval", "0.2"}, client, test::kShortJob);
  ASSERT_EQ(r.exit_code, 0) << r.describe();
  r = pd({"status", job, "--json"}, client);
  ASSERT_EQ(r.exit_code, 0) << r.describe();
  const json status = test::parse_json(r).at("jobs").at(0);
  EXPECT_EQ(status.at("state"), "done");
  EXPECT_EQ(status.at("levels").at(0).at("frames_total"), 6);  // frame 0 and the 5 simulated ones
  EXPECT_EQ(status.at("levels").at(0).at("frames_done"), 6);
  int tasks = 0;
  for (const json& t : status.at("tasks")) {
    EXPECT_EQ(t.at("worker"), "good") << t.dump();
    ++tasks;
  }
  EXPECT_GE(tasks, 2) << "a hierarchy task and at least one preview task";

  // Clients without the right keys get no answer (5 s each).
  for (const Args& keys : {Args{}, keys_of("server", "stranger")}) {
    r = pd({"workers", "--json"}, keys);
    EXPECT_EQ(r.exit_code, 2) << r.describe();
    EXPECT_NE(r.err.find("no answer within 5 s"), std::string::npos) << r.describe();
  }

  // By now the other workers have tried for the whole job and more: still running, never listed,
  // never connected, and each has given up on a silent scheduler at least once.
  r = pd({"workers", "--json"}, client);
  ASSERT_EQ(r.exit_code, 0) << r.describe();
  listed = test::parse_json(r).at("workers");
  ASSERT_EQ(listed.size(), 1u) << listed.dump();
  EXPECT_EQ(listed[0].at("name"), "good");
  EXPECT_GE(listed[0].at("tasks_done").get<int>(), tasks);
  int refused_workers = 0;
  for (int k = 1; k < 4; ++k) {
    const std::string name = k == 1 ? "stranger" : k == 2 ? "wrong-server" : "no-keys";
    EXPECT_TRUE(workers_[k].running()) << name << " exited";
    const std::string log = test::read_file_text(log_of(name));
    EXPECT_EQ(log.find("connected"), std::string::npos) << name << ":\n" << log;
    EXPECT_EQ(log.find(": task: "), std::string::npos) << name << ":\n" << log;
    EXPECT_NE(log.find("scheduler lost"), std::string::npos) << name << " never gave up waiting:\n" << log;
    ++refused_workers;
  }
  EXPECT_EQ(refused_workers, 3);
  EXPECT_NE(test::read_file_text(log_of("good")).find("connected"), std::string::npos);
  EXPECT_NE(test::read_file_text(log_of("no-keys")).find("admits CURVE workers only"), std::string::npos);
  // The ZAP handler's refusal of the stranger's key is in the scheduler's log.
  const std::string stranger_key = farm::read_public_key(dir_ + "/stranger.pub");
  const auto refusals = test::log_events(dir_ + "/scheduler.log", "auth_refused");
  const bool stranger_logged = std::any_of(refusals.begin(), refusals.end(), [&](const json& e) {
    return e.at("message").get<std::string>().find(stranger_key) != std::string::npos;
  });
  EXPECT_TRUE(stranger_logged) << test::read_file_text(dir_ + "/scheduler.log");
}

}  // namespace
}  // namespace pd
