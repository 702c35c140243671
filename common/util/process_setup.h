#pragma once
// Process-wide settings that must be in place before any numerical work, shared by every program
// (pd, pd-worker, the benchmarks, the test binaries).

namespace pd {

// Sets the numerical libraries' start-up variables and re-executes the program with the same
// arguments when it had to set one, because both libraries read them only when the process is
// loaded. A variable the user set themselves (to a non-empty value) is respected. Returns normally
// when nothing had to be done or when the re-exec failed (then the program runs slower, or with
// OpenBLAS's own kernel).
//   OMP_THREAD_LIMIT=1: Debian's CHOLMOD runs parts of its supernodal factorization with a
//     compiled-in num_threads(4) OpenMP clause. On the 2-core machines we run on that oversubscribes
//     the cores, and factorization was 2.3x slower than with one OpenMP thread (measured in
//     docs/performance.md). The element loops have their own threads (util/parallel.h).
//   OPENBLAS_NUM_THREADS=1: CholmodSolver calls openblas_set_num_threads(1) (the same frames on every
//     machine), but OpenBLAS starts a pool of one thread per core when it is loaded, and the pool's
//     threads spin on sched_yield for about 0.1 s before they sleep: a core's worth of work the
//     element threads then compete with (measured in docs/performance.md, issue 16).
//   OPENBLAS_CORETYPE (blas_kernel_for_this_cpu()): Debian's OpenBLAS picks its kernels by CPU model
//     when loaded, and the kernels sum in different orders (AVX-512 against AVX2 blocking), so the
//     supernodal factorization, and with it every frame, differed in the last bits between an
//     Intel AVX-512 worker and an AMD one (drape-gear: 4e-10 m after 20 frames; a contact scene
//     amplifies that to centimetres). One kernel on every machine keeps the farm's promise of the
//     same frames whichever worker ran a task.
void configure_numerical_libraries(char** argv);

// The OpenBLAS kernel every process runs on this CPU: "Haswell" (AVX2 + FMA: Intel Xeons since
// Haswell, AMD since Zen; OpenBLAS's own Zen choice gives the same bits) or nullptr when the CPU
// cannot run it (older x86-64, other architectures): OpenBLAS then chooses, and frames may differ in
// the last bits from those of AVX2 machines.
const char* blas_kernel_for_this_cpu();

// The kernel OpenBLAS actually loaded (its own name, e.g. "Haswell", "Cooperlake"), for logs.
const char* blas_kernel_in_use();

}  // namespace pd
