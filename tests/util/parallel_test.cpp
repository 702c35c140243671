// util/parallel.h: every index runs once whatever the thread count, the lowest failing index's
// exception is the one rethrown, and the thread setting is validated.
#include "util/parallel.h"

#include <atomic>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace pd {
namespace {

// Restores the process's thread setting when a test ends (tests share one process).
struct ThreadSettingGuard {
  int saved = element_threads();
  ~ThreadSettingGuard() { set_element_threads(saved); }
};

TEST(Parallel, EveryIndexRunsExactlyOnceForOneTwoAndFourThreads) {
  ThreadSettingGuard guard;
  for (int threads : {1, 2, 4}) {
    set_element_threads(threads);
    EXPECT_EQ(effective_element_threads(), threads);
    for (int count : {0, 1, 511, 512, 10007}) {
      std::vector<std::atomic<int>> visits(static_cast<size_t>(count));
      parallel_for_index(count, [&](int i) { visits[static_cast<size_t>(i)].fetch_add(1); });
      int wrong = 0;
      for (const auto& v : visits) wrong += v.load() != 1;
      EXPECT_EQ(wrong, 0) << threads << " threads, " << count << " indices";
    }
  }
}

TEST(Parallel, TheLowestFailingIndexIsTheExceptionRethrown) {
  ThreadSettingGuard guard;
  for (int threads : {1, 2}) {
    set_element_threads(threads);
    // Indices 3000 and 9000 fail; a serial loop meets 3000 first.
    try {
      parallel_for_index(12000, [](int i) {
        if (i == 3000 || i == 9000) throw std::runtime_error("index " + std::to_string(i));
      });
      ADD_FAILURE() << "no exception with " << threads << " threads";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "index 3000") << threads << " threads";
    }
  }
}

TEST(Parallel, ANegativeThreadCountIsRefusedAndZeroMeansEveryCore) {
  ThreadSettingGuard guard;
  EXPECT_THROW(set_element_threads(-1), std::invalid_argument);
  set_element_threads(0);
  EXPECT_EQ(element_threads(), 0);
  EXPECT_GE(effective_element_threads(), 1);
}

}  // namespace
}  // namespace pd
