#pragma once
// Checked access to parsed JSON for scene files (internal to common/scene).
//
// A JsonNode is a JSON value together with its key path ("objects[0].material.thickness") and the
// name of the file it came from. Every accessor either returns a valid value or throws one
// InputError "<file>: <key path>: <problem>, got <value>".
#include <initializer_list>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "geometry/mesh.h"

namespace pd::scene_json {

using Json = nlohmann::json;

// Parses `text` as JSON. Syntax errors are reported as "<file>:<line>:<column>: invalid JSON: ...";
// duplicate keys in one object (which JSON parsers otherwise resolve silently) are errors too.
Json parse_json_text(const std::string& text, const std::string& file);

// 1-based line and column of the 0-based byte offset `offset` in `text`.
struct LineColumn {
  int line = 1;
  int column = 1;
};
LineColumn line_column(const std::string& text, std::size_t offset);

// Optimal-string-alignment distance (insertions, deletions, substitutions, adjacent transpositions).
int edit_distance(const std::string& a, const std::string& b);

// The candidate nearest to `key` if it is within edit distance 2, else "".
std::string nearest_key(const std::string& key, const std::vector<std::string>& candidates);

// Short description of a JSON value for messages: numbers and short values verbatim, long ones cut.
std::string describe(const Json& value);

class JsonNode {
 public:
  JsonNode(const Json& value, std::string key_path, const std::string& file);

  const Json& json() const { return *value_; }
  const std::string& path() const { return path_; }
  const std::string& file() const { return *file_; }

  // Throws InputError "<file>: <path>: <problem>".
  [[noreturn]] void fail(const std::string& problem) const;
  // Throws InputError "<file>: <path>: <problem>, got <value>".
  [[noreturn]] void fail_got(const std::string& problem) const;

  // --- objects ---
  // Requires an object whose keys are all in `allowed`; an unknown key is reported at its own path
  // with the nearest allowed key as a suggestion.
  void expect_keys(std::initializer_list<const char*> allowed) const;
  bool has(const char* key) const;
  JsonNode required(const char* key) const;                 // missing: "<path>.<key>: required key is missing"
  std::optional<JsonNode> optional(const char* key) const;  // absent: nullopt
  std::string child_path(const std::string& key) const;

  // --- arrays ---
  std::vector<JsonNode> elements() const;                      // any length
  std::vector<JsonNode> elements(std::size_t count) const;     // exactly `count`

  // --- scalars ---
  double number() const;                    // finite number
  double positive() const;                  // finite, > 0
  double at_least(double lower) const;      // finite, >= lower
  // Integer written without a fractional part (120, 120.0, 1.2e2), within [lower, upper].
  long long integer(long long lower, long long upper) const;
  bool boolean() const;
  std::string string() const;
  // A string equal to one of `allowed`; otherwise the message lists the allowed values.
  std::string choice(std::initializer_list<const char*> allowed, const char* what) const;
  Vec3 vec3() const;                        // [x, y, z], finite
  Vec3 positive_vec3() const;               // [x, y, z], each > 0

 private:
  const Json* value_;
  std::string path_;
  const std::string* file_;
};

}  // namespace pd::scene_json
