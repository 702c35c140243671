#include "util/subprocess.h"

#include <sys/resource.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

extern char** environ;

namespace pd {

namespace {

using Clock = std::chrono::steady_clock;

std::string first_line(const std::string& s) {
  std::string line = s.substr(0, s.find('\n'));
  return line.size() > 300 ? line.substr(0, 300) + "..." : line;
}

// Reads from both pipes until both are closed or the deadline passes; false on timeout.
bool drain(int out_fd, int err_fd, std::string& out, std::string& err, Clock::time_point deadline) {
  pollfd fds[2] = {{out_fd, POLLIN, 0}, {err_fd, POLLIN, 0}};
  std::string* sinks[2] = {&out, &err};
  int open = 2;
  char buf[65536];
  while (open > 0) {
    const auto now = Clock::now();
    if (now >= deadline) return false;
    // Rounded up: truncating would give up to 1 ms before the deadline (a 0.3 s timeout then
    // reported 0.2997 s).
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - now).count();
    const int n = poll(fds, 2, static_cast<int>(left));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return false;
    for (int k = 0; k < 2; ++k) {
      if (fds[k].fd < 0 || !(fds[k].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const ssize_t got = read(fds[k].fd, buf, sizeof buf);
      if (got > 0) {
        const std::size_t room = kMaxCommandOutput - std::min(kMaxCommandOutput, sinks[k]->size());
        sinks[k]->append(buf, std::min<std::size_t>(room, static_cast<std::size_t>(got)));
      } else if (got == 0 || (errno != EINTR && errno != EAGAIN)) {
        fds[k].fd = -1;  // poll skips negative descriptors
        --open;
      }
    }
  }
  return true;
}

}  // namespace

CommandResult run_command(const std::vector<std::string>& argv, std::chrono::milliseconds timeout) {
  CommandResult r;
  const std::string name = argv.empty() ? std::string("(empty command)") : argv[0];
  if (argv.empty()) {
    r.failure = name + ": cannot run";
    return r;
  }
  int out_pipe[2], err_pipe[2];
  if (pipe2(out_pipe, O_CLOEXEC) != 0) {
    r.failure = name + ": cannot run: " + std::strerror(errno);
    return r;
  }
  if (pipe2(err_pipe, O_CLOEXEC) != 0) {
    r.failure = name + ": cannot run: " + std::strerror(errno);
    close(out_pipe[0]);
    close(out_pipe[1]);
    return r;
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, out_pipe[1], 1);  // dup2 clears FD_CLOEXEC on the copy
  posix_spawn_file_actions_adddup2(&actions, err_pipe[1], 2);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attr, 0);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, argv[0].c_str(), &actions, &attr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  close(out_pipe[1]);
  close(err_pipe[1]);
  if (rc != 0) {
    close(out_pipe[0]);
    close(err_pipe[0]);
    r.failure = name + ": cannot run: " + std::strerror(rc);
    return r;
  }
  const auto started = Clock::now();
  const auto deadline = started + timeout;
  const bool finished = drain(out_pipe[0], err_pipe[0], r.out, r.err, deadline);
  close(out_pipe[0]);
  close(err_pipe[0]);
  int status = 0;
  bool reaped = false;
  // Both pipes closed: the command has ended (or closed them itself); wait for it, bounded.
  while (finished && !reaped && Clock::now() < deadline) {
    const pid_t w = waitpid(pid, &status, WNOHANG);
    if (w == pid) reaped = true;
    else if (w < 0 && errno != EINTR) break;
    else usleep(2000);
  }
  if (!reaped) {
    kill(-pid, SIGKILL);
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    r.timed_out = true;
    r.seconds = std::chrono::duration<double>(Clock::now() - started).count();
    char seconds[32];
    std::snprintf(seconds, sizeof seconds, "%.1f", static_cast<double>(timeout.count()) / 1000.0);
    r.failure = name + ": timed out after " + seconds + " s";
    return r;
  }
  r.seconds = std::chrono::duration<double>(Clock::now() - started).count();
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  if (r.exit_code != 0) {
    const std::string said = first_line(r.err.empty() ? r.out : r.err);
    r.failure = name + ": exit " + std::to_string(r.exit_code) + (said.empty() ? "" : ": " + said);
  }
  return r;
}

void cap_address_space(std::size_t bytes) {
#if !defined(__SANITIZE_ADDRESS__)
  const rlimit cap = {static_cast<rlim_t>(bytes), static_cast<rlim_t>(bytes)};
  setrlimit(RLIMIT_AS, &cap);
#else
  (void)bytes;
#endif
}

std::optional<std::string> check_refusal(const CommandResult& r, const std::string& error_prefix) {
  if (r.timed_out || r.exit_code != 2) return std::nullopt;
  std::string first = r.err.substr(0, r.err.find('\n'));
  if (first.rfind(error_prefix, 0) == 0) first = first.substr(error_prefix.size());
  if (first.empty()) return std::nullopt;
  return first;
}

}  // namespace pd
