#include "support/test_paths.h"

#include <unistd.h>

#include <atomic>
#include <filesystem>

namespace pd::test {

std::string source_dir() { return PD_SOURCE_DIR; }
std::string pd_binary() { return PD_BINARY; }

std::string scratch_dir(const std::string& tag) {
  static std::atomic<int> counter{0};
  namespace fs = std::filesystem;
  const fs::path p = fs::temp_directory_path() /
                     ("pd_test_" + tag + "_" + std::to_string(getpid()) + "_" + std::to_string(counter++));
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

}  // namespace pd::test
