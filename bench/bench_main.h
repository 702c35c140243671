#pragma once
// The benchmark programs' main(): a bad argument or input file (an exception from the library or
// the program) ends the run with a one-line error naming it and exit status 2, not an abort.
#include <cstdio>
#include <exception>

namespace pd::bench {

// Returns run(argc, argv), or 2 after printing "<program>: error: <what>" when it throws.
template <class Run>
int run_reporting_errors(const char* program, Run run, int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", program, e.what());
    return 2;
  }
}

}  // namespace pd::bench
