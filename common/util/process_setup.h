#pragma once
// Process-wide settings that must be in place before any numerical work, shared by every program
// (pd, the benchmarks, later the worker).

namespace pd {

// Debian's CHOLMOD runs parts of its supernodal factorization with a compiled-in num_threads(4)
// OpenMP clause. On the 2-core machines we run on that oversubscribes the cores, and factorization
// was 2.3x slower than with one OpenMP thread (measured in docs/performance.md). OpenMP reads its
// thread limit (OMP_THREAD_LIMIT) only when the process starts, so when the variable is unset this
// sets it to 1 and re-executes the program with the same arguments; a user who wants more threads
// sets OMP_THREAD_LIMIT themselves and it is respected. Returns normally when nothing had to be done
// or when the re-exec failed (then the program just runs slower).
void limit_openmp_threads(char** argv);

}  // namespace pd
