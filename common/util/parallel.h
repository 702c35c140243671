#pragma once
// Element loops on several cores, with results that do not depend on the number of threads.
//
// The rule that keeps frames bit for bit the same for every thread count: a parallel loop body
// writes only the outputs of its own index (one slot per element), and every reduction over
// elements (energy sums, gradient scatters, Hessian assembly) adds each output's terms in element
// order, as the serial loop did: serially, or in parallel over the outputs (one thread per global
// entry or vertex, each summing its own terms in that order). So a run with N threads does the same
// floating-point operations in the same order as a run with one, and the speed-up comes from the
// per-element work (energy densities, gradients, 9x9 / 12x12 Hessians and their eigen-projections),
// which dominates.
//
// The threads are oneTBB's. OpenMP is not used for this because CHOLMOD's own OpenMP regions are
// held to one thread (util/process_setup.h) and OpenMP's limit is process-wide.
#include <exception>
#include <mutex>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace pd {

// Sets how many threads element loops may use in this process: n >= 1, or 0 for every core the
// process may run on (its CPU affinity). Throws std::invalid_argument for n < 0.
void set_element_threads(int n);
// The number set (0 until set_element_threads is called: every core).
int element_threads();
// The number a loop uses now: element_threads(), or the cores available when that is 0.
int effective_element_threads();

// Calls body(i) for every i in [0, count), on up to effective_element_threads() threads. body(i)
// must write only outputs of index i (see the rule above). If bodies throw, the exception of the
// lowest index that threw is rethrown after the loop (the one a serial loop would have thrown
// first; with one thread, the loop stops there as a serial loop does). min_per_task: the fewest
// indices a thread takes at once; the default suits element loops (~0.1-2 us per index: below 256
// per thread the scheduling costs more than the work), 1 suits a few long tasks.
template <class Body>
void parallel_for_index(int count, const Body& body, int min_per_task = 256) {
  const int kMinPerTask = min_per_task < 1 ? 1 : min_per_task;
  if (count <= 0) return;
  if (effective_element_threads() == 1 || count < 2 * kMinPerTask) {
    for (int i = 0; i < count; ++i) body(i);
    return;
  }
  std::mutex failure_mutex;
  int failed_index = count;
  std::exception_ptr failure;
  tbb::parallel_for(tbb::blocked_range<int>(0, count, kMinPerTask), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i) {
      try {
        body(i);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(failure_mutex);
        if (i < failed_index) {
          failed_index = i;
          failure = std::current_exception();
        }
        return;  // the rest of this range would be discarded anyway
      }
    }
  });
  if (failure) std::rethrow_exception(failure);
}

}  // namespace pd
