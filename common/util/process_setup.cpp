#include "util/process_setup.h"

#include <unistd.h>

#include <cstdlib>

namespace pd {

void limit_openmp_threads(char** argv) {
  if (std::getenv("OMP_THREAD_LIMIT") != nullptr) return;
  if (setenv("OMP_THREAD_LIMIT", "1", 1) != 0) return;
  execv("/proc/self/exe", argv);  // only returns on failure
}

}  // namespace pd
