#include "support/process.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace pd::test {
namespace {

using Clock = std::chrono::steady_clock;

// Polling period of the bounded waits: short against the farm's 1 s heartbeat, long enough not to
// busy the two cores the tests share.
constexpr auto kPoll = std::chrono::milliseconds(10);

int code_of(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

// "NAME=value" strings: this process's environment with `env` replacing or adding names.
std::vector<std::string> merged_environment(const EnvAdditions& env) {
  std::map<std::string, std::string> vars;
  for (char** e = environ; e && *e; ++e) {
    const std::string entry = *e;
    const size_t eq = entry.find('=');
    if (eq == std::string::npos) continue;
    vars[entry.substr(0, eq)] = entry.substr(eq + 1);
  }
  for (const auto& [name, value] : env) vars[name] = value;
  std::vector<std::string> out;
  out.reserve(vars.size());
  for (const auto& [name, value] : vars) out.push_back(name + "=" + value);
  return out;
}

std::vector<char*> c_strings(std::vector<std::string>& strings) {
  std::vector<char*> out;
  for (std::string& s : strings) out.push_back(s.data());
  out.push_back(nullptr);
  return out;
}

// RAII for the spawn attribute and file-action objects.
struct SpawnSetup {
  posix_spawnattr_t attr;
  posix_spawn_file_actions_t actions;
  SpawnSetup() {
    posix_spawnattr_init(&attr);
    posix_spawn_file_actions_init(&actions);
  }
  ~SpawnSetup() {
    posix_spawn_file_actions_destroy(&actions);
    posix_spawnattr_destroy(&attr);
  }
};

std::string quoted_command(const std::vector<std::string>& argv) {
  std::string out;
  for (const std::string& a : argv) {
    if (!out.empty()) out += ' ';
    out += a.find_first_of(" \t\"'") == std::string::npos ? a : "'" + a + "'";
  }
  return out;
}

// A path for a temporary capture file, unique in this process and across processes.
std::string temp_capture_path(const char* what) {
  std::string tmpl = (std::filesystem::temp_directory_path() / (std::string("pd_run_") + what + "_XXXXXX")).string();
  const int fd = mkstemp(tmpl.data());
  if (fd < 0) throw std::runtime_error("mkstemp " + tmpl + ": " + std::strerror(errno));
  close(fd);
  return tmpl;
}

}  // namespace

Process::~Process() { terminate(); }

Process::Process(Process&& other) noexcept
    : pid_(other.pid_), name_(std::move(other.name_)), exit_code_(other.exit_code_) {
  other.pid_ = -1;
  other.exit_code_.reset();
}

Process& Process::operator=(Process&& other) noexcept {
  if (this != &other) {
    terminate();
    pid_ = other.pid_;
    name_ = std::move(other.name_);
    exit_code_ = other.exit_code_;
    other.pid_ = -1;
    other.exit_code_.reset();
  }
  return *this;
}

void Process::start(const std::vector<std::string>& argv, const EnvAdditions& env, const std::string& stdout_path,
                    const std::string& stderr_path) {
  if (argv.empty()) throw std::runtime_error("Process::start: empty argv");
  if (pid_ > 0) throw std::runtime_error("Process::start " + argv[0] + ": this object already holds pid " +
                                         std::to_string(pid_));
  SpawnSetup setup;
  // Own process group (pgid = its pid), default signal dispositions and an empty signal mask, so the
  // child behaves as if started from a shell whatever this test process did with signals.
  sigset_t all, none;
  sigfillset(&all);
  sigemptyset(&none);
  posix_spawnattr_setpgroup(&setup.attr, 0);
  posix_spawnattr_setsigdefault(&setup.attr, &all);
  posix_spawnattr_setsigmask(&setup.attr, &none);
  posix_spawnattr_setflags(&setup.attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK);
  const int out_flags = O_WRONLY | O_CREAT | O_TRUNC;
  posix_spawn_file_actions_addopen(&setup.actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&setup.actions, 1, stdout_path.empty() ? "/dev/null" : stdout_path.c_str(),
                                   out_flags, 0644);
  posix_spawn_file_actions_addopen(&setup.actions, 2, stderr_path.empty() ? "/dev/null" : stderr_path.c_str(),
                                   out_flags, 0644);
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 34))
  // Files this process holds open (HDF5 readers, other children's logs) are none of the child's business.
  posix_spawn_file_actions_addclosefrom_np(&setup.actions, 3);
