#include "util/message_text.h"

#include <sstream>

namespace pd {
namespace {

// Length of the valid UTF-8 sequence starting at s[i], or 0 when the bytes there are not one
// (overlong forms, surrogates and code points above U+10FFFF count as invalid).
std::size_t utf8_length(std::string_view s, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char b0 = byte(i);
  std::size_t n = 0;
  unsigned int code = 0;
  if (b0 >= 0xc2 && b0 <= 0xdf) {
    n = 2, code = b0 & 0x1f;
  } else if (b0 >= 0xe0 && b0 <= 0xef) {
    n = 3, code = b0 & 0x0f;
  } else if (b0 >= 0xf0 && b0 <= 0xf4) {
    n = 4, code = b0 & 0x07;
  } else {
    return 0;
  }
  if (i + n > s.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xc0) != 0x80) return 0;
    code = (code << 6) | (byte(i + k) & 0x3f);
  }
  if ((n == 3 && code < 0x800) || (n == 4 && (code < 0x10000 || code > 0x10ffff))) return 0;
  if (code >= 0xd800 && code <= 0xdfff) return 0;
  return n;
}

void append_hex(std::string& out, unsigned char b) {
  const char* digits = "0123456789abcdef";
  out += "\\x";
  out += digits[b >> 4];
  out += digits[b & 0x0f];
}

// Appends the escaped first `max_chars` characters of `s` to `out`; returns whether `s` was cut.
bool append_escaped(std::string& out, std::string_view s, std::size_t max_chars) {
  std::size_t shown = 0;  // characters of `s` written so far
  std::size_t i = 0;
  while (i < s.size() && shown < max_chars) {
    const unsigned char b = static_cast<unsigned char>(s[i]);
    std::size_t step = 1;
    switch (b) {
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      case '\\': out += "\\\\"; break;
      case '"': out += "\\\""; break;
      default:
        if (b < 0x20 || b == 0x7f) {
          append_hex(out, b);
        } else if (b < 0x80) {
          out += static_cast<char>(b);
        } else if (std::size_t n = utf8_length(s, i); n > 0) {
          out.append(s.substr(i, n));
          step = n;
        } else {
          append_hex(out, b);
        }
    }
    i += step;
    ++shown;
  }
  return i < s.size();
}

std::string length_note(std::string_view s) { return "(" + std::to_string(s.size()) + " chars)"; }

}  // namespace

std::string escaped_for_message(std::string_view s, std::size_t max_chars) {
  std::string out;
  if (append_escaped(out, s, max_chars)) out += "..." + length_note(s);
  return out;
}

std::string quoted_for_message(std::string_view s, std::size_t max_chars) {
  std::string out = "\"";
  const bool cut = append_escaped(out, s, max_chars);
  // The length goes after the closing quote, so the quoted part is only what the input holds.
  out += cut ? "...\"" + length_note(s) : "\"";
  return out;
}

std::string number_for_message(double x) {
  std::ostringstream out;
  out.precision(10);
  out << x;
  return out.str();
}

}  // namespace pd
