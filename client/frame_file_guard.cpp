#include "frame_file_guard.h"

#include <chrono>
#include <cstdio>
#include <exception>

#include "output_files.h"
#include "store/frame_store.h"
#include "store/hierarchy_store.h"
#include "util/input_error.h"
#include "util/subprocess.h"

namespace pd::cli {

namespace {

std::string g_checker;

constexpr std::chrono::seconds kCheckTime{30};

}  // namespace

void set_frame_file_checker(const std::string& program) { g_checker = program; }

void check_frame_file_in_child(const std::string& path) {
  if (g_checker.empty()) return;
  const CommandResult r = run_command({g_checker, "check-frame-file", path}, kCheckTime);
  if (r.exit_code == 0 && !r.timed_out) return;
  if (const std::optional<std::string> refused = check_refusal(r, "pd: error: ")) throw InputError(*refused);
  const std::string how = r.timed_out ? "did not finish within " + std::to_string(kCheckTime.count()) + " s"
                          : r.exit_code > 128 ? "crashed (killed by signal " + std::to_string(r.exit_code - 128) + ")"
                                              : "ended with exit " + std::to_string(r.exit_code);
  throw InputError(shown_path(path) + ": HDF5 " + how +
                   " reading this file: it is damaged or crafted (docs/fuzzing.md, known HDF5 bugs); not opened");
}

int check_frame_file_here(const std::string& path) {
  cap_address_space(std::size_t{4} << 30);
  try {
    const FrameReader reader(path);
    read_hierarchy(path);  // nullopt when the file holds no stored hierarchy
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd: error: %s\n", e.what());
    return 2;
  }
}

}  // namespace pd::cli
