#include "util/process_setup.h"

#include <unistd.h>

#include <cstdlib>

// OpenBLAS, linked directly (solver/cholmod_solver.cpp).
extern "C" char* openblas_get_corename(void);

namespace pd {

namespace {
// Sets `name` to `value` when it is unset or empty (both libraries read an empty value as unset);
// true when it was set here.
bool set_if_unset(const char* name, const char* value) {
  const char* current = std::getenv(name);
  return (current == nullptr || *current == '\0') && setenv(name, value, 1) == 0;
}
}  // namespace

const char* blas_kernel_for_this_cpu() {
#if defined(__x86_64__)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return "Haswell";
#endif
  return nullptr;
}

const char* blas_kernel_in_use() { return openblas_get_corename(); }

void configure_numerical_libraries(char** argv) {
  const bool openmp = set_if_unset("OMP_THREAD_LIMIT", "1");
  const bool threads = set_if_unset("OPENBLAS_NUM_THREADS", "1");
  const char* kernel = blas_kernel_for_this_cpu();
  const bool core = kernel != nullptr && set_if_unset("OPENBLAS_CORETYPE", kernel);
  if (openmp || threads || core) execv("/proc/self/exe", argv);  // only returns on failure
}

}  // namespace pd
