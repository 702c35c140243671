#include "local_farm.h"

#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "farm_client.h"
#include "util/input_error.h"

extern char** environ;

namespace pd::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

bool is_executable(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec) && access(p.c_str(), X_OK) == 0;
}

std::string find_program(const char* env_name, const std::string& name, const std::string& subdir) {
  if (const char* env = std::getenv(env_name); env != nullptr && *env != '\0') {
    if (is_executable(env)) return env;
    throw InputError(std::string(env_name) + "=" + env + ": not an executable file");
  }
  std::vector<fs::path> candidates;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    candidates.push_back((self.parent_path() / ".." / subdir / name).lexically_normal());
    candidates.push_back(self.parent_path() / name);
  }
  std::string looked;
  for (const fs::path& c : candidates) {
    if (is_executable(c)) return c.string();
    looked += (looked.empty() ? "" : ", ") + c.string();
  }
  if (looked.empty()) looked = "(nowhere: /proc/self/exe is unreadable)";
  throw InputError("cannot find " + name + ": looked at " + looked + "; build it, or set " + env_name);
}

std::string describe_status(int status) {
  if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    return "was killed by signal " + std::to_string(sig) + " (" + strsignal(sig) + ")";
  }
  return "stopped (wait status " + std::to_string(status) + ")";
}

// waitpid that retries on EINTR; returns the pid, 0 (WNOHANG, still running) or -1.
pid_t wait_for(pid_t pid, int* status, int options) {
  for (;;) {
    const pid_t r = waitpid(pid, status, options);
    if (r >= 0 || errno != EINTR) return r;
  }
}

void append_to_file(const std::string& path, const char* data, std::size_t n) {
  std::ofstream out(path, std::ios::binary | std::ios::app);
  out.write(data, static_cast<std::streamsize>(n));
}

}  // namespace

FarmBinaries find_farm_binaries() {
  return {find_program("PD_SCHEDULER_BIN", "pd-scheduler", "scheduler"),
          find_program("PD_WORKER_BIN", "pd-worker", "worker")};
}

std::string tail_of_file(const std::string& path, int lines) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff from = size > 65536 ? size - 65536 : 0;  // the end is what matters
  in.seekg(from);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  while (!text.empty() && text.back() == '\n') text.pop_back();
  std::size_t pos = text.size();
  for (int k = 0; k < lines && pos != std::string::npos && pos > 0; ++k) pos = text.rfind('\n', pos - 1);
  return pos == std::string::npos || pos == 0 ? text : text.substr(pos + 1);
}

LocalFarm::LocalFarm(FarmBinaries binaries) : binaries_(std::move(binaries)) {}

LocalFarm::~LocalFarm() {
  try {
    stop();
  } catch (...) {  // a destructor must not throw; stop() only fails on system errors
  }
}

pid_t LocalFarm::spawn(const std::vector<std::string>& argv, const std::string& log, int stdout_fd) {
  posix_spawn_file_actions_t files;
  posix_spawn_file_actions_init(&files);
  posix_spawn_file_actions_addopen(&files, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&files, 2, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&files, stdout_fd >= 0 ? stdout_fd : 2, 1);

  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none, defaults;
  sigemptyset(&none);
  sigemptyset(&defaults);
  for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) sigaddset(&defaults, sig);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  posix_spawnattr_setpgroup(&attr, group_);  // 0: a new group led by this child
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);

  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0].c_str(), &files, &attr, args.data(), environ);
  posix_spawn_file_actions_destroy(&files);
  posix_spawnattr_destroy(&attr);
  if (rc != 0) throw std::runtime_error("cannot start " + argv[0] + ": " + std::strerror(rc));
  if (group_ == 0) group_ = pid;
  return pid;
}

void LocalFarm::start(const std::string& dir, int n_workers, int worker_threads, std::chrono::milliseconds startup) {
  if (!children_.empty()) throw std::logic_error("LocalFarm::start called twice");
  dir_ = dir;
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw InputError(dir_ + ": cannot create the farm folder: " + ec.message());

  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  const std::string log = dir_ + "/scheduler.log";
  pid_t pid = -1;
  try {
    // --exit-with-parent: a pd run killed outright (SIGKILL, no destructor) takes its farm with it.
    pid = spawn({binaries_.scheduler, "--dir", dir_, "--workers-endpoint", "tcp://127.0.0.1:0", "--clients-endpoint",
                 "tcp://127.0.0.1:0", "--exit-with-parent", std::to_string(getpid())},
                log, fds[1]);
  } catch (...) {
    close(fds[0]);
    close(fds[1]);
    throw;
  }
  close(fds[1]);  // the scheduler holds the only write end: EOF on ours means it closed stdout or died
  scheduler_out_ = fds[0];
  children_.push_back({"pd-scheduler", log, pid, true, true});
  parse_listening_line(read_listening_line(startup));
  fcntl(scheduler_out_, F_SETFL, fcntl(scheduler_out_, F_GETFL) | O_NONBLOCK);

  for (int k = 1; k <= n_workers; ++k) {
    const std::string name = "w" + std::to_string(k);
    const std::string worker_log = dir_ + "/worker-" + std::to_string(k) + ".log";
    std::vector<std::string> argv = {binaries_.worker, "--connect", workers_, "--name", name,
                                     "--exit-with-parent", std::to_string(getpid())};
    if (worker_threads > 0) argv.insert(argv.end(), {"--threads", std::to_string(worker_threads)});
    const pid_t w = spawn(argv, worker_log, -1);
    children_.push_back({"pd-worker " + name, worker_log, w, true, false});
  }
}

