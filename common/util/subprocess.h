#pragma once
// Runs a short external command (sbatch, squeue, scancel for the scheduler's Slurm workers) to its
// end with a time limit, capturing what it prints. The scheduler is single-threaded, so every call
// is bounded: a command that does not end in time is killed (SIGKILL to its process group) and
// reported as timed out, never waited on for ever.
#include <chrono>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace pd {

struct CommandResult {
  int exit_code = -1;      // 0..255, 128 + signal when a signal ended it, -1 when it never ran
  bool timed_out = false;  // killed after the timeout
  std::string out, err;    // stdout and stderr, each cut at kMaxCommandOutput bytes
  double seconds = 0.0;    // wall time from the spawn to the end (or the kill)
  // "" when it ran and exited 0, else one line for a message: "sbatch: exit 1: <first stderr line>",
  // "sbatch: timed out after 10 s", "sbatch: cannot run: No such file or directory".
  std::string failure;
};

constexpr std::size_t kMaxCommandOutput = std::size_t{1} << 20;

// argv[0] is looked up in PATH (posix_spawnp). stdin is /dev/null; the child has its own process
// group and no other file descriptor of this process; it inherits the environment.
CommandResult run_command(const std::vector<std::string>& argv, std::chrono::milliseconds timeout);

// For a check run as a child process on an untrusted file (pd-scheduler --check-hierarchy, pd
// check-frame-file): the child's side caps its own address space (a crafted file can ask for
// gigabytes; not under AddressSanitizer, which reserves terabytes up front) ...
void cap_address_space(std::size_t bytes);

// ... and the parent's side: the refusal the check printed when it exited 2 ("<prefix>error: ..." on
// its first stderr line, without the prefix), or nullopt (it passed, or it crashed, timed out or
// could not run: r.exit_code, r.timed_out and r.failure say which).
std::optional<std::string> check_refusal(const CommandResult& r, const std::string& error_prefix);

}  // namespace pd
