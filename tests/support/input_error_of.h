#pragma once
// The message of the InputError that f() throws, for tests that check what a bad input is told.
#include <string>

#include "util/input_error.h"

namespace pd::test {

template <typename F>
std::string input_error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError thrown)";
}

}  // namespace pd::test
