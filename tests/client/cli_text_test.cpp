// client/cli_text: echoes of user values and the decimal number validators (called in-process; the
// pd binary's one-line messages are checked end to end in pd_cli_test.cpp).
#include "cli_text.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>

namespace pd::cli {
namespace {

TEST(CliText, EchoCutsLongValuesAndSaysHowLongTheyWere) {
  const std::string e = echo(std::string(100000, 'x'));
  EXPECT_EQ(e, std::string(kEchoChars, 'x') + "...(100000 chars)");
  EXPECT_EQ(echo(std::string(kEchoChars, 'y')), std::string(kEchoChars, 'y'));  // exactly the limit: whole
}

TEST(CliText, EchoEscapesControlCharactersSoMessagesStayOneLine) {
  EXPECT_EQ(echo(std::string("a\nb\tc\rd\x1b[31m\x7f", 13)), "a\\nb\\tc\\rd\\x1b[31m\\x7f");
  EXPECT_EQ(echo(std::string("nul\0byte", 8)), "nul\\x00byte");
  EXPECT_EQ(one_line("two\nlines"), "two\\nlines");
  EXPECT_EQ(one_line(std::string(50, 'z'), 10), std::string(10, 'z') + "...");
}

TEST(CliText, IntegersAreDecimalWithLeadingZerosAndNoOctalOrHex) {
  EXPECT_EQ(parse_decimal_integer("010", 1, 100, "1..100").value, 10);  // not octal 8
  EXPECT_EQ(parse_decimal_integer("+7", 1, 100, "1..100").value, 7);
  EXPECT_EQ(parse_decimal_integer("-0", -5, 5, "-5..5").value, 0);
  for (const char* bad : {"0x10", "1e3", "1.0", "", " 5", "5 ", "+", "-", "0b1", "٣"}) {
    const ParsedInteger p = parse_decimal_integer(bad, 1, 100, "1..100");
    EXPECT_NE(p.problem.find("is not a decimal integer"), std::string::npos) << "'" << bad << "': " << p.problem;
    EXPECT_NE(p.problem.find("; allowed: 1..100"), std::string::npos) << p.problem;
  }
}

TEST(CliText, IntegersOutsideTheRangeOrInt64AreRefusedWithTheShortRange) {
  EXPECT_EQ(parse_decimal_integer("9223372036854775807", 1, INT64_MAX, "x").value, INT64_MAX);
  EXPECT_EQ(parse_decimal_integer("-9223372036854775808", INT64_MIN, 0, "x").value, INT64_MIN);
  for (const char* bad : {"9223372036854775808", "-9223372036854775809", "99999999999999999999999999", "0", "101"}) {
    const ParsedInteger p = parse_decimal_integer(bad, 1, 100, range_text(1, 100));
    EXPECT_NE(p.problem.find("is out of range; allowed: 1..100"), std::string::npos) << bad << ": " << p.problem;
  }
}

TEST(CliText, RealsAreFiniteDecimalNumbersInTheirRange) {
  EXPECT_DOUBLE_EQ(parse_decimal_real("0.5", 0, true, 10, "x").value, 0.5);
  EXPECT_DOUBLE_EQ(parse_decimal_real("1e-3", 0, true, 10, "x").value, 1e-3);
  EXPECT_DOUBLE_EQ(parse_decimal_real(".25", 0, true, 10, "x").value, 0.25);
  for (const char* bad : {"0x1p3", "inf", "nan", "1e", "e3", ".", "1..2", ""})
    EXPECT_NE(parse_decimal_real(bad, 0, true, 10, "x").problem.find("not a decimal number"), std::string::npos)
        << bad;
  for (const char* bad : {"0", "-1", "11", "1e400"})
    EXPECT_NE(parse_decimal_real(bad, 0, true, 10, "x").problem.find("out of range"), std::string::npos) << bad;
}

TEST(CliText, ValidatorsRewriteToCanonicalDecimalForCli11) {
  CLI::App app;
  int frames = 0;
  int64_t job = 0;
  app.add_option("--frames", frames)->transform(decimal_integer(1, 1000));
  app.add_option("--job", job)->transform(decimal_integer(1, INT64_MAX, "a positive integer"));
  app.parse("--frames 010 --job 0000012", false);
  EXPECT_EQ(frames, 10);  // CLI11 alone reads "010" as octal 8
  EXPECT_EQ(job, 12);
  try {
    app.parse("--frames 0x10", false);
    ADD_FAILURE() << "0x10 accepted";
  } catch (const CLI::ParseError& e) {
    EXPECT_EQ(parse_error_text(e).rfind("--frames: '0x10' is not a decimal integer", 0), 0u) << e.what();
  }
}

TEST(CliText, AnEmptyValueIsRefusedWhereLeavingTheOptionOutMeansADefault) {
  CLI::App app;
  std::string csv = "unset";
  app.add_option("--csv", csv)->check(non_empty("FILE.compare.csv"));
  app.parse("--csv out.csv", false);
  EXPECT_EQ(csv, "out.csv");
  try {
    std::vector<std::string> args = {"", "--csv"};  // CLI11 reads the vector from its back
    app.parse(args);
    ADD_FAILURE() << "an empty --csv accepted";
  } catch (const CLI::ParseError& e) {
    EXPECT_NE(parse_error_text(e).find("--csv: an empty value; leave the option out for FILE.compare.csv"),
              std::string::npos)
        << e.what();
  }
}

TEST(CliText, ParseErrorTextCutsOverlongWords) {
  const CLI::ExtrasError e({std::string(5000, 'q')});
  const std::string text = parse_error_text(e);
  EXPECT_LT(text.size(), 300u) << text;
  EXPECT_NE(text.find("(5000 chars)"), std::string::npos) << text;
}

}  // namespace
}  // namespace pd::cli
