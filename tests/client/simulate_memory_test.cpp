// pd simulate checks the memory a scene needs before building it (util/memory_budget.h; issue 47
// item 2): under an address-space limit (ulimit -v, set by a shell the test starts) a scene too large
// for it is refused naming the scene, its vertices, the estimate and the limit, with exit 2 and no
// output, instead of "internal error: std::bad_alloc" after minutes; a scene that fits runs.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

#include "support/process.h"
#include "support/test_paths.h"
#include "util/memory_budget.h"

namespace pd {
namespace {

using namespace std::chrono_literals;

// A pinned cotton sheet of cells x cells (direct, one frame).
std::string write_sheet(const std::string& dir, int cells) {
  const std::string path = dir + "/sheet" + std::to_string(cells) + ".json";
  std::ofstream(path) << R"({"format_version": 1, "name": "sheet", "time_step": 0.01, "frames": 1, "mode": "direct",
    "objects": [{"name": "sheet", "mesh": {"type": "rectangle", "size": [1, 1], "cells": [)"
                      << cells << ", " << cells << R"(]},
      "material": {"preset": "cotton"}, "pins": [{"indices": [0]}]}]})";
  return path;
}

// pd simulate SCENE under `ulimit -v kib`.
test::RunResult simulate_limited(const std::string& scene, const std::string& out, long kib) {
  return test::run({"/bin/bash", "-c",
                    "ulimit -v " + std::to_string(kib) + " && exec " + test::pd_binary() + " simulate " + scene +
                        " --out " + out},
                   120s);
}

TEST(SimulateMemory, ASceneTooLargeForTheAddressSpaceLimitIsRefusedBeforeItIsBuilt) {
  const std::string dir = test::scratch_dir("simulate_memory");
  const std::string big = write_sheet(dir, 1000);  // 1 002 001 vertices: about 17 GiB
  const test::RunResult r = simulate_limited(big, dir + "/big.h5", 1L << 20);  // 1 GiB
  EXPECT_EQ(r.exit_code, 2) << r.describe();
  EXPECT_NE(r.err.find("sheet1000.json: 1002001 vertices would need about 17.2 GiB to simulate"), std::string::npos)
      << r.describe();
  EXPECT_NE(r.err.find("is left to this process by the address-space limit (ulimit -v)"), std::string::npos)
      << r.describe();
  EXPECT_EQ(r.err.find("internal error"), std::string::npos) << r.describe();
  EXPECT_FALSE(std::filesystem::exists(dir + "/big.h5"));
  std::printf("refused in %.2f s: %s", r.seconds, r.err.c_str());

  const std::string small = write_sheet(dir, 20);  // 441 vertices
  const test::RunResult ok = simulate_limited(small, dir + "/small.h5", 1L << 20);
  EXPECT_EQ(ok.exit_code, 0) << ok.describe();
  EXPECT_TRUE(std::filesystem::exists(dir + "/small.h5"));
}

TEST(SimulateMemory, TheBudgetIsTheSmallestLimitThisProcessHas) {
  const MemoryBudget b = memory_budget();
  EXPECT_GT(b.bytes, 0.0);
  EXPECT_FALSE(b.limited_by.empty()) << "no limit read (is /proc mounted?)";
  EXPECT_EQ(gib_text(1.5 * 1024 * 1024 * 1024), "1.5 GiB");
  EXPECT_DOUBLE_EQ(simulation_bytes(1000), 1000 * kSimulationBytesPerVertex);
}

}  // namespace
}  // namespace pd
