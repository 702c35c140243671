#pragma once
// Progress reporting for long commands: a redrawn bar with ETA on a terminal, plain lines (one per
// ~10% and the last) when the output is a file or pipe, so logs stay readable.
#include <chrono>
#include <cstdio>
#include <string>

namespace pd::cli {

class Progress {
 public:
  Progress(std::string label, int total, std::FILE* out = stderr);
  // `done` units finished; `detail` is appended (e.g. "12 Newton its").
  void update(int done, const std::string& detail = "");
  void finish(const std::string& summary);

 private:
  std::string label_;
  int total_;
  std::FILE* out_;
  bool tty_;
  int last_plain_decile_ = -1;
  std::chrono::steady_clock::time_point start_;
};

// "1h02m", "3m05s", "12.3s".
std::string format_duration(double seconds);

}  // namespace pd::cli
