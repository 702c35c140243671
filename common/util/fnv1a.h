#pragma once
// 64-bit FNV-1a over a canonical byte stream: the content hashes of hierarchies (the cache key of
// scene_hierarchy.h, stored in frame files) and the benchmarks' result hashes. Not cryptographic; it
// tells apart inputs or results that differ in any bit (doubles are hashed as their 8 bytes, so
// -0.0 and 0.0, or two NaNs with different payloads, hash apart).

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace pd {

class Fnv1a {
 public:
  void bytes(const void* data, std::size_t size) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
      h_ ^= p[i];
      h_ *= 0x100000001b3ULL;  // the 64-bit FNV prime
    }
  }
  // Integers as 8 little- or big-endian bytes, as the machine stores them (the hashes compare runs on
  // one architecture family; every machine here is x86-64).
  void i64(long long v) {
    const std::int64_t x = v;
    bytes(&x, sizeof x);
  }
  void f64(double v) { bytes(&v, sizeof v); }
  // Length first, so that ("ab", "c") and ("a", "bc") hash apart.
  void str(const std::string& s) {
    i64(static_cast<long long>(s.size()));
    bytes(s.data(), s.size());
  }
  std::uint64_t value() const { return h_; }
  // 16 lower-case hex digits.
  std::string hex() const {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h_));
    return buf;
  }

 private:
  std::uint64_t h_ = 0xcbf29ce484222325ULL;  // the 64-bit FNV offset basis
};

}  // namespace pd
