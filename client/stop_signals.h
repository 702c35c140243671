#pragma once
// SIGINT / SIGTERM as a flag for the life of one command (pd run, pd simulate): the command polls
// it and stops cleanly (a farm shut down, the frames stored so far kept) instead of dying mid-write.
#include <csignal>

namespace pd::cli {

class StopSignals {
 public:
  // Installs the handler with these sigaction flags and clears the flag; the destructor restores the
  // old handlers. pd run: 0 (a blocking wait returns EINTR, so its loop notices promptly). pd
  // simulate: SA_RESTART | SA_RESETHAND (the solver is not interrupted; a second signal ends pd).
  explicit StopSignals(int flags);
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

  // The signal received since construction (SIGINT or SIGTERM), 0 if none; the flag itself for code
  // that polls a pointer (LocalFarm::set_stop_flag).
  static int received() { return flag_; }
  static volatile std::sig_atomic_t* flag() { return &flag_; }

 private:
  static volatile std::sig_atomic_t flag_;
  struct sigaction old_int_ = {}, old_term_ = {};
};

}  // namespace pd::cli
