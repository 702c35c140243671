#pragma once
// Fuzz entry points: each feeds one input to a reader of hostile input and returns 0 when the reader
// either accepted it or refused it with pd::InputError. Anything else (another exception, a crash, a
// hang) is a finding. Compiled into the libFuzzer targets (fuzz/*_fuzzer.cpp, clang only) and into
// the normal test suite, which replays fuzz/corpus/ and fuzz/regression/ through them
// (tests/fuzz/fuzz_regression_test.cpp). docs/fuzzing.md describes the targets.
#include <cstddef>
#include <cstdint>

namespace pd {

// The bytes as scene JSON text: pd::parse_scene(text, "fuzz.json", ""). OBJ paths in the input are
// refused before they are opened (a fuzzer must not read files or FIFOs of the machine), so the
// input stays self-contained.
int pd_fuzz_scene(const uint8_t* data, size_t size);

// The bytes as an HDF5 frame file: written to a private temporary file (in /dev/shm when it exists),
// opened with FrameReader, and every part read: scene text, each level's mesh, done flags, every done
// frame and centre of mass, every statistic; then the stored hierarchy with pd::read_hierarchy.
int pd_fuzz_frame_file(const uint8_t* data, size_t size);

}  // namespace pd
