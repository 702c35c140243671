// libFuzzer target: HDF5 frame files (fuzz/fuzz_entries.h, docs/fuzzing.md).
#include "fuzz_entries.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pd::pd_fuzz_frame_file(data, size);
}
