#include "util/parallel.h"

#include <memory>
#include <stdexcept>
#include <string>

#include <tbb/global_control.h>
#include <tbb/info.h>

namespace pd {

namespace {

int g_threads = 0;  // 0: every core
// TBB's process-wide cap; lives until the next set_element_threads or the end of the process.
std::unique_ptr<tbb::global_control> g_control;

}  // namespace

void set_element_threads(int n) {
  if (n < 0) throw std::invalid_argument("element threads must be >= 0 (0: every core), got " + std::to_string(n));
  g_control.reset();
  g_threads = n;
  if (n > 0) g_control = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                               static_cast<size_t>(n));
}

int element_threads() { return g_threads; }

int effective_element_threads() {
  if (g_threads > 0) return g_threads;
  // The default arena's concurrency follows the process's CPU affinity mask.
  return tbb::info::default_concurrency();
}

}  // namespace pd
