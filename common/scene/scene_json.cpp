#include "scene/scene_json.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <utility>

#include "scene/scene.h"
#include "util/input_error.h"
#include "util/message_text.h"

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
      path += key_for_path(v.key);
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

// Short form of a limit for messages: 1e-06, 1000, 1e+07.
std::string format_limit(double x) {
  std::ostringstream out;
  out.precision(6);
  out << x;
  return out.str();
}

std::string with_unit(double x, const char* unit) {
  return format_limit(x) + (unit[0] != '\0' ? std::string(" ") + unit : std::string());
}

// One linear pass over the text, before any tree is built: document size, nesting depth and string
// lengths. Strings are skipped (a '[' inside one is text), escapes included, so the scan agrees
// with the parser on well-formed input; malformed input is left to the parser's own messages.
void check_document_limits(const std::string& text, const std::string& file) {
  if (text.size() > kMaxDocumentBytes) {
    throw InputError(file + ": the scene file has " + std::to_string(text.size()) +
                     " bytes, more than the limit of " + std::to_string(kMaxDocumentBytes) + " (16 MiB)");
  }
  // JSON text never holds a raw NUL (inside a string it is written \u0000), and the parser takes one
  // for the end of its input: a document followed by a NUL and anything at all would be accepted.
  if (const std::size_t nul = text.find('\0'); nul != std::string::npos)
    throw InputError(location(file, text, nul) + ": a NUL byte; JSON text cannot hold one (binary data in the file?)");
  int depth = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"') {
      const std::size_t start = i++;
      while (i < text.size() && text[i] != '"') i += text[i] == '\\' ? 2 : 1;
      const std::size_t length = std::min(i, text.size()) - start - 1;
      if (length > kMaxStringBytes) {
        throw InputError(location(file, text, start) + ": string of " + std::to_string(length) +
                         " bytes is longer than the limit of " + std::to_string(kMaxStringBytes));
      }
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxNestingDepth) {
        throw InputError(location(file, text, i) + ": arrays and objects nested deeper than " +
                         std::to_string(kMaxNestingDepth) + " levels (a scene needs about 8)");
      }
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;  // (an unmatched one is a syntax error the parser reports)
    }
  }
}

}  // namespace

std::string key_for_path(const std::string& key) {
  const bool plain = !key.empty() && key.size() <= kMessageTextMaxChars &&
                     std::all_of(key.begin(), key.end(), [](char c) {
                       const auto b = static_cast<unsigned char>(c);
                       return b >= 0x20 && b < 0x7f && c != '"';
                     });
  return plain ? key : quoted_for_message(key);
}

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
  check_document_limits(text, file);
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
    // Lengths differing by more than 2 cannot be within 2 edits; skipping them keeps a 60 000-character
    // key from costing a 60 000-row table per candidate.
    const std::size_t longer = std::max(key.size(), candidate.size());
    if (longer - std::min(key.size(), candidate.size()) > 2) continue;
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
  if (value.is_string()) return quoted_for_message(value.get_ref<const std::string&>(), 57);
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
  const std::string shown = key_for_path(key);
  return path_.empty() ? shown : path_ + "." + shown;
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

