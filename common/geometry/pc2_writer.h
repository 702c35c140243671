#pragma once
// Writing PC2 point caches (pd export --format pc2, the character generator in tools/; the reader is
// geometry/pc2_io.h): the vertex animation format that Blender's Mesh Cache
// modifier, 3ds Max's Point Cache modifier and Maya's point cache import read. Layout, all
// little-endian:
//   char[12] "POINTCACHE2\0", int32 file version (1), int32 number of points, float32 start frame,
//   float32 sample rate (frames per sample), int32 number of samples   (32 bytes)
//   then, sample after sample, each point's x, y, z as float32          (samples x points x 12 bytes)
// The coordinates are the frame file's metres, rounded to the nearest float32 (static_cast<float>).
#include <cstdint>
#include <cstdio>
#include <string>

#include "geometry/mesh.h"

namespace pd {

// Bytes of the PC2 header.
inline constexpr int kPc2HeaderBytes = 32;

// Index into x.data() (row-major: 3 * row + axis) of the first coordinate among rows
// [first_row, first_row + rows) that a float32 cannot hold: not finite, or |value| above FLT_MAX
// (it would become inf); -1 when every one fits.
Eigen::Index first_non_float32(const Positions& x, Eigen::Index first_row, Eigen::Index rows);

// One PC2 file, written frame by frame. The constructor creates `path` and writes the header; each
// add_sample appends one sample; close() checks that exactly `num_samples` were added and closes.
// Every failure (cannot create or write, a coordinate beyond float32, wrong sample count) throws
// InputError "<path>: ..."; the caller writes into a temporary folder, so nothing partial is left.
class Pc2Writer {
 public:
  Pc2Writer(std::string path, int num_points, float start_frame, float sample_rate, int num_samples);
  Pc2Writer(const Pc2Writer&) = delete;
  Pc2Writer& operator=(const Pc2Writer&) = delete;
  ~Pc2Writer();

  // Appends rows [first_row, first_row + num_points) of x (metres) as one sample. `what` names the
  // sample in an error (e.g. "frame 7"); callers check first_non_float32 themselves first to name
  // the frame file and vertex, this check is the last guard.
  void add_sample(const Positions& x, Eigen::Index first_row, const std::string& what);
  void close();
  const std::string& path() const { return path_; }

 private:
  void write(const void* bytes, std::size_t n);
  std::string path_;
  std::FILE* out_ = nullptr;
  int num_points_ = 0;
  int num_samples_ = 0;
  int written_ = 0;
};

}  // namespace pd
