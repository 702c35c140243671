#include "util/fnv1a.h"

#include <gtest/gtest.h>

namespace pd {
namespace {

// The published FNV-1a 64-bit test vectors (the empty input is the offset basis).
TEST(Fnv1a, MatchesThePublishedTestVectors) {
  EXPECT_EQ(Fnv1a().hex(), "cbf29ce484222325");
  Fnv1a a;
  a.bytes("a", 1);
  EXPECT_EQ(a.hex(), "af63dc4c8601ec8c");
  Fnv1a foobar;
  foobar.bytes("foobar", 6);
  EXPECT_EQ(foobar.value(), 0x85944171f73967e8ULL);
}

TEST(Fnv1a, StringsCarryTheirLengthSoSplitsHashApart) {
  Fnv1a ab_c, a_bc;
  ab_c.str("ab");
  ab_c.str("c");
  a_bc.str("a");
  a_bc.str("bc");
  EXPECT_NE(ab_c.value(), a_bc.value());
}

TEST(Fnv1a, DoublesHashBitForBit) {
  Fnv1a zero, negative_zero, zero_again;
  zero.f64(0.0);
  negative_zero.f64(-0.0);
  zero_again.f64(0.0);
  EXPECT_NE(zero.value(), negative_zero.value());
  EXPECT_EQ(zero.value(), zero_again.value());
}

}  // namespace
}  // namespace pd
