#include "scene/scene_json.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <utility>

#include "util/input_error.h"

namespace pd::scene_json {
namespace {

std::string join(std::initializer_list<const char*> items, const char* quote) {
  std::string out;
  for (const char* item : items) {
    if (!out.empty()) out += ", ";
    out += quote;
    out += item;
    out += quote;
  }
  return out;
}

std::vector<std::string> to_strings(std::initializer_list<const char*> items) {
  return std::vector<std::string>(items.begin(), items.end());
}

// Where the parser is while it reads: one frame per open object or array, for key paths of
// duplicate keys (the parse callback reports no byte position).
struct OpenValue {
  bool is_array = false;
  long long index = 0;         // arrays: index of the element being read
  std::string key;             // objects: key of the member being read
  std::set<std::string> keys;  // objects: keys seen so far
};

std::string path_of(const std::vector<OpenValue>& stack) {
  std::string path;
  for (const OpenValue& v : stack) {
    if (v.is_array) {
      path += "[" + std::to_string(v.index) + "]";
    } else {
      if (!path.empty()) path += ".";
      path += v.key;
    }
  }
  return path;
}

// Strips nlohmann's "[json.exception.parse_error.101] parse error at line 3, column 8: " prefix and
// shortens its "last read: '...'" excerpt (which can hold a whole long string) to its last characters.
std::string parse_error_detail(const std::string& what) {
  std::size_t start = what.find("parse error");
  if (start == std::string::npos) return what;
  std::size_t colon = what.find(": ", start);
  if (colon == std::string::npos) return what;
  std::string detail = what.substr(colon + 2);
  const std::string marker = "last read: '";
  std::size_t open = detail.find(marker);
  if (open == std::string::npos) return detail;
  open += marker.size();
  std::size_t close = detail.find("'; expected", open);
  if (close == std::string::npos) close = detail.rfind('\'');
  constexpr std::size_t kKeep = 40;
  if (close == std::string::npos || close < open || close - open <= kKeep) return detail;
  return detail.substr(0, open) + "..." + detail.substr(close - kKeep);
}

bool is_number_char(char c) {
  return (c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.' || c == 'e' || c == 'E';
}

// Byte offset of `token` standing alone as a number in `text`, or npos.
std::size_t find_number_token(const std::string& text, const std::string& token) {
  if (token.empty()) return std::string::npos;
  for (std::size_t at = text.find(token); at != std::string::npos; at = text.find(token, at + 1)) {
    bool left_ok = at == 0 || !is_number_char(text[at - 1]);
    std::size_t end = at + token.size();
    bool right_ok = end >= text.size() || !is_number_char(text[end]);
    if (left_ok && right_ok) return at;
  }
  return std::string::npos;
}

std::string location(const std::string& file, const std::string& text, std::size_t offset) {
  LineColumn lc = line_column(text, offset);
  return file + ":" + std::to_string(lc.line) + ":" + std::to_string(lc.column);
}

}  // namespace

LineColumn line_column(const std::string& text, std::size_t offset) {
  offset = std::min(offset, text.size());
  LineColumn lc;
  std::size_t line_start = 0;
  for (std::size_t i = 0; i < offset; ++i) {
    if (text[i] == '\n') {
      ++lc.line;
      line_start = i + 1;
    }
  }
  lc.column = static_cast<int>(offset - line_start) + 1;
  return lc;
}

Json parse_json_text(const std::string& text, const std::string& file) {
  std::vector<OpenValue> stack;
  Json::parser_callback_t track = [&](int, Json::parse_event_t event, Json& parsed) {
    switch (event) {
      case Json::parse_event_t::object_start:
        stack.push_back(OpenValue{});
        break;
      case Json::parse_event_t::array_start:
        stack.push_back(OpenValue{});
        stack.back().is_array = true;
        break;
      case Json::parse_event_t::key: {
        OpenValue& top = stack.back();
        top.key = parsed.get<std::string>();
        if (!top.keys.insert(top.key).second) {
          throw InputError(file + ": " + path_of(stack) +
                           ": duplicate key (a key may appear only once in an object)");
        }
        break;
      }
      case Json::parse_event_t::value:
        if (!stack.empty() && stack.back().is_array) ++stack.back().index;
        break;
      case Json::parse_event_t::object_end:
      case Json::parse_event_t::array_end:
        stack.pop_back();
        if (!stack.empty() && stack.back().is_array) ++stack.back().index;
        break;
    }
    return true;
  };
  try {
    return Json::parse(text, track);
  } catch (const Json::parse_error& e) {
    // e.byte counts the characters read, so the offending character is at offset byte - 1.
    std::size_t offset = e.byte > 0 ? e.byte - 1 : 0;
    throw InputError(location(file, text, offset) + ": invalid JSON: " + parse_error_detail(e.what()));
  } catch (const Json::out_of_range& e) {
    // Number overflow (e.g. 1e400) carries no position; find the number in the text.
    std::string what = e.what();
    std::size_t open = what.find('\'');
    std::size_t close = open == std::string::npos ? open : what.find('\'', open + 1);
    if (close != std::string::npos) {
      std::string token = what.substr(open + 1, close - open - 1);
      std::size_t at = find_number_token(text, token);
      std::string where = at == std::string::npos ? file : location(file, text, at);
      throw InputError(where + ": invalid JSON: number " + token + " is out of range for a double");
    }
    throw InputError(file + ": invalid JSON: " + what);
  } catch (const Json::exception& e) {
    throw InputError(file + ": invalid JSON: " + std::string(e.what()));
  }
}

int edit_distance(const std::string& a, const std::string& b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<int>> d(n + 1, std::vector<int>(m + 1, 0));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = static_cast<int>(i);
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = static_cast<int>(j);
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      int cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[n][m];
}

std::string nearest_key(const std::string& key, const std::vector<std::string>& candidates) {
  std::string best;
  int best_distance = 3;
  for (const std::string& candidate : candidates) {
    int distance = edit_distance(key, candidate);
    if (distance < best_distance) {
      best_distance = distance;
      best = candidate;
    }
  }
  return best;
}

std::string describe(const Json& value) {
  if (value.is_number_float() && !std::isfinite(value.get<double>())) return "a non-finite number";
  std::string text = value.dump(-1, ' ', false, Json::error_handler_t::replace);
  if (text.size() <= 60) return text;
  if (value.is_object()) return "an object with " + std::to_string(value.size()) + " keys";
  if (value.is_array()) return "an array of " + std::to_string(value.size()) + " elements";
  return text.substr(0, 57) + "...";
}

JsonNode::JsonNode(const Json& value, std::string key_path, const std::string& file)
    : value_(&value), path_(std::move(key_path)), file_(&file) {}

void JsonNode::fail(const std::string& problem) const {
  throw InputError(*file_ + ": " + (path_.empty() ? std::string("(top level)") : path_) + ": " + problem);
}

void JsonNode::fail_got(const std::string& problem) const { fail(problem + ", got " + describe(*value_)); }

std::string JsonNode::child_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

void JsonNode::expect_keys(std::initializer_list<const char*> allowed) const {
  if (!value_->is_object()) fail_got("must be an object {...}");
  const std::vector<std::string> names = to_strings(allowed);
  for (const auto& member : value_->items()) {
    if (std::find(names.begin(), names.end(), member.key()) != names.end()) continue;
    std::string suggestion = nearest_key(member.key(), names);
    std::string problem = suggestion.empty()
                              ? "unknown key (allowed here: " + join(allowed, "") + ")"
                              : "unknown key, did you mean '" + suggestion + "'?";
    throw InputError(*file_ + ": " + child_path(member.key()) + ": " + problem);
  }
}

bool JsonNode::has(const char* key) const { return value_->is_object() && value_->contains(key); }

JsonNode JsonNode::required(const char* key) const {
  if (!value_->is_object()) fail_got("must be an object {...}");
  auto it = value_->find(key);
  if (it == value_->end()) throw InputError(*file_ + ": " + child_path(key) + ": required key is missing");
  return JsonNode(*it, child_path(key), *file_);
}

std::optional<JsonNode> JsonNode::optional(const char* key) const {
  if (!value_->is_object()) fail_got("must be an object {...}");
  auto it = value_->find(key);
  if (it == value_->end()) return std::nullopt;
  return JsonNode(*it, child_path(key), *file_);
}

std::vector<JsonNode> JsonNode::elements() const {
  if (!value_->is_array()) fail_got("must be an array [...]");
  std::vector<JsonNode> out;
  for (std::size_t i = 0; i < value_->size(); ++i) {
    out.emplace_back((*value_)[i], path_ + "[" + std::to_string(i) + "]", *file_);
  }
  return out;
}

std::vector<JsonNode> JsonNode::elements(std::size_t count) const {
  if (!value_->is_array() || value_->size() != count) {
    fail_got("must be an array of " + std::to_string(count) + " elements");
  }
  return elements();
}

double JsonNode::number() const {
  if (!value_->is_number()) fail_got("must be a number");
  double v = value_->get<double>();
  if (!std::isfinite(v)) fail_got("must be a finite number");
  return v;
}

double JsonNode::positive() const {
  double v = number();
  if (!(v > 0.0)) fail_got("must be > 0");
  return v;
}

double JsonNode::at_least(double lower) const {
  double v = number();
  if (!(v >= lower)) fail_got("must be >= " + describe(Json(lower)));
  return v;
}

long long JsonNode::integer(long long lower, long long upper) const {
  const std::string range = "must be an integer from " + std::to_string(lower) + " to " + std::to_string(upper);
  if (value_->is_number_unsigned()) {
    auto v = value_->get<unsigned long long>();
    if (lower > 0 && v < static_cast<unsigned long long>(lower)) fail_got(range);
    if (upper < 0 || v > static_cast<unsigned long long>(upper)) fail_got(range);
    return static_cast<long long>(v);
  }
  if (value_->is_number_integer()) {
    auto v = value_->get<long long>();
    if (v < lower || v > upper) fail_got(range);
    return v;
  }
  if (value_->is_number_float()) {
    double v = value_->get<double>();
    if (!std::isfinite(v) || std::floor(v) != v) fail_got("must be an integer (no fractional part)");
    if (v < static_cast<double>(lower) || v > static_cast<double>(upper)) fail_got(range);
    return static_cast<long long>(v);
  }
  fail_got("must be an integer");
}

bool JsonNode::boolean() const {
  if (!value_->is_boolean()) fail_got("must be true or false");
  return value_->get<bool>();
}

std::string JsonNode::string() const {
  if (!value_->is_string()) fail_got("must be a string");
  return value_->get<std::string>();
}

std::string JsonNode::choice(std::initializer_list<const char*> allowed, const char* what) const {
  const std::string list = join(allowed, "\"");
  if (!value_->is_string()) fail_got("must be a string, one of " + list);
  std::string v = value_->get<std::string>();
  const std::vector<std::string> names = to_strings(allowed);
  if (std::find(names.begin(), names.end(), v) != names.end()) return v;
  std::string suggestion = nearest_key(v, names);
  std::string hint = suggestion.empty() ? "" : ", did you mean '" + suggestion + "'?";
  fail_got(std::string("unknown ") + what + hint + " (allowed: " + list + ")");
}

Vec3 JsonNode::vec3() const {
  if (!value_->is_array() || value_->size() != 3) fail_got("must be an array of 3 numbers [x, y, z]");
  std::vector<JsonNode> e = elements();
  return Vec3(e[0].number(), e[1].number(), e[2].number());
}

Vec3 JsonNode::positive_vec3() const {
  if (!value_->is_array() || value_->size() != 3) fail_got("must be an array of 3 positive numbers [x, y, z]");
  std::vector<JsonNode> e = elements();
  return Vec3(e[0].positive(), e[1].positive(), e[2].positive());
}

}  // namespace pd::scene_json
