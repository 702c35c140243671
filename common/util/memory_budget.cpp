#include "util/memory_budget.h"

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

namespace pd {

namespace {

constexpr double kUnknown = std::numeric_limits<double>::infinity();

// MemAvailable from /proc/meminfo, bytes.
double mem_available() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  double kib = 0.0;
  std::string unit;
  while (in >> key >> kib) {
    std::getline(in, unit);
    if (key == "MemAvailable:") return kib * 1024.0;
  }
  return kUnknown;
}

// RLIMIT_AS less the address space mapped now (/proc/self/statm's first field, in pages).
double address_space_left() {
  struct rlimit limit = {};
  if (getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return kUnknown;
  std::ifstream in("/proc/self/statm");
  double pages = 0.0;
  if (!(in >> pages)) return kUnknown;
  const double used = pages * static_cast<double>(sysconf(_SC_PAGESIZE));
  return static_cast<double>(limit.rlim_cur) - used;
}

// A cgroup v2 file's number; kUnknown for "max", a missing file or anything else.
double cgroup_number(const std::string& path) {
  std::ifstream in(path);
  std::string text;
  if (!(in >> text) || text == "max") return kUnknown;
  std::istringstream s(text);
  double v = 0.0;
  return s >> v ? v : kUnknown;
}

// memory.max less memory.current of this process's cgroup (v2: /proc/self/cgroup's "0::<path>").
double cgroup_left() {
  std::ifstream in("/proc/self/cgroup");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("0::", 0) != 0) continue;
    const std::string dir = "/sys/fs/cgroup" + line.substr(3);
    const double max = cgroup_number(dir + "/memory.max"), current = cgroup_number(dir + "/memory.current");
    if (max == kUnknown || current == kUnknown) return kUnknown;
    return max - current;
  }
  return kUnknown;
}

}  // namespace

MemoryBudget memory_budget() {
  MemoryBudget b{kUnknown, ""};
  const struct {
    double bytes;
    const char* name;
  } limits[] = {{mem_available(), "available memory (MemAvailable)"},
                {address_space_left(), "the address-space limit (ulimit -v)"},
                {cgroup_left(), "the cgroup's memory.max"}};
  for (const auto& l : limits)
    if (l.bytes < b.bytes) b = MemoryBudget{l.bytes < 0.0 ? 0.0 : l.bytes, l.name};
  return b;
}

std::string gib_text(double bytes) {
  char text[64];
  std::snprintf(text, sizeof text, "%.1f GiB", bytes / (1024.0 * 1024.0 * 1024.0));
  return text;
}

double simulation_bytes(long long vertices) { return kSimulationBytesPerVertex * static_cast<double>(vertices); }

}  // namespace pd
