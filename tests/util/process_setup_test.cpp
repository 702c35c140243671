// util/process_setup: every process (this test binary too, through support/test_main.cpp) runs with
// the numerical libraries' variables set and OpenBLAS on the one kernel chosen for the CPU.
#include "util/process_setup.h"

#include <strings.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>

#include <gtest/gtest.h>

#include "support/process.h"

namespace pd {
namespace {

TEST(ProcessSetup, TheReExecutedProcessHasEveryLibraryVariableSet) {
  EXPECT_NE(std::getenv("OMP_THREAD_LIMIT"), nullptr);
  EXPECT_NE(std::getenv("OPENBLAS_NUM_THREADS"), nullptr);
  if (blas_kernel_for_this_cpu() != nullptr) {
    EXPECT_NE(std::getenv("OPENBLAS_CORETYPE"), nullptr);
  }
}

// The farm's promise of the same frames whichever worker: OpenBLAS's own choice (e.g. "Cooperlake"
// on an AVX-512 Xeon, "Zen" on an EPYC) gave different bits, so every AVX2 + FMA machine runs
// "Haswell".
TEST(ProcessSetup, EveryAvx2FmaCpuRunsOpenBlasHaswellKernel) {
#if defined(__x86_64__)
  __builtin_cpu_init();
  const bool avx2_fma = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  const bool avx2_fma = false;
#endif
  if (!avx2_fma) {
    EXPECT_EQ(blas_kernel_for_this_cpu(), nullptr);  // OpenBLAS chooses; nothing can be pinned
    return;
  }
  ASSERT_STREQ(blas_kernel_for_this_cpu(), "Haswell");
  // What runs is what the environment names: ours, or one the user set themselves.
  const char* named = std::getenv("OPENBLAS_CORETYPE");
  ASSERT_NE(named, nullptr);
  EXPECT_EQ(strcasecmp(blas_kernel_in_use(), named), 0) << "in use: " << blas_kernel_in_use() << ", named: " << named;
}

// An empty variable is unset to OpenBLAS, which then picks its own kernel: it must be set too. The
// test above, run in a child started with OPENBLAS_CORETYPE="", finds the kernel it names.
TEST(ProcessSetup, AnEmptyKernelVariableIsSetLikeAnUnsetOne) {
  const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
  const test::RunResult r =
      test::run({self, "--gtest_filter=ProcessSetup.EveryAvx2FmaCpuRunsOpenBlasHaswellKernel"}, std::chrono::seconds(60),
                {{"OPENBLAS_CORETYPE", ""}});
  EXPECT_EQ(r.exit_code, 0) << r.describe();
  EXPECT_NE(r.out.find("[  PASSED  ] 1 test"), std::string::npos) << r.describe();
}

}  // namespace
}  // namespace pd
