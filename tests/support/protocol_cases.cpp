#include "support/protocol_cases.h"

#include <cstring>

namespace pd::protocol::test {

std::string error_of(const Parts& parts, const Decode& decode) {
  return error_of([&] { decode(parts); });
}

::testing::AssertionResult has(const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "'" << text << "' does not contain '" << part << "'";
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

Json header(const Parts& p) { return Json::parse(p.at(0)); }

Parts with_header(Parts p, const Json& h) {
  p.at(0) = h.dump();
  return p;
}

Parts with_field(const Parts& p, const std::string& name, const Json& value) {
  Json h = header(p);
  h[name] = value;
  return with_header(p, h);
}

namespace {

// Calls f(h, key, value) for each field of the object at `pointer` inside h, part 0 of parts
// ("v" and "type" of part 0 itself excepted). Returns the number of fields visited.
int for_each_field(const Parts& parts, const std::string& pointer,
                   const std::function<void(const Json& h, const std::string& key, const Json& value)>& f) {
  const Json h = header(parts);
  const Json& object = h.at(Json::json_pointer(pointer));
  int visited = 0;
  for (auto it = object.begin(); it != object.end(); ++it) {
    if (pointer.empty() && (it.key() == "v" || it.key() == "type")) continue;
    f(h, it.key(), it.value());
    ++visited;
  }
  return visited;
}

}  // namespace

int check_every_field_required(const Parts& parts, const Decode& decode, const std::string& pointer,
                               const std::string& prefix) {
  const std::string type = header(parts).at("type");
  return for_each_field(parts, pointer, [&](const Json& h, const std::string& key, const Json&) {
    Json without = h;
    without.at(Json::json_pointer(pointer)).erase(key);
    EXPECT_EQ(error_of(with_header(parts, without), decode), type + ": field '" + prefix + key + "': missing");
  });
}

int check_every_field_typed(const Parts& parts, const Decode& decode, const std::string& pointer,
                            const std::string& prefix) {
  const std::string type = header(parts).at("type");
  return for_each_field(parts, pointer, [&](const Json& h, const std::string& key, const Json& value) {
    Json wrong = h;
    wrong.at(Json::json_pointer(pointer))[key] = value.is_string() ? Json(5) : Json("x");
    EXPECT_TRUE(has(error_of(with_header(parts, wrong), decode), type + ": field '" + prefix + key + "': expected"));
  });
}

}  // namespace pd::protocol::test