double JsonNode::in_range(const Range& range) const {
  double v = number();
  if (!(v >= range.lower && v <= range.upper)) {
    fail_got("must be from " + format_limit(range.lower) + " to " + with_unit(range.upper, range.unit));
  }
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

std::string JsonNode::string(std::size_t max_bytes) const {
  if (!value_->is_string()) fail_got("must be a string");
  const std::string& v = value_->get_ref<const std::string&>();
  if (v.find('\0') != std::string::npos) fail_got("must not contain a NUL character (\\u0000)");
  if (v.size() > max_bytes) {
    fail_got("is " + std::to_string(v.size()) + " bytes long, more than the limit of " + std::to_string(max_bytes));
  }
  return v;
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
  // One statement per element: the order of a constructor's argument evaluation is unspecified, and
  // the first bad element is the one to report.
  const double x = e[0].number(), y = e[1].number(), z = e[2].number();
  return Vec3(x, y, z);
}

Vec3 JsonNode::vec3_in(const Range& range) const {
  if (!value_->is_array() || value_->size() != 3) fail_got("must be an array of 3 numbers [x, y, z]");
  std::vector<JsonNode> e = elements();
  const double x = e[0].in_range(range), y = e[1].in_range(range), z = e[2].in_range(range);
  return Vec3(x, y, z);
}

Vec3 JsonNode::vec3_length_at_most(double max_length, const char* unit) const {
  // Components bounded first, so the length itself cannot overflow to infinity.
  const Vec3 v = vec3_in(Range{-max_length, max_length, unit});
  if (!(v.norm() <= max_length)) fail_got("must have a length of at most " + with_unit(max_length, unit));
  return v;
}

Vec3 JsonNode::direction() const {
  const Vec3 v = vec3_in(Range{-1e6, 1e6, ""});
  if (!(v.norm() >= 1e-6)) fail_got("must be a non-zero vector (length >= 1e-06)");
  return v.normalized();
}

Vec3 JsonNode::positive_vec3() const {
  if (!value_->is_array() || value_->size() != 3) fail_got("must be an array of 3 positive numbers [x, y, z]");
  std::vector<JsonNode> e = elements();
  const double x = e[0].positive(), y = e[1].positive(), z = e[2].positive();
  return Vec3(x, y, z);
}

// ---------------------------------------------------------------------------------------------
// Magnitude checks that need more than one value

namespace {

std::string format_point(const Vec3& v) {
  return "[" + format_limit(v.x()) + ", " + format_limit(v.y()) + ", " + format_limit(v.z()) + "]";
}

// Largest speed, m/s, that `s` gives any vertex whose initial position is a row of `initial` listed
// in `vertices` (all rows when null); see check_script_speed in the header for the formulas.
double script_max_speed(const PinScript& s, const Positions& initial, const std::vector<int>* vertices) {
  const Eigen::Index n = vertices ? static_cast<Eigen::Index>(vertices->size()) : initial.rows();
  auto point = [&](Eigen::Index k) -> Vec3 {
    return initial.row(vertices ? (*vertices)[static_cast<std::size_t>(k)] : k).transpose();
  };
  double fastest = 0.0;
  if (s.keyframes.empty()) {
    for (Eigen::Index k = 0; k < n; ++k)
      fastest = std::max(fastest, (s.velocity + s.angular_velocity.cross(point(k) - s.center)).norm());
    return fastest;
  }
  double reach = 0.0;  // max |X|, m
  for (Eigen::Index k = 0; k < n; ++k) reach = std::max(reach, point(k).norm());
  for (std::size_t k = 1; k < s.keyframes.size(); ++k) {
    const Keyframe& a = s.keyframes[k - 1];
    const Keyframe& b = s.keyframes[k];
    const double theta = a.rotation.angularDistance(b.rotation);
    fastest = std::max(fastest, ((b.translation - a.translation).norm() + theta * reach) / (b.time - a.time));
  }
  return fastest;
}

// Keyframes whose rotation turns faster than the angular-speed limit (spin scripts are bounded by
// their angular_velocity key already).
void check_keyframe_spin(const JsonNode& node, const PinScript& s) {
  for (std::size_t k = 1; k < s.keyframes.size(); ++k) {
    const Keyframe& a = s.keyframes[k - 1];
    const Keyframe& b = s.keyframes[k];
    const double rate = a.rotation.angularDistance(b.rotation) / (b.time - a.time);
    if (rate > limits::kMaxAngularSpeed) {
      node.fail("turns at " + format_limit(rate) + " rad/s between the keyframes at t = " + format_limit(a.time) +
                " and " + format_limit(b.time) + " s, more than the limit of " +
                format_limit(limits::kMaxAngularSpeed) + " rad/s");
    }
  }
}

}  // namespace

void check_script_speed(const JsonNode& node, const PinScript& s, const Positions& initial,
                        const std::vector<int>* vertices) {
  if (!s.keyframes.empty()) check_keyframe_spin(node, s);
  const double speed = script_max_speed(s, initial, vertices);
  if (!(speed <= limits::kMaxSpeed)) {
    node.fail("moves vertices at up to " + format_limit(speed) + " m/s, more than the limit of " +
              format_limit(limits::kMaxSpeed) + " m/s (velocity plus angular_velocity times the distance from "
              "center, or the keyframes' translation and rotation over their time steps)");
  }
}

// Every coordinate of `V` inside limits::kPosition (after the transform).
void check_positions(const JsonNode& node, const Positions& V, const char* what) {
  const Range& r = limits::kPosition;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    if ((V.row(i).array() >= r.lower).all() && (V.row(i).array() <= r.upper).all()) continue;
    node.fail(std::string(what) + " vertex " + std::to_string(i) + " is at " + format_point(V.row(i).transpose()) +
              " m after the transform, outside the " + format_limit(r.lower) + " to " + format_limit(r.upper) +
              " m the simulator accepts on each axis");
  }
}

}  // namespace pd::scene_json
