#include "util/process_setup.h"

#include <unistd.h>

#include <cstdlib>

namespace pd {

namespace {
// Sets `name` to "1" when it is unset; true when it was set here.
bool set_to_one_if_unset(const char* name) {
  return std::getenv(name) == nullptr && setenv(name, "1", 1) == 0;
}
}  // namespace

void limit_library_threads(char** argv) {
  const bool openmp = set_to_one_if_unset("OMP_THREAD_LIMIT");
  const bool openblas = set_to_one_if_unset("OPENBLAS_NUM_THREADS");
  if (openmp || openblas) execv("/proc/self/exe", argv);  // only returns on failure
}

}  // namespace pd
