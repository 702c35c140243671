// Replays every file of fuzz/corpus/<target>/ and fuzz/regression/<target>/ through the fuzzers'
// entry functions (fuzz/fuzz_entries.h), in the normal g++ build: each input must come back within
// 1 s with no exception other than the InputError the entry function catches. The regression folders
// hold every input that ever failed (docs/fuzzing.md), so a fixed finding stays fixed.
#include "fuzz_entries.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace pd {
namespace {

namespace fs = std::filesystem;
using Entry = int (*)(const uint8_t*, size_t);

std::vector<fs::path> inputs_of(const std::string& target) {
  std::vector<fs::path> out;
  for (const char* folder : {"corpus", "regression"}) {
    const fs::path dir = fs::path(PD_SOURCE_DIR) / "fuzz" / folder / target;
    if (!fs::is_directory(dir)) continue;
    for (const fs::directory_entry& e : fs::directory_iterator(dir))
      if (e.is_regular_file()) out.push_back(e.path());
  }
  return out;
}

// Replays every input of `target`; returns how many ran.
size_t replay(const std::string& target, Entry entry) {
  const std::vector<fs::path> files = inputs_of(target);
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    std::ifstream in(file, std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto start = std::chrono::steady_clock::now();
    try {
      EXPECT_EQ(entry(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()), 0);
    } catch (const std::exception& e) {
      ADD_FAILURE() << "exception other than InputError: " << e.what();
    } catch (...) {
      ADD_FAILURE() << "exception of an unknown type";
    }
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
  }
  return files.size();
}

TEST(FuzzRegression, EverySceneInputReturnsWithinOneSecond) {
  EXPECT_GT(replay("scene", pd_fuzz_scene), 0u) << "no input found under fuzz/corpus/scene";
}

TEST(FuzzRegression, EveryFrameFileInputReturnsWithinOneSecond) {
  EXPECT_GT(replay("frame_file", pd_fuzz_frame_file), 0u) << "no input found under fuzz/corpus/frame_file";
}

}  // namespace
}  // namespace pd
