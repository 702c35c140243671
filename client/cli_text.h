#pragma once
// Command-line text of the pd client: how values the user typed are echoed in messages, and the
// CLI11 validators of its numeric and word options, so that every command-line error is ONE line
//   pd: error: <option>: <problem>; allowed: <values or range>
// (main.cpp prints CLI11's message after "pd: error: "; CLI11 puts "<option>: " in front of a
// validator's text).
//
// Numbers are decimal only. CLI11 2.1 converts integers with strtoll(..., base 0), which reads "010"
// as octal 8 and accepts "0x10"; the validators here run first (as transforms), refuse anything but
// [+-]digits (or a plain decimal number for real options) and rewrite the text to its canonical
// decimal form ("010" -> "10"), so CLI11's conversion only ever sees plain decimal digits.
//
// Echoes share common/util/message_text.h with the scene files' messages.
#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace pd::cli {

// Longest echo of a user value, in characters before escaping (longer ones end in "...").
constexpr std::size_t kEchoChars = 80;
// Most frames a command line may ask for: the scene format's own limit for "frames"
// (docs/scene-format.md), so --frames can never ask for more than a scene could.
constexpr int64_t kMaxFrames = 10000000;
// Most hierarchy levels (docs/scene-format.md, hierarchy.levels).
constexpr int64_t kMaxLevels = 20;

// `text` for a message: util/message_text.h's escaped_for_message cut to kEchoChars characters
// (then "...(N chars)"), control characters as \n, \t, \r or \xHH. Never contains a newline, so a
// message that echoes it stays one line.
std::string echo(const std::string& text);

// A whole message for stderr: control characters escaped (one line), cut to `max_chars`.
std::string one_line(const std::string& message, std::size_t max_chars = 1000);

// The integer written in `text` when it is [+-]digits (leading zeros allowed, decimal) and within
// [lo, hi]; else the problem as "<problem>; allowed: <allowed>". Exactly one of value / problem set.
struct ParsedInteger {
  int64_t value = 0;
  std::string problem;
};
ParsedInteger parse_decimal_integer(const std::string& text, int64_t lo, int64_t hi, const std::string& allowed);

// Same for a real number: [+-]digits[.digits][e[+-]digits] (or .digits...), finite, within [lo, hi]
// (lo excluded when lo_open). No hex floats, inf or nan.
struct ParsedReal {
  double value = 0.0;
  std::string problem;
};
ParsedReal parse_decimal_real(const std::string& text, double lo, bool lo_open, double hi, const std::string& allowed);

// "1..2147483647" style range text.
std::string range_text(int64_t lo, int64_t hi);

// Transform validators (use with Option::transform): decimal integer in [lo, hi], `allowed` is how the
// message states the range (default range_text(lo, hi)); decimal real; one word of `words`.
CLI::Validator decimal_integer(int64_t lo, int64_t hi, std::string allowed = "");
CLI::Validator decimal_real(double lo, bool lo_open, double hi, const std::string& allowed);
CLI::Validator one_of(const std::vector<std::string>& words);
// Refuses an empty value (a check validator): for options whose absence means a default, so that
// `--csv ''` is an error instead of the default in disguise. `absent` says what leaving it out does.
CLI::Validator non_empty(const std::string& absent);

// The one-line text of a CLI11 parse error (without "pd: error: "): CLI11's message with control
// characters escaped and overlong user values (e.g. unexpected arguments) cut.
std::string parse_error_text(const CLI::ParseError& e);

}  // namespace pd::cli
