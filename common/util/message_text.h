#pragma once
// Echoing user-supplied text (names, keys, paths, option values) inside one-line error messages.
//
// User text can be 100 000 characters long, hold newlines or NUL bytes, or be invalid UTF-8; printed
// verbatim it floods the terminal, splits the one-line message "pd: error: <file>: <key>: <problem>"
// or hides what was wrong. These helpers make any byte string safe to print on one line.
#include <cstddef>
#include <string>
#include <string_view>

namespace pd {

// The longest echo error messages use by default, in characters of the input.
constexpr std::size_t kMessageTextMaxChars = 80;

// `s` escaped for a one-line message, at most `max_chars` characters of it shown:
//   - `\n`, `\r`, `\t`, `\\`, `\"` as those two-character escapes; every other control character (NUL,
//     0x01-0x1f, DEL) and every byte that is not part of valid UTF-8 as `\xHH` (two hex digits);
//   - valid UTF-8 sequences kept as they are, each counting as one character;
//   - when `s` has more than `max_chars` characters: the first `max_chars` of them, then
//     "...(N chars)" with N the length of `s` in bytes.
// Never cuts an escape or a UTF-8 sequence in two.
std::string escaped_for_message(std::string_view s, std::size_t max_chars = kMessageTextMaxChars);

// escaped_for_message in double quotes; a cut string reads  "abc..."(100000 chars).
//   quoted_for_message("a\nb")  ->  "a\nb"   (backslash-n, no line break)
std::string quoted_for_message(std::string_view s, std::size_t max_chars = kMessageTextMaxChars);

// A number as a message shows it: up to 10 significant digits, no trailing zeros ("0.25", "1e+06").
std::string number_for_message(double x);

}  // namespace pd
