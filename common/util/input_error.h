#pragma once
#include <stdexcept>

namespace pd {

// Every bad-input error (scene files, meshes, frame files, command lines) is thrown as this type, and
// its what() names the file and, where there is one, the key path or line, e.g.
//   "scenes/flag.json: objects[0].material.thickness: must be > 0, got -0.001"
// The pd command prints it and exits non-zero.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace pd
