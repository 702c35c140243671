#include "util/base64.h"

#include <algorithm>

#include <boost/archive/iterators/base64_from_binary.hpp>
#include <boost/archive/iterators/binary_from_base64.hpp>
#include <boost/archive/iterators/transform_width.hpp>

namespace pd {

namespace it = boost::archive::iterators;

std::string base64_encode(std::string_view bytes) {
  using Encoder = it::base64_from_binary<it::transform_width<std::string_view::const_iterator, 6, 8>>;
  std::string out(Encoder(bytes.begin()), Encoder(bytes.end()));
  out.append((3 - bytes.size() % 3) % 3, '=');
  return out;
}

std::optional<std::string> base64_decode(std::string_view text) {
  if (text.size() % 4 != 0) return std::nullopt;
  std::size_t pad = 0;
  while (pad < 2 && pad < text.size() && text[text.size() - 1 - pad] == '=') ++pad;
  const auto valid = [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '/';
  };
  if (!std::all_of(text.begin(), text.end() - static_cast<std::ptrdiff_t>(pad), valid)) return std::nullopt;
  // The decoder reads whole characters only: the padding is decoded as 'A' (zero bits) and its bytes cut.
  std::string body(text);
  std::fill(body.end() - static_cast<std::ptrdiff_t>(pad), body.end(), 'A');
  using Decoder = it::transform_width<it::binary_from_base64<std::string::const_iterator>, 8, 6>;
  std::string out(Decoder(body.cbegin()), Decoder(body.cend()));
  out.resize(out.size() - pad);
  return out;
}

bool is_plain_text(std::string_view bytes) {
  return std::all_of(bytes.begin(), bytes.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return (u >= 0x20 && u < 0x7f) || u == '\t' || u == '\n' || u == '\r';
  });
}

}  // namespace pd