std::string LocalFarm::read_listening_line(std::chrono::milliseconds startup) {
  const auto deadline = Clock::now() + startup;
  std::string buffer;
  for (;;) {
    if (stop_flag_ != nullptr && *stop_flag_ != 0) throw Interrupted();
    const std::size_t newline = buffer.find('\n');
    if (newline != std::string::npos) {
      // The line goes to the log too (the endpoints, for whoever reads it); anything after it is
      // ordinary output and is kept there as well.
      append_to_file(children_[0].log, buffer.data(), newline + 1);
      if (newline + 1 < buffer.size())
        append_to_file(children_[0].log, buffer.data() + newline + 1, buffer.size() - newline - 1);
      return buffer.substr(0, newline);
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) {
      fail_start("pd-scheduler did not report its endpoints within " + std::to_string(startup.count() / 1000) + " s");
    }
    pollfd p{scheduler_out_, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::min<long long>(left.count(), 100)));
    if (ready < 0 && errno != EINTR) fail_start(std::string("poll: ") + std::strerror(errno));
    if (ready <= 0) continue;
    char chunk[4096];
    const ssize_t n = read(scheduler_out_, chunk, sizeof chunk);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      int status = 0;
      const bool ended = wait_for(children_[0].pid, &status, 0) == children_[0].pid;
      if (ended) children_[0].running = false;
      fail_start("pd-scheduler " + (ended ? describe_status(status) : std::string("closed its output")) +
                 " before reporting its endpoints");
    }
    buffer.append(chunk, static_cast<std::size_t>(n));
  }
}

void LocalFarm::parse_listening_line(const std::string& line) {
  const std::string expected = "pd-scheduler's first output line is not {\"event\":\"listening\",\"workers\":...,"
                               "\"clients\":...}: ";
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(line);
  } catch (const nlohmann::json::exception&) {
    fail_start(expected + line);
  }
  const auto text = [&](const char* key) -> std::string {
    const auto it = j.is_object() ? j.find(key) : j.end();
    if (it == j.end() || !it->is_string() || it->get<std::string>().empty()) fail_start(expected + line);
    return it->get<std::string>();
  };
  if (text("event") != "listening") fail_start(expected + line);
  workers_ = text("workers");
  clients_ = text("clients");
}

void LocalFarm::fail_start(const std::string& problem) {
  stop();
  const std::string tail = tail_of_file(children_.empty() ? dir_ + "/scheduler.log" : children_[0].log);
  throw std::runtime_error(problem + "; " + dir_ + "/scheduler.log " +
                           (tail.empty() ? std::string("is empty") : "ends with:\n" + tail));
}

void LocalFarm::drain_scheduler_stdout() {
  if (scheduler_out_ < 0) return;
  char chunk[4096];
  for (;;) {
    const ssize_t n = read(scheduler_out_, chunk, sizeof chunk);
    if (n > 0) {
      append_to_file(children_[0].log, chunk, static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n == 0) {  // EOF: the scheduler is gone or closed stdout
      close(scheduler_out_);
      scheduler_out_ = -1;
    }
    return;  // EAGAIN: nothing more for now
  }
}

std::vector<ChildExit> LocalFarm::poll_exits() {
  drain_scheduler_stdout();
  std::vector<ChildExit> exits;
  for (Child& c : children_) {
    if (!c.running) continue;
    int status = 0;
    if (wait_for(c.pid, &status, WNOHANG) != c.pid) continue;
    c.running = false;
    exits.push_back({c.name, c.log, c.name + " (pid " + std::to_string(c.pid) + ") " + describe_status(status),
                     c.is_scheduler});
  }
  return exits;
}

int LocalFarm::running_workers() const {
  int n = 0;
  for (const Child& c : children_) n += (c.running && !c.is_scheduler) ? 1 : 0;
  return n;
}

void LocalFarm::stop(std::chrono::milliseconds grace) {
  bool any_running = false;
  for (Child& c : children_) {
    if (c.running) kill(c.pid, SIGTERM);
    any_running = any_running || c.running;
  }
  // Exits are detected without reaping (WNOWAIT) until the end: an unreaped child keeps the process
  // group's id reserved, so the group kill below cannot hit an unrelated group that reused the id.
  const auto deadline = Clock::now() + grace;
  while (any_running && Clock::now() < deadline) {
    bool all_exited = true;
    for (const Child& c : children_) {
      if (!c.running) continue;
      siginfo_t info = {};
      const int r = waitid(P_PID, static_cast<id_t>(c.pid), &info, WEXITED | WNOHANG | WNOWAIT);
      if (r == 0 && info.si_pid == 0) all_exited = false;  // still running
    }
    if (all_exited) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // Whatever the children started themselves (a wrapper script's program) is in their group too;
  // SIGKILL to the group ends it and every child that ignored SIGTERM.
  if (any_running && group_ > 0) kill(-group_, SIGKILL);
  for (Child& c : children_) {
    if (!c.running) continue;
    int status = 0;
    wait_for(c.pid, &status, 0);
    c.running = false;
  }
  if (scheduler_out_ >= 0) {
    fcntl(scheduler_out_, F_SETFL, fcntl(scheduler_out_, F_GETFL) | O_NONBLOCK);
    drain_scheduler_stdout();
    if (scheduler_out_ >= 0) close(scheduler_out_);
    scheduler_out_ = -1;
  }
}

}  // namespace pd::cli
