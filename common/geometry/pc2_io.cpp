#include "geometry/pc2_io.h"

#include <cerrno>
#include <cmath>
#include <cstring>

#include "geometry/regular_file.h"
#include "util/input_error.h"

namespace pd {
namespace {

constexpr std::uintmax_t kHeaderBytes = 32;

// Little-endian fields of the header (every machine here is little-endian x86-64, but the format is
// defined in bytes, so decode it as bytes).
std::int32_t int32_at(const unsigned char* p) {
  const std::uint32_t u = static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
                          static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
  std::int32_t v;
  std::memcpy(&v, &u, sizeof v);
  return v;
}

float float32_at(const unsigned char* p) {
  const std::int32_t bits = int32_at(p);
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

void read_exactly(std::FILE* in, unsigned char* into, std::size_t bytes, const std::string& path) {
  if (std::fread(into, 1, bytes, in) != bytes)
    throw InputError(path + ": read error: " + (std::ferror(in) ? std::strerror(errno) : "the file ended early"));
}

}  // namespace

Pc2Cache read_pc2(const std::string& path, const Pc2Limits& limits) {
  std::uintmax_t size = 0;
  std::FILE* in = open_regular_file(path, limits.max_bytes, "a PC2 file", &size);
  const FileCloser closer{in};
  if (size < kHeaderBytes)
    throw InputError(path + ": the file has " + std::to_string(size) + " bytes, less than a PC2 header's 32");
  unsigned char header[kHeaderBytes];
  read_exactly(in, header, kHeaderBytes, path);
  if (std::memcmp(header, "POINTCACHE2\0", 12) != 0)
    throw InputError(path + ": signature: not \"POINTCACHE2\" (not a PC2 point cache)");
  const std::int32_t version = int32_at(header + 12), points = int32_at(header + 16),
                     samples = int32_at(header + 28);
  if (version != 1) throw InputError(path + ": file version: " + std::to_string(version) + ", this reader reads 1");
  if (points <= 0) throw InputError(path + ": number of points: " + std::to_string(points) + ", must be > 0");
  if (samples <= 0) throw InputError(path + ": number of samples: " + std::to_string(samples) + ", must be > 0");
  Pc2Cache cache;
  cache.start_frame = float32_at(header + 20);
  cache.sample_rate = float32_at(header + 24);
  if (!std::isfinite(cache.start_frame)) throw InputError(path + ": start frame: not finite");
  if (!(cache.sample_rate > 0.0f) || !std::isfinite(cache.sample_rate))
    throw InputError(path + ": sample rate: " + std::to_string(cache.sample_rate) + ", must be finite and > 0");
  // Both counts are below 2^31, so the product fits in 64 bits.
  const std::uintmax_t body = 12u * static_cast<std::uintmax_t>(points) * static_cast<std::uintmax_t>(samples);
  if (size != kHeaderBytes + body)
    throw InputError(path + ": the file has " + std::to_string(size) + " bytes; its header (" + std::to_string(points) +
                     " points x " + std::to_string(samples) + " samples) needs " + std::to_string(kHeaderBytes + body));
  std::vector<unsigned char> buffer(12u * static_cast<std::size_t>(points));
  cache.samples.reserve(static_cast<std::size_t>(samples));
  for (std::int32_t s = 0; s < samples; ++s) {
    read_exactly(in, buffer.data(), buffer.size(), path);
    Positions x(points, 3);
    for (std::int32_t p = 0; p < points; ++p)
      for (int axis = 0; axis < 3; ++axis) {
        const std::size_t at = 12u * static_cast<std::size_t>(p) + 4u * static_cast<std::size_t>(axis);
        const float v = float32_at(buffer.data() + at);
        if (!std::isfinite(v))
          throw InputError(path + ": sample " + std::to_string(s) + ", point " + std::to_string(p) + ", " +
                           "xyz"[axis] + " (byte " +
                           std::to_string(kHeaderBytes + 12u * static_cast<std::uintmax_t>(points) * s + at) +
                           "): not finite");
        x(p, axis) = v;
      }
    cache.samples.push_back(std::move(x));
  }
  return cache;
}

}  // namespace pd
