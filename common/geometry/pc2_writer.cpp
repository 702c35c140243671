#include "geometry/pc2_writer.h"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include "util/input_error.h"

namespace pd {
namespace {

// Little-endian bytes of a 32-bit word, whatever the host's byte order (PC2 is little-endian).
void put_u32(unsigned char* p, uint32_t v) {
  p[0] = static_cast<unsigned char>(v & 0xffu);
  p[1] = static_cast<unsigned char>((v >> 8) & 0xffu);
  p[2] = static_cast<unsigned char>((v >> 16) & 0xffu);
  p[3] = static_cast<unsigned char>((v >> 24) & 0xffu);
}

void put_i32(unsigned char* p, int32_t v) {
  uint32_t u;
  std::memcpy(&u, &v, 4);
  put_u32(p, u);
}

void put_f32(unsigned char* p, float v) {
  static_assert(sizeof(float) == 4 && std::numeric_limits<float>::is_iec559, "PC2 stores IEEE 754 binary32");
  uint32_t u;
  std::memcpy(&u, &v, 4);
  put_u32(p, u);
}

}  // namespace

Eigen::Index first_non_float32(const Positions& x, Eigen::Index first_row, Eigen::Index rows) {
  const double max = static_cast<double>(std::numeric_limits<float>::max());
  const double* d = x.data() + 3 * first_row;
  for (Eigen::Index i = 0; i < 3 * rows; ++i)
    if (!std::isfinite(d[i]) || std::abs(d[i]) > max) return 3 * first_row + i;
  return -1;
}

Pc2Writer::Pc2Writer(std::string path, int num_points, float start_frame, float sample_rate, int num_samples)
    : path_(std::move(path)), num_points_(num_points), num_samples_(num_samples) {
  out_ = std::fopen(path_.c_str(), "wb");
  if (!out_) throw InputError(path_ + ": cannot write: " + std::strerror(errno));
  unsigned char h[kPc2HeaderBytes] = {};
  std::memcpy(h, "POINTCACHE2", 12);  // 11 characters and the terminating NUL
  put_i32(h + 12, 1);                 // file version
  put_i32(h + 16, num_points);
  put_f32(h + 20, start_frame);
  put_f32(h + 24, sample_rate);
  put_i32(h + 28, num_samples);
  write(h, sizeof h);
}

Pc2Writer::~Pc2Writer() {
  if (out_) std::fclose(out_);  // after an error: the caller's temporary folder is removed anyway
}

void Pc2Writer::write(const void* bytes, std::size_t n) {
  if (std::fwrite(bytes, 1, n, out_) != n) throw InputError(path_ + ": cannot write: " + std::strerror(errno));
}

void Pc2Writer::add_sample(const Positions& x, Eigen::Index first_row, const std::string& what) {
  if (written_ == num_samples_)
    throw InputError(path_ + ": " + what + ": more samples than the " + std::to_string(num_samples_) +
                     " in the header");
  if (const Eigen::Index bad = first_non_float32(x, first_row, num_points_); bad >= 0)
    throw InputError(path_ + ": " + what + ": vertex " + std::to_string(bad / 3 - first_row) +
                     ": a coordinate is not finite or beyond float32 range");
  std::vector<unsigned char> buf(static_cast<std::size_t>(num_points_) * 12);
  const double* d = x.data() + 3 * first_row;
  for (std::size_t i = 0; i < static_cast<std::size_t>(num_points_) * 3; ++i)
    put_f32(buf.data() + 4 * i, static_cast<float>(d[i]));
  write(buf.data(), buf.size());
  ++written_;
}

void Pc2Writer::close() {
  if (written_ != num_samples_)
    throw InputError(path_ + ": " + std::to_string(written_) + " samples written, the header says " +
                     std::to_string(num_samples_));
  std::FILE* f = std::exchange(out_, nullptr);
  if (std::fclose(f) != 0) throw InputError(path_ + ": cannot write: " + std::strerror(errno));
}

}  // namespace pd
