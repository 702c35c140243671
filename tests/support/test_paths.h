#pragma once
// Paths the tests need: the source tree (scenes/), the pd binary, and a fresh scratch folder.
#include <string>

namespace pd::test {

std::string source_dir();          // the repository root
std::string pd_binary();           // the built pd executable
// A new empty folder under the system temp dir, unique per call, named after `tag`.
std::string scratch_dir(const std::string& tag);

}  // namespace pd::test
