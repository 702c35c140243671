#include "stop_signals.h"

namespace pd::cli {

volatile std::sig_atomic_t StopSignals::flag_ = 0;

namespace {
extern "C" void on_stop_signal(int sig) { *StopSignals::flag() = sig; }
}  // namespace

StopSignals::StopSignals(int flags) {
  flag_ = 0;
  struct sigaction sa = {};
  sa.sa_handler = on_stop_signal;
  sa.sa_flags = flags;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &old_int_);
  sigaction(SIGTERM, &sa, &old_term_);
}

StopSignals::~StopSignals() {
  sigaction(SIGINT, &old_int_, nullptr);
  sigaction(SIGTERM, &old_term_, nullptr);
}

}  // namespace pd::cli
