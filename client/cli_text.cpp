#include "cli_text.h"

#include "util/message_text.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

namespace pd::cli {
namespace {

// Escapes one character of a message: control characters and DEL as \n, \t, \r or \xHH.
void append_escaped(std::string& out, char c) {
  const auto u = static_cast<unsigned char>(c);
  if (c == '\n') {
    out += "\\n";
  } else if (c == '\t') {
    out += "\\t";
  } else if (c == '\r') {
    out += "\\r";
  } else if (u < 0x20 || u == 0x7f) {
    char buf[8];
    std::snprintf(buf, sizeof buf, "\\x%02x", u);
    out += buf;
  } else {
    out += c;
  }
}

bool is_digit(char c) { return c >= '0' && c <= '9'; }

// Whether `s` is a plain decimal real: [+-] (digits [. digits*] | . digits) [(e|E) [+-] digits].
bool is_decimal_real(const std::string& s) {
  std::size_t i = 0;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  std::size_t mantissa_digits = 0;
  while (i < s.size() && is_digit(s[i])) ++i, ++mantissa_digits;
  if (i < s.size() && s[i] == '.') {
    ++i;
    while (i < s.size() && is_digit(s[i])) ++i, ++mantissa_digits;
  }
  if (mantissa_digits == 0) return false;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    std::size_t exponent_digits = 0;
    while (i < s.size() && is_digit(s[i])) ++i, ++exponent_digits;
    if (exponent_digits == 0) return false;
  }
  return i == s.size();
}

}  // namespace

std::string echo(const std::string& text) { return escaped_for_message(text, kEchoChars); }

std::string one_line(const std::string& message, std::size_t max_chars) {
  std::string out;
  for (std::size_t i = 0; i < message.size() && i < max_chars; ++i) append_escaped(out, message[i]);
  if (message.size() > max_chars) out += "...";
  return out;
}

std::string range_text(int64_t lo, int64_t hi) { return std::to_string(lo) + ".." + std::to_string(hi); }

ParsedInteger parse_decimal_integer(const std::string& text, int64_t lo, int64_t hi, const std::string& allowed) {
  ParsedInteger r;
  const std::string tail = "; allowed: " + allowed;
  std::size_t i = (!text.empty() && (text[0] == '+' || text[0] == '-')) ? 1 : 0;
  const bool negative = i == 1 && text[0] == '-';
  if (i == text.size()) {
    r.problem = "'" + echo(text) + "' is not a decimal integer" + tail;
    return r;
  }
  for (std::size_t k = i; k < text.size(); ++k)
    if (!is_digit(text[k])) {
      r.problem = "'" + echo(text) + "' is not a decimal integer (digits only: no fraction, exponent or 0x)" + tail;
      return r;
    }
  // Accumulate as a magnitude with an overflow check (leading zeros are just zeros: "010" is 10).
  uint64_t magnitude = 0;
  constexpr uint64_t kLimit = static_cast<uint64_t>(std::numeric_limits<int64_t>::max()) + 1;  // |INT64_MIN|
  bool overflow = false;
  for (; i < text.size(); ++i) {
    const auto d = static_cast<uint64_t>(text[i] - '0');
    if (magnitude > (kLimit - d) / 10) {
      overflow = true;
      break;
    }
    magnitude = magnitude * 10 + d;
  }
  if (overflow || (!negative && magnitude == kLimit)) {
    r.problem = "'" + echo(text) + "' is out of range" + tail;
    return r;
  }
  const int64_t v = negative ? (magnitude == kLimit ? std::numeric_limits<int64_t>::min()
                                                    : -static_cast<int64_t>(magnitude))
                             : static_cast<int64_t>(magnitude);
  if (v < lo || v > hi) {
    r.problem = "'" + echo(text) + "' is out of range" + tail;
    return r;
  }
  r.value = v;
  return r;
}

ParsedReal parse_decimal_real(const std::string& text, double lo, bool lo_open, double hi, const std::string& allowed) {
  ParsedReal r;
  const std::string tail = "; allowed: " + allowed;
  if (!is_decimal_real(text)) {
    r.problem = "'" + echo(text) + "' is not a decimal number" + tail;
    return r;
  }
  errno = 0;
  const double v = std::strtod(text.c_str(), nullptr);
  if (!std::isfinite(v) || errno == ERANGE || v < lo || (lo_open && v == lo) || v > hi) {
    r.problem = "'" + echo(text) + "' is out of range" + tail;
    return r;
  }
  r.value = v;
  return r;
}

CLI::Validator decimal_integer(int64_t lo, int64_t hi, std::string allowed) {
  if (allowed.empty()) allowed = range_text(lo, hi);
  const std::string name = "INT in " + allowed;
  return CLI::Validator(
      [lo, hi, allowed](std::string& text) -> std::string {
        const ParsedInteger p = parse_decimal_integer(text, lo, hi, allowed);
        if (!p.problem.empty()) return p.problem;
        text = std::to_string(p.value);  // canonical: what CLI11's base-0 conversion reads as decimal
        return "";
      },
      name);
}

CLI::Validator decimal_real(double lo, bool lo_open, double hi, const std::string& allowed) {
  return CLI::Validator(
      [lo, lo_open, hi, allowed](std::string& text) -> std::string {
        const ParsedReal p = parse_decimal_real(text, lo, lo_open, hi, allowed);
        return p.problem;
      },
      "NUMBER in " + allowed);
}

CLI::Validator one_of(const std::vector<std::string>& words) {
  std::string allowed;
  for (const std::string& w : words) allowed += (allowed.empty() ? "" : ", ") + w;
  return CLI::Validator(
      [words, allowed](std::string& text) -> std::string {
        for (const std::string& w : words)
          if (text == w) return "";
        return "'" + echo(text) + "' is not a known value; allowed: " + allowed;
      },
      allowed);
}

CLI::Validator non_empty(const std::string& absent) {
  return CLI::Validator(
      [absent](std::string& text) -> std::string {
        return text.empty() ? "an empty value; leave the option out for " + absent : "";
      },
      "");
}

std::string parse_error_text(const CLI::ParseError& e) {
  // Escape first (one line), then cut every space-free run longer than an echo: CLI11 repeats
  // unexpected arguments and bad values whole.
  const std::string escaped = one_line(e.what(), std::numeric_limits<std::size_t>::max());
  std::string out, word;
  const auto flush_word = [&] {
    out += word.size() > kEchoChars ? word.substr(0, kEchoChars) + "...(" + std::to_string(word.size()) + " chars)"
                                    : word;
    word.clear();
  };
  for (const char c : escaped) {
    if (c == ' ') {
      flush_word();
      out += c;
    } else {
      word += c;
    }
  }
  flush_word();
  return one_line(out);
}

}  // namespace pd::cli
