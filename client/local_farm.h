#pragma once
// A farm on this machine, for `pd run` (and the integration tests): one pd-scheduler on loopback
// port-0 endpoints and N pd-worker processes, started with posix_spawn and always stopped again
// (stop() or the destructor: SIGTERM, up to 5 s grace, SIGKILL, every child reaped).
//
// The children get their own process group, so a Ctrl-C on the terminal reaches pd only and pd
// stops them in order; the flip side is that a pd killed with SIGKILL leaves them running.
#include <sys/types.h>

#include <chrono>
#include <csignal>
#include <optional>
#include <string>
#include <vector>

namespace pd::cli {

struct FarmBinaries {
  std::string scheduler;  // pd-scheduler
  std::string worker;     // pd-worker
};

// Where the farm programs are: the environment variables PD_SCHEDULER_BIN / PD_WORKER_BIN when set,
// else as CMake builds them next to pd (<dir of pd>/../scheduler/pd-scheduler,
// <dir of pd>/../worker/pd-worker), else in pd's own folder. Throws InputError naming every place it
// looked when one is missing.
FarmBinaries find_farm_binaries();

// A child that ended on its own, for messages: "pd-worker w2 (pid 1234) exited with status 1".
struct ChildExit {
  std::string name;
  std::string log;          // its log file
  std::string description;
  bool is_scheduler = false;
};

class LocalFarm {
 public:
  explicit LocalFarm(FarmBinaries binaries);
  ~LocalFarm();
  LocalFarm(const LocalFarm&) = delete;
  LocalFarm& operator=(const LocalFarm&) = delete;

  // While waiting in start(), returns early (throwing Interrupted) once *flag is non-zero, e.g. set
  // by a SIGINT handler.
  void set_stop_flag(const volatile std::sig_atomic_t* flag) { stop_flag_ = flag; }

  // Starts `pd-scheduler --dir DIR` (stderr to DIR/scheduler.log), waits up to `startup` for its
  // first stdout line {"event":"listening","workers":...,"clients":...}, then starts n_workers
  // `pd-worker --connect <workers> --name w<k>` (k = 1..n, output to DIR/worker-<k>.log).
  // Throws std::runtime_error with the end of the scheduler's log when it fails to start.
  // worker_threads > 0 adds `--threads worker_threads` to every worker (0: the workers' default).
  void start(const std::string& dir, int n_workers, int worker_threads = 0,
             std::chrono::milliseconds startup = std::chrono::seconds(10));

  const std::string& clients_endpoint() const { return clients_; }
  const std::string& workers_endpoint() const { return workers_; }
  const std::string& dir() const { return dir_; }

  // Reaps children that ended since the last call and returns them (each once). Also moves what the
  // scheduler wrote to stdout into its log, so the pipe never fills up and blocks it.
  std::vector<ChildExit> poll_exits();
  // Number of workers that are still running.
  int running_workers() const;

  // SIGTERM to every running child, up to `grace` for them to exit, then SIGKILL; waits for all.
  void stop(std::chrono::milliseconds grace = std::chrono::seconds(5));

 private:
  struct Child {
    std::string name;
    std::string log;
    pid_t pid = -1;
    bool running = false;
    bool is_scheduler = false;
  };

  pid_t spawn(const std::vector<std::string>& argv, const std::string& log, int stdout_fd);
  std::string read_listening_line(std::chrono::milliseconds startup);
  void parse_listening_line(const std::string& line);
  void drain_scheduler_stdout();
  [[noreturn]] void fail_start(const std::string& problem);

  FarmBinaries binaries_;
  std::string dir_;
  std::string workers_, clients_;
  std::vector<Child> children_;
  pid_t group_ = 0;         // process group of the children (the scheduler's pid), 0 before the first
  int scheduler_out_ = -1;  // read end of the scheduler's stdout pipe
  const volatile std::sig_atomic_t* stop_flag_ = nullptr;
};

// The last `lines` lines of a text file ("" when it cannot be read), for error messages.
std::string tail_of_file(const std::string& path, int lines = 20);

}  // namespace pd::cli