#endif
  std::vector<std::string> args = argv;
  std::vector<std::string> vars = merged_environment(env);
  std::vector<char*> c_args = c_strings(args), c_vars = c_strings(vars);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0].c_str(), &setup.actions, &setup.attr, c_args.data(), c_vars.data());
  if (rc != 0) throw std::runtime_error("cannot start " + argv[0] + ": " + std::strerror(rc));
  pid_ = pid;
  name_ = argv[0];
  exit_code_.reset();
}

bool Process::reap(bool block) {
  if (pid_ <= 0 || exit_code_) return exit_code_.has_value();
  int status = 0;
  for (;;) {
    const pid_t r = waitpid(pid_, &status, block ? 0 : WNOHANG);
    if (r == pid_) {
      exit_code_ = code_of(status);
      return true;
    }
    if (r == 0) return false;
    if (errno == EINTR) continue;
    // ECHILD: someone else reaped it (should not happen); treat it as ended with an unknown code.
    exit_code_ = -1;
    return true;
  }
}

bool Process::running() { return pid_ > 0 && !reap(false); }

std::optional<int> Process::wait_for_exit(std::chrono::milliseconds timeout) {
  if (pid_ <= 0) return std::nullopt;
  const auto deadline = Clock::now() + timeout;
  while (!reap(false)) {
    if (Clock::now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(kPoll);
  }
  return exit_code_;
}

int Process::terminate(std::chrono::milliseconds grace) {
  if (pid_ <= 0) return -1;
  if (exit_code_) return *exit_code_;
  // The group is signalled only while its leader is not reaped: until then the pgid cannot belong to
  // anyone else's processes.
  if (!reap(false)) {
    kill(-pid_, SIGTERM);
    if (!wait_for_exit(grace)) {
      kill(-pid_, SIGKILL);
      reap(true);
    }
  }
  return *exit_code_;
}

std::string RunResult::describe() const {
  std::ostringstream s;
  s << "`" << command << "`: ";
  if (timed_out)
    s << "killed after the timeout (" << seconds << " s)";
  else
    s << "exit " << exit_code << " after " << seconds << " s";
  s << "\n--- stdout:\n" << out << "\n--- stderr:\n" << err;
  return s.str();
}

RunResult run(const std::vector<std::string>& argv, std::chrono::milliseconds timeout, const EnvAdditions& env) {
  RunResult result;
  result.command = quoted_command(argv);
  const std::string out_path = temp_capture_path("out"), err_path = temp_capture_path("err");
  const auto t0 = Clock::now();
  {
    Process p;
    p.start(argv, env, out_path, err_path);
    if (const auto code = p.wait_for_exit(timeout)) {
      result.exit_code = *code;
    } else {
      result.timed_out = true;
      p.terminate(std::chrono::seconds(1));
    }
  }
  result.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  result.out = read_file_text(out_path);
  result.err = read_file_text(err_path);
  std::remove(out_path.c_str());
  std::remove(err_path.c_str());
  return result;
}

std::optional<std::string> read_first_line(const std::string& path, std::chrono::milliseconds timeout,
                                           Process* writer) {
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    // Checked before reading, so that a line written just before the writer exited is still seen.
    const bool writer_ended = writer && !writer->running();
    const std::string text = read_file_text(path);
    const size_t nl = text.find('\n');
    if (nl != std::string::npos) return text.substr(0, nl);
    if (writer_ended || Clock::now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(kPoll);
  }
}

long proc_status_kib(pid_t pid, const std::string& field) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field + ":", 0) == 0) return std::strtol(line.c_str() + field.size() + 1, nullptr, 10);
  return -1;
}

std::string read_file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string file_tail(const std::string& path, int lines) {
  std::ifstream in(path);
  if (!in) return "";
  std::deque<std::string> last;
  std::string line;
  while (std::getline(in, line)) {
    last.push_back(line);
    if (static_cast<int>(last.size()) > lines) last.pop_front();
  }
  std::string out;
  for (const std::string& l : last) out += l + "\n";
  return out;
}

}  // namespace pd::test
