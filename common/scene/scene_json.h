#pragma once
// Checked access to parsed JSON for scene files (internal to common/scene).
//
// A JsonNode is a JSON value together with its key path ("objects[0].material.thickness") and the
// name of the file it came from. Every accessor either returns a valid value or throws one
// InputError "<file>: <key path>: <problem>, got <value>".
#include <cstddef>
#include <initializer_list>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "geometry/mesh.h"

namespace pd {
struct PinScript;  // scene/scene.h
}  // namespace pd

namespace pd::scene_json {

using Json = nlohmann::json;

// Limits on the document itself, checked by a linear scan of the text BEFORE a JSON tree is built
// (docs/scene-format.md, "Limits"). The nesting limit keeps every recursive walk of the tree (the
// library's dump(), our own readers) far from the stack's end: a 100 000-deep array used to crash.
constexpr std::size_t kMaxDocumentBytes = std::size_t{16} << 20;  // 16 MiB: 200x the largest example scene
constexpr int kMaxNestingDepth = 64;            // arrays and objects; scenes need 8
constexpr std::size_t kMaxStringBytes = 65536;  // any string or key, as written (escapes included)
constexpr std::size_t kMaxNameBytes = 256;      // scene and object names
constexpr std::size_t kMaxPathBytes = 4096;     // OBJ paths (PATH_MAX on Linux)

// Parses `text` as JSON. Syntax errors are reported as "<file>:<line>:<column>: invalid JSON: ...";
// duplicate keys in one object (which JSON parsers otherwise resolve silently) are errors too, and
// so are a document over kMaxDocumentBytes, nesting deeper than kMaxNestingDepth and strings longer
// than kMaxStringBytes (each at its line and column).
Json parse_json_text(const std::string& text, const std::string& file);

// A closed interval [lower, upper] that a physical number must lie in, with its unit for messages.
struct Range {
  double lower;
  double upper;
  const char* unit;  // "" for dimensionless
};

// The physical ranges of scene keys (docs/scene-format.md, "Limits", gives the reason for each).
// Generous for real shots, tight enough that no finite value can overflow the solver.
namespace limits {
constexpr Range kTimeStep{1e-6, 1.0, "s"};
constexpr Range kGravity{-1000.0, 1000.0, "m/s^2"};         // per component
constexpr Range kTolerance{1e-12, 1000.0, "1/s"};
constexpr Range kPosition{-1e4, 1e4, "m"};                  // translations, centres, heights, vertices
constexpr Range kRegion{-1e6, 1e6, "m"};                    // pin region corners
constexpr Range kLength{1e-6, 1e4, "m"};                    // procedural mesh sizes
constexpr Range kScale{1e-6, 1e6, ""};
constexpr Range kAngleDeg{-36000.0, 36000.0, "degrees"};
constexpr Range kTime{0.0, 1e7, "s"};                       // script start/end, keyframe times
constexpr double kMaxSpeed = 1000.0;                        // m/s: vertex, script and wind speeds
constexpr double kMaxAirSpeed = 300.0;                      // m/s
constexpr double kMaxAngularSpeed = 1000.0;                 // rad/s
constexpr Range kDensity{0.1, 1e5, "kg/m^3"};
constexpr Range kYoungsModulus{1.0, 1e13, "Pa"};
constexpr Range kBendingModulus{1e-6, 1e13, "Pa"};
constexpr Range kThickness{1e-7, 1.0, "m"};
constexpr Range kPressure{-1e7, 1e7, "Pa"};
constexpr Range kAirDensity{1e-6, 2000.0, "kg/m^3"};
constexpr Range kDragCoefficient{0.0, 10.0, ""};
constexpr Range kGustAmplitude{0.0, 10.0, ""};
constexpr Range kGustFrequency{0.0, 1000.0, "Hz"};
constexpr Range kDhat{1e-8, 1.0, "m"};
constexpr Range kContactOffset{0.0, 1.0, "m"};
constexpr Range kFriction{0.0, 10.0, ""};
constexpr Range kEpsV{1e-9, 100.0, "m/s"};
constexpr Range kBarrierStiffness{1e-6, 1e25, "J/m^4"};
constexpr Range kStrainLimitStiffness{1e-9, 1e13, "J/m^2"};  // E * thickness spans 1e-6 .. 1e13
constexpr Range kHierarchyRatio{1.0, 1000.0, ""};           // and > 1
constexpr long long kMaxObjects = 1000;
constexpr long long kMaxPinGroups = 1000;                   // per object
}  // namespace limits

// How a key appears in a key path: itself when short and printable, else quoted_for_message (cut
// and escaped), so a 60 000-character or control-character key cannot flood a message.
std::string key_for_path(const std::string& key);

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
  double in_range(const Range& range) const;  // finite, range.lower <= v <= range.upper
  // Integer written without a fractional part (120, 120.0, 1.2e2), within [lower, upper].
  long long integer(long long lower, long long upper) const;
  bool boolean() const;
  // A string of at most `max_bytes` bytes without NUL characters (a NUL would cut it silently in
  // every C API it reaches: file names, HDF5 attributes).
  std::string string(std::size_t max_bytes = kMaxStringBytes) const;
  // A string equal to one of `allowed`; otherwise the message lists the allowed values.
  std::string choice(std::initializer_list<const char*> allowed, const char* what) const;
  Vec3 vec3() const;                        // [x, y, z], finite
  Vec3 positive_vec3() const;               // [x, y, z], each > 0
  Vec3 vec3_in(const Range& range) const;   // [x, y, z], each component in `range`
  // [x, y, z] with length <= max_length (a speed: the limit holds in every direction).
  Vec3 vec3_length_at_most(double max_length, const char* unit) const;
  // A direction: components within +-1e6, length >= 1e-6 (so squaring neither overflows nor
  // underflows); returned normalised.
  Vec3 direction() const;

 private:
  const Json* value_;
  std::string path_;
  const std::string* file_;
};

// Fails at `node` (the script's key) when `script` moves any of the listed vertices (rows of
// `initial`; all rows when `vertices` is null) faster than limits::kMaxSpeed, or turns keyframes
// faster than limits::kMaxAngularSpeed. Velocity + spin: exact, |v + w x (X - c)| per vertex.
// Keyframes: per segment (|T1 - T0| + theta max|X|) / (t1 - t0), theta the rotation angle between
// the poses: a bound on the slerp path's speed (its rotation is about the origin at constant rate).
void check_script_speed(const JsonNode& node, const PinScript& script, const Positions& initial,
                        const std::vector<int>* vertices);

// Fails at `node` when a row of `V` (positions after the object's transform, `what` = "rest" or
// "initial") lies outside limits::kPosition on any axis.
void check_positions(const JsonNode& node, const Positions& V, const char* what);

}  // namespace pd::scene_json
