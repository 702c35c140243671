#pragma once
// PC2 point-cache bytes written from the format's layout (32-byte header, then float32 x, y, z per
// point per sample, little-endian), independently of the project's reader and writer, for tests
// that feed caches to scenes.
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "geometry/mesh.h"

namespace pd::test {

inline void append_le32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

inline void append_float(std::string& out, float f) {
  std::uint32_t bits;
  std::memcpy(&bits, &f, 4);
  append_le32(out, bits);
}

// The bytes of a PC2 file holding `samples` (each (points, 3), metres) from `start_frame` every
// `sample_rate` frames; `points` and `count` override the header's counts (to write bad headers).
inline std::string pc2_bytes(const std::vector<Positions>& samples, float start_frame = 0.0f,
                             float sample_rate = 1.0f, int version = 1, long points = -1, long count = -1) {
  std::string out("POINTCACHE2", 11);
  out.push_back('\0');
  append_le32(out, static_cast<std::uint32_t>(version));
  append_le32(out, static_cast<std::uint32_t>(points >= 0 ? points : samples.empty() ? 0 : samples.front().rows()));
  append_float(out, start_frame);
  append_float(out, sample_rate);
  append_le32(out, static_cast<std::uint32_t>(count >= 0 ? count : static_cast<long>(samples.size())));
  for (const Positions& x : samples)
    for (Eigen::Index i = 0; i < x.rows(); ++i)
      for (int a = 0; a < 3; ++a) append_float(out, static_cast<float>(x(i, a)));
  return out;
}

}  // namespace pd::test
