#pragma once
// Validation of frame files (docs/frame-format.md, "Errors" and "Limits") shared by FrameReader,
// FrameWriter::open and the hierarchy reader. Internal to common/store, like h5_util.h.
//
// A file is checked completely when it is opened, so that a corrupted or hostile file is refused
// at once with InputError "<file>: <dataset path>: <problem>" instead of being read into NaN output,
// an out-of-range index or an allocation of gigabytes. Each check costs one pass over the
// (small) mesh datasets and the done flags; frame data is checked when a frame is read.
#include <string>
#include <vector>

#include "store/h5_util.h"

namespace pd {

// Limits a frame file must keep (they follow docs/scene-format.md's scene limits).
constexpr int kMaxFrameFileLevels = 20;               // hierarchy.levels <= 20
constexpr long long kMaxFrameFileFrames = 10000001;   // N + 1, frames <= 10 000 000
constexpr long long kMaxLevelVertices = 715827882;    // 3 n fits an int (Eigen and OBJ indices)
constexpr long long kMaxLevelFaces = 715827882;
constexpr long long kMaxLevelObjects = 1000000;
constexpr size_t kMaxSceneTextBytes = 64u << 20;      // the /@scene attribute, 64 MiB

// The counts of one level that opening a file finds (and checks every dataset against).
struct LevelCounts {
  int num_vertices = 0, num_faces = 0, num_objects = 0;
};

// Checks the whole layout of the open frame file f: /@format_version (a single integer, equal to
// kFrameFormatVersion), /@scene (one variable-length string of at most kMaxSceneTextBytes), levels
// 0..L-1 (1 <= L <= kMaxFrameFileLevels, no other link under /levels) each with /hierarchy/<l> and
// /levels/<l>, and per level every dataset's type, shape and content: rest positions finite, faces
// within the vertex count, object offsets from 0 to n without decreasing, names at most
// h5::kMaxStringBytes long, done flags 0 or 1, the same frame count N + 1 (1..kMaxFrameFileFrames)
// in done, positions, center_of_mass and every statistic. *num_frames gets N + 1.
std::vector<LevelCounts> check_frame_file(const h5::File& f, int* num_frames);

// Refuses a file with a global heap collection (signature "GCOL", where HDF5 keeps variable-length
// strings) that HDF5 1.10 would parse forever: an object whose size makes no progress (index 0 with
// size 0) or runs past the collection's end. HDF5's own parser (H5HG__cache_heap_deserialize) loops
// on the first, which the fuzzer found in a 1-byte mutation of a frame file. Call before H5Fopen;
// costs one pass over the file's bytes (mapped, not copied).
void check_global_heaps(const h5::File& f);

// Every value of v finite, else InputError "<name>: <what> <i> is not finite (<value>)"; `per` values
// make one row (3 for positions: the message then names the row, e.g. "vertex 17").
void check_finite(const h5::File& f, const std::string& name, const double* v, size_t n, int per,
                  const std::string& what);
// Every v[i] in [lo, hi), else InputError naming the entry and the range.
void check_index_range(const h5::File& f, const std::string& name, const int* v, size_t n, long long lo,
                       long long hi, const std::string& what = "entry");
// Offsets that start at 0, never decrease and end at `total`.
void check_offsets(const h5::File& f, const std::string& name, const std::vector<long long>& off, long long total);

// Frame t of the (frames, rows, 3) dataset dset has storage in the file (its chunk was written, or the
// dataset is contiguous or compact): a frame marked done whose chunk was never written would read the
// fill value. InputError "<name>: frame <t> of level <l> is marked done but was never written".
void check_frame_stored(const h5::File& f, hid_t dset, const std::string& name, int level, int t);

}  // namespace pd
