#pragma once
// The benchmark programs' main(): the numerical libraries configured as in every program
// (util/process_setup.h), and a bad argument or input file (an exception from the library or the
// program) ending the run with a one-line error naming it and exit status 2, not an abort.
#include <cstdio>
#include <exception>

#include "util/process_setup.h"

namespace pd::bench {

// Configures the numerical libraries (may re-execute the program), then returns run(argc, argv), or
// 2 after printing "<program>: error: <what>" when it throws.
template <class Run>
int run_benchmark(const char* program, Run run, int argc, char** argv) {
  configure_numerical_libraries(argv);
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", program, e.what());
    return 2;
  }
}

}  // namespace pd::bench
