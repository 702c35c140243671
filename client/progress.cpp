#include "progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>

namespace pd::cli {

std::string format_duration(double s) {
  char buf[32];
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 60) std::snprintf(buf, sizeof buf, "%.1fs", s);
  else if (s < 3600) std::snprintf(buf, sizeof buf, "%dm%02ds", int(s) / 60, int(s) % 60);
  else std::snprintf(buf, sizeof buf, "%dh%02dm", int(s) / 3600, (int(s) % 3600) / 60);
  return buf;
}

Progress::Progress(std::string label, int total, std::FILE* out)
    : label_(std::move(label)), total_(std::max(total, 1)), out_(out),
      tty_(isatty(fileno(out)) != 0), start_(std::chrono::steady_clock::now()) {}

void Progress::update(int done, const std::string& detail) {
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double frac = std::clamp(double(done) / total_, 0.0, 1.0);
  const double eta = done > 0 ? elapsed * (total_ - done) / done : NAN;
  if (tty_) {
    const int width = 30, filled = int(frac * width + 0.5);
    std::fprintf(out_, "\r%s [%s%s] %d/%d %3.0f%% elapsed %s ETA %s %s\033[K", label_.c_str(),
                 std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(), done, total_,
                 100 * frac, format_duration(elapsed).c_str(), format_duration(eta).c_str(), detail.c_str());
    std::fflush(out_);
    return;
  }
  const int decile = int(frac * 10);
  if (decile == last_plain_decile_ && done != total_) return;
  last_plain_decile_ = decile;
  std::fprintf(out_, "%s %d/%d (%.0f%%) elapsed %s ETA %s %s\n", label_.c_str(), done, total_, 100 * frac,
               format_duration(elapsed).c_str(), format_duration(eta).c_str(), detail.c_str());
  std::fflush(out_);
}

void Progress::finish(const std::string& summary) {
  if (tty_) std::fprintf(out_, "\n");
  std::fprintf(out_, "%s\n", summary.c_str());
  std::fflush(out_);
}

}  // namespace pd::cli
