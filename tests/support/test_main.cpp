// main() of the test executables: the numerical libraries are configured as in every program
// (util/process_setup.h) before any test runs, so that a test computes the bits pd and pd-worker
// compute, on any machine. The process re-executes itself once to do so (gtest's arguments are
// passed on unchanged).
#include <gtest/gtest.h>

#include "util/process_setup.h"

int main(int argc, char** argv) {
  pd::configure_numerical_libraries(argv);
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
