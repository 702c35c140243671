// quoted_for_message / escaped_for_message: user text echoed in error messages stays on one line,
// readable and short, whatever bytes it holds.
#include "util/message_text.h"

#include <gtest/gtest.h>

#include <string>

namespace pd {
namespace {

using namespace std::string_literals;

TEST(MessageText, ShortPrintableTextIsQuotedUnchanged) {
  EXPECT_EQ(quoted_for_message("sheet"), "\"sheet\"");
  EXPECT_EQ(quoted_for_message(""), "\"\"");
  EXPECT_EQ(escaped_for_message("objects[0].name"), "objects[0].name");
}

TEST(MessageText, ControlCharactersAndNulAreEscaped) {
  EXPECT_EQ(quoted_for_message("a\nb\rc\td"), "\"a\\nb\\rc\\td\"");
  EXPECT_EQ(quoted_for_message("a\0b"s), "\"a\\x00b\"");
  EXPECT_EQ(quoted_for_message("\x01\x1f\x7f"), "\"\\x01\\x1f\\x7f\"");
  EXPECT_EQ(quoted_for_message("say \"hi\" \\o/"), "\"say \\\"hi\\\" \\\\o/\"");
  // Nothing that could end the line or the quote survives.
  const std::string out = quoted_for_message("x\n\r\0\"y"s);
  EXPECT_EQ(out.find('\n'), std::string::npos);
  EXPECT_EQ(out.find('\r'), std::string::npos);
  EXPECT_EQ(out.find('\0'), std::string::npos);
}

TEST(MessageText, ValidUtf8IsKeptAndInvalidBytesAreEscaped) {
  EXPECT_EQ(quoted_for_message("Fl\xc3\xa4" "che \xe2\x82\xac"), "\"Fl\xc3\xa4" "che \xe2\x82\xac\"");
  EXPECT_EQ(quoted_for_message("\xf0\x9f\x98\x80"), "\"\xf0\x9f\x98\x80\"");       // U+1F600
  EXPECT_EQ(quoted_for_message("a\xff" "b"), "\"a\\xffb\"");                       // never valid
  EXPECT_EQ(quoted_for_message("\xc3"), "\"\\xc3\"");                              // truncated sequence
  EXPECT_EQ(quoted_for_message("\xc0\xaf"), "\"\\xc0\\xaf\"");                     // overlong '/'
  EXPECT_EQ(quoted_for_message("\xed\xa0\x80"), "\"\\xed\\xa0\\x80\"");            // surrogate
}

TEST(MessageText, LongTextIsCutWithItsLength) {
  const std::string name(100000, 'n');
  const std::string out = quoted_for_message(name);
  EXPECT_EQ(out, "\"" + std::string(80, 'n') + "...\"(100000 chars)");
  EXPECT_EQ(escaped_for_message(name, 5), "nnnnn...(100000 chars)");
  // Exactly max_chars characters: not cut.
  EXPECT_EQ(quoted_for_message(std::string(80, 'x')), "\"" + std::string(80, 'x') + "\"");
  EXPECT_EQ(quoted_for_message("abcdef", 0), "\"...\"(6 chars)");
}

TEST(MessageText, CutCountsEscapesAndUtf8SequencesAsOneCharacterAndNeverSplitsThem) {
  // Three characters shown: an escape, a two-byte sequence, a plain letter.
  EXPECT_EQ(escaped_for_message("\n\xc3\xa4xyz", 3), "\\n\xc3\xa4x...(6 chars)");
  EXPECT_EQ(escaped_for_message("\xe2\x82\xac\xe2\x82\xac", 1), "\xe2\x82\xac...(6 chars)");
}

TEST(MessageText, NumbersShowTenSignificantDigitsWithoutTrailingZeros) {
  EXPECT_EQ(number_for_message(0.25), "0.25");
  EXPECT_EQ(number_for_message(1e6), "1000000");
  EXPECT_EQ(number_for_message(1e12), "1e+12");
  EXPECT_EQ(number_for_message(3.14159265358979), "3.141592654");
  EXPECT_EQ(number_for_message(-0.0005), "-0.0005");
}

}  // namespace
}  // namespace pd
