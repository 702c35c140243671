#pragma once
// How much memory this process may still take, asked before a large allocation is made (issue 47
// item 2: `pd simulate` on a 2 M-vertex mesh under a 2 GiB limit ended in "internal error:
// std::bad_alloc" after minutes of work). Three limits, whichever is smallest:
//  * the kernel's MemAvailable (/proc/meminfo): what can be allocated without swapping;
//  * the address-space limit (RLIMIT_AS, `ulimit -v`) less the address space mapped now
//    (/proc/self/statm): every allocation counts against it, touched or not;
//  * the cgroup's memory.max less its memory.current (cgroup v2, /sys/fs/cgroup): a container's or a
//    systemd unit's MemoryMax=.
// Linux only; a limit that cannot be read is left out (+infinity when none can).
#include <stdexcept>
#include <string>

namespace pd {

struct MemoryBudget {
  double bytes = 0.0;      // the smallest of the limits, bytes (+infinity when none could be read)
  std::string limited_by;  // which one: "available memory (MemAvailable)", "the address-space limit
                           // (ulimit -v)", "the cgroup's memory.max"; "" when none
};

MemoryBudget memory_budget();

// An allocation failed (std::bad_alloc) where a command can still say what it kept (pd simulate's
// stored frames): not a bug, not bad input; pd exits 3 with the message.
class OutOfMemory : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Bytes as "1.5 GiB" (one decimal), for messages.
std::string gib_text(double bytes);

// The memory a simulation of a scene with `vertices` vertices (every object's, obstacles included)
// is expected to need, bytes: kSimulationBytesPerVertex each. Measured (docs/performance.md,
// "Memory a simulation needs"): peak resident size of `pd simulate` on a pinned cotton sheet, one
// frame, direct: 14.0 / 13.2 / 14.0 KiB per vertex at 10 201 / 40 401 / 160 801 vertices (the
// Hessian, its CHOLMOD factorization, the element data); progressive 16.1-17.1 KiB.
constexpr double kSimulationBytesPerVertex = 18.0 * 1024.0;
double simulation_bytes(long long vertices);

}  // namespace pd
