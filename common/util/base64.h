#pragma once
// Base64 (RFC 4648, standard alphabet, '=' padding) for bytes that must travel inside JSON text: a
// JSON string holds UTF-8 text only, and a scene's PC2 cache is binary. Boost.Archive's dataflow
// iterators do the 6/8-bit regrouping; this file adds the padding they leave to the caller.
#include <optional>
#include <string>
#include <string_view>

namespace pd {

std::string base64_encode(std::string_view bytes);
// The bytes, or nothing for text that is not padded base64 (a length that is not a multiple of 4, a
// character outside the alphabet, padding anywhere but the last two places).
std::optional<std::string> base64_decode(std::string_view text);

// True when every byte is printable ASCII or tab, CR, LF: text that a JSON string carries as it is
// (OBJ files). Anything else is sent as base64.
bool is_plain_text(std::string_view bytes);

}  // namespace pd
