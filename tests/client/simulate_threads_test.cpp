// pd simulate --threads N: the same frames bit for bit for every thread count (the element loops'
// fixed-order reductions, util/parallel.h), direct and progressive, with contact.
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <string>
#include <vector>

#include "store/frame_store.h"
#include "support/process.h"
#include "support/test_paths.h"

namespace pd {
namespace {

// Every stored frame of every level of a and b must hold the same bytes; returns the number of
// doubles compared.
long expect_same_frames(const std::string& a_path, const std::string& b_path) {
  const FrameReader a(a_path), b(b_path);
  EXPECT_EQ(a.num_levels(), b.num_levels());
  long compared = 0;
  for (int level = 0; level < a.num_levels() && level < b.num_levels(); ++level) {
    const std::vector<uint8_t> done = a.done(level);
    EXPECT_EQ(done, b.done(level)) << "level " << level;
    for (int t = 0; t < static_cast<int>(done.size()); ++t) {
      if (!done[static_cast<size_t>(t)]) continue;
      const Positions xa = a.frame(level, t), xb = b.frame(level, t);
      EXPECT_EQ(xa.size(), xb.size());
      if (xa.size() != xb.size()) continue;
      if (std::memcmp(xa.data(), xb.data(), sizeof(double) * static_cast<size_t>(xa.size())) != 0)
        ADD_FAILURE() << a_path << " and " << b_path << " differ at level " << level << ", frame " << t;
      compared += xa.size();
    }
  }
  return compared;
}

void simulate(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {test::pd_binary(), "simulate"};
  argv.insert(argv.end(), args.begin(), args.end());
  const test::RunResult r = test::run(argv, std::chrono::minutes(5));
  ASSERT_EQ(r.exit_code, 0) << r.describe();
}

TEST(SimulateThreads, DirectFramesWithContactAreBitIdenticalOnOneTwoAndThreeThreads) {
  // The cloth (1 152 faces, 1 680 hinges) lands on the sphere within the frames simulated.
  const std::string dir = test::scratch_dir("simulate_threads_direct");
  const std::string scene = test::source_dir() + "/scenes/drape-sphere.json";
  long compared = 0;
  for (const char* threads : {"1", "2", "3"}) {
    simulate({scene, "--mode", "direct", "--frames", "12", "--quiet", "--threads", threads, "--out",
              dir + "/t" + threads + ".h5"});
    if (std::string(threads) != "1") compared += expect_same_frames(dir + "/t1.h5", dir + "/t" + threads + ".h5");
  }
  EXPECT_GT(compared, 2 * 12 * 3 * 600);  // two comparisons of 13 frames of ~1 300 vertices
}

TEST(SimulateThreads, ProgressiveFramesAreBitIdenticalOnOneAndTwoThreads) {
  const std::string dir = test::scratch_dir("simulate_threads_progressive");
  const std::string scene = test::source_dir() + "/scenes/basket.json";
  for (const char* threads : {"1", "2"})
    simulate({scene, "--mode", "progressive", "--frames", "4", "--quiet", "--threads", threads, "--out",
              dir + "/t" + threads + ".h5"});
  EXPECT_GT(expect_same_frames(dir + "/t1.h5", dir + "/t2.h5"), 3 * 4 * 3 * 100);  // 3 levels, 5 frames
}

TEST(SimulateThreads, ABadThreadCountIsRefusedNamingTheOption) {
  const std::string dir = test::scratch_dir("simulate_threads_bad");
  for (const char* bad : {"0", "-2", "two", "0x2"}) {
    const test::RunResult r = test::run({test::pd_binary(), "simulate", test::source_dir() + "/scenes/basket.json",
                                         "--threads", bad, "--out", dir + "/x.h5"},
                                        std::chrono::seconds(30));
    EXPECT_EQ(r.exit_code, 2) << r.describe();
    EXPECT_NE(r.err.find("--threads"), std::string::npos) << r.describe();
  }
}

}  // namespace
}  // namespace pd
