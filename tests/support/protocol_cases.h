#pragma once
// Helpers shared by the protocol tests (tests/protocol/): error texts, header edits and the checks
// that run over every field of a message. Family-specific behaviour comes in as the decoder to use.
#include <gtest/gtest.h>

#include <exception>
#include <functional>
#include <string>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "protocol/protocol.h"

namespace pd::protocol::test {

// The JSON of part 0, with its keys in the order they were written (as protocol/wire.h keeps them).
using Json = nlohmann::ordered_json;

// One family's decoder (decode_command, decode_report, ...); its result is not looked at.
using Decode = std::function<void(const Parts&)>;

// The ProtocolError message of f(), or a text saying what happened instead (another exception or none).
template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const ProtocolError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("(not a ProtocolError: ") + e.what() + ")";
  }
  return "(no ProtocolError thrown)";
}

// The ProtocolError message of decoding parts with decode, or a text saying what happened instead.
std::string error_of(const Parts& parts, const Decode& decode);

// Whether text contains part; on failure says both.
::testing::AssertionResult has(const std::string& text, const std::string& part);

// Whether a and b hold the same doubles bit for bit (signed zeros, NaN payloads and all).
bool same_bits(const std::vector<double>& a, const std::vector<double>& b);

// Whether a and b are the same double bit for bit.
bool same_bits(double a, double b);

// Part 0 of p parsed as JSON.
Json header(const Parts& p);

// p with part 0 replaced by h.
Parts with_header(Parts p, const Json& h);

// p with the top-level field name of part 0 set to value (added if it was not there).
Parts with_field(const Parts& p, const std::string& name, const Json& value);

// Erases each field of the JSON object at `pointer` inside part 0 ("" is part 0 itself, whose "v" and
// "type" are left alone); decode must say that field, named `prefix` + key, is missing. Returns the
// number of fields checked.
int check_every_field_required(const Parts& parts, const Decode& decode, const std::string& pointer = "",
                               const std::string& prefix = "");

// Replaces each field of the object at `pointer` (as above) with a value of another JSON type; decode
// must name that field and say what it expected. Returns the number of fields checked.
int check_every_field_typed(const Parts& parts, const Decode& decode, const std::string& pointer = "",
                            const std::string& prefix = "");

// Encodes m alone and as the family's Variant (the two must give the same parts), decodes the parts
// with decode (which returns a Variant) and returns the alternative, which must be a T.
template <typename Variant, typename T, typename DecodeAs>
T round_trip(const T& m, DecodeAs&& decode) {
  const Parts parts = encode(m);
  EXPECT_EQ(parts, encode(Variant{m}));  // the variant overload encodes the same parts
  const Variant v = decode(parts);
  EXPECT_TRUE(std::holds_alternative<T>(v));
  return std::get<T>(v);
}

}  // namespace pd::protocol::test
