// base64_encode / base64_decode against RFC 4648's test vectors, every length of random bytes, and
// the inputs the decoder must refuse.
#include "util/base64.h"

#include <random>

#include <gtest/gtest.h>

namespace pd {
namespace {

TEST(Base64, Rfc4648VectorsEncodeAndDecode) {
  const std::pair<const char*, const char*> vectors[] = {{"", ""},         {"f", "Zg=="},     {"fo", "Zm8="},
                                                         {"foo", "Zm9v"},  {"foob", "Zm9vYg=="}, {"fooba", "Zm9vYmE="},
                                                         {"foobar", "Zm9vYmFy"}};
  for (const auto& [bytes, text] : vectors) {
    EXPECT_EQ(base64_encode(bytes), text);
    EXPECT_EQ(base64_decode(text), std::string(bytes));
  }
}

TEST(Base64, EveryLengthOfRandomBytesRoundTrips) {
  std::mt19937 rng(7);
  int checked = 0;
  for (std::size_t n = 0; n < 64; ++n) {
    std::string bytes(n, '\0');
    for (char& c : bytes) c = static_cast<char>(rng() & 0xff);
    EXPECT_EQ(base64_decode(base64_encode(bytes)), bytes) << n;
    ++checked;
  }
  EXPECT_EQ(checked, 64);
}

TEST(Base64, MalformedTextIsRefused) {
  for (const char* bad : {"Zg=", "Zm9", "Zm*v", "Z===", "=Zm9", "Zg==Zg==", "Zm 9v"}) EXPECT_FALSE(base64_decode(bad)) << bad;
}

TEST(Base64, PlainTextIsPrintableAsciiAndLineBreaks) {
  EXPECT_TRUE(is_plain_text("v 0.5 1 2\r\n\tf 1 2 3\n"));
  EXPECT_FALSE(is_plain_text(std::string("a\0b", 3)));
  EXPECT_FALSE(is_plain_text("caf\xc3\xa9"));
  EXPECT_FALSE(is_plain_text("\x7f"));
}

}  // namespace
}  // namespace pd
