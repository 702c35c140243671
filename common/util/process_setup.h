#pragma once
// Process-wide settings that must be in place before any numerical work, shared by every program
// (pd, pd-worker, the benchmarks).

namespace pd {

// Holds the numerical libraries' own thread pools to one thread; the element loops have their own
// (util/parallel.h). Both libraries read their limit only when the process starts, so when a
// variable is unset this sets it to 1 and re-executes the program with the same arguments; a user
// who sets a variable themselves is respected. Returns normally when nothing had to be done or when
// the re-exec failed (then the program just runs slower).
//   OMP_THREAD_LIMIT: Debian's CHOLMOD runs parts of its supernodal factorization with a
//     compiled-in num_threads(4) OpenMP clause. On the 2-core machines we run on that oversubscribes
//     the cores, and factorization was 2.3x slower than with one OpenMP thread (measured in
//     docs/performance.md).
//   OPENBLAS_NUM_THREADS: CholmodSolver calls openblas_set_num_threads(1) (the same frames on every
//     machine), but OpenBLAS starts a pool of one thread per core when it is loaded, and the pool's
//     threads spin on sched_yield for about 0.1 s before they sleep: a core's worth of work the
//     element threads then compete with (measured in docs/performance.md, issue 16).
void limit_library_threads(char** argv);

}  // namespace pd
