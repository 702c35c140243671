#pragma once
// Child processes for the integration tests (tests/integration/): the farm's pd-scheduler and
// pd-worker, and short pd commands. Every wait is bounded and nothing outlives its owner: a Process
// is terminated and reaped by its destructor, so a failing assertion (which returns from the test
// body) or an exception still stops it.
//
// Exit codes, everywhere in this header: the exit status (0..255) when the child exited, 128 + the
// signal number when a signal ended it (as a shell reports it).
#include <sys/types.h>

#include <chrono>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace pd::test {

// Environment variables added to (or replacing same-named ones of) this process's environment.
using EnvAdditions = std::vector<std::pair<std::string, std::string>>;

class Process {
 public:
  Process() = default;
  ~Process();  // terminate() when still running
  Process(Process&& other) noexcept;
  Process& operator=(Process&& other) noexcept;  // terminates the process this one holds first
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;

  // Starts argv[0] (a path; PATH is not searched) with posix_spawn in a new process group of its own
  // (so signals to the test's group do not reach it and terminate() reaches its children too), the
  // environment of this process plus `env`, stdin from /dev/null, stdout and stderr to the given
  // files (created or truncated; "" means /dev/null), and no other file descriptor of this process.
  // Throws std::runtime_error naming argv[0] when this object already holds a process, argv is empty
  // or the spawn fails (e.g. no such file).
  void start(const std::vector<std::string>& argv, const EnvAdditions& env = {}, const std::string& stdout_path = "",
             const std::string& stderr_path = "");

  pid_t pid() const { return pid_; }            // -1 before start()
  const std::string& name() const { return name_; }  // argv[0], for messages
  bool started() const { return pid_ > 0; }
  // True while started and not yet ended (reaps it when it has ended).
  bool running();
  // The exit code once the process ended and was reaped, else nullopt.
  std::optional<int> exit_code() const { return exit_code_; }

  // Waits up to `timeout` for the process to end; its exit code, or nullopt when it still runs
  // (it is left running). Returns at once for a process already reaped.
  std::optional<int> wait_for_exit(std::chrono::milliseconds timeout);

  // SIGTERM to its process group, up to `grace` for the process to exit, then SIGKILL to the group;
  // always reaps it. Returns its exit code (128 + 9 when it had to be killed). Does nothing but
  // return the exit code for a process that already ended; -1 when never started.
  int terminate(std::chrono::milliseconds grace = std::chrono::seconds(5));

 private:
  bool reap(bool block);  // waitpid; true once reaped

  pid_t pid_ = -1;
  std::string name_;
  std::optional<int> exit_code_;
};

// A short command's result. exit_code is -1 and timed_out true when it had to be killed after the
// timeout: a failure for every test expecting an exit code.
struct RunResult {
  std::string command;  // argv joined, for messages
  int exit_code = -1;
  bool timed_out = false;
  std::string out;  // stdout
  std::string err;  // stderr
  double seconds = 0.0;  // wall time
  // "`<command>`: exit 2 after 0.1 s; stdout: ...; stderr: ..." for assertion messages.
  std::string describe() const;
};

// Runs argv to its end, at most `timeout` (then SIGTERM, 1 s grace, SIGKILL), capturing stdout and
// stderr through temporary files (so a grandchild that keeps them open cannot stall the wait).
RunResult run(const std::vector<std::string>& argv, std::chrono::milliseconds timeout, const EnvAdditions& env = {});

// The first line of the text file `path` (without its '\n') once the file holds a complete line,
// polling every 10 ms for at most `timeout`; nullopt when no line arrived in time, or when `writer`
// is given and ended without writing one.
std::optional<std::string> read_first_line(const std::string& path, std::chrono::milliseconds timeout,
                                           Process* writer = nullptr);

// The last `lines` lines of a text file ("" when it cannot be read), for failure messages.
std::string file_tail(const std::string& path, int lines = 40);

// The whole file ("" when it cannot be read).
std::string read_file_text(const std::string& path);

// A /proc/<pid>/status field in kiB (VmRSS: resident set, VmHWM: its peak), -1 when unreadable.
long proc_status_kib(pid_t pid, const std::string& field);

}  // namespace pd::test
