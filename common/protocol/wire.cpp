// The wire format's building blocks (protocol/wire.h).
#include "protocol/wire.h"

#include <cmath>
#include <cstring>
#include <limits>

#include "util/base64.h"

namespace pd::protocol::wire {

// Data parts are the host's doubles copied as bytes; the wire is little-endian IEEE-754.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the farm's float64 parts assume a little-endian host");
static_assert(std::numeric_limits<double>::is_iec559 && sizeof(double) == 8, "doubles must be IEEE-754 binary64");

namespace {

constexpr std::array<std::pair<const char*, Family>, 30> kTypes{{
    {kWelcome, Family::command},       {kAssign, Family::command},         {kBelowFrame, Family::command},
    {kGuideFrame, Family::command},
    {kCancelTask, Family::command},    {kHeartbeat, Family::command},      {kRefused, Family::command},
    {kHello, Family::report},          {kWorkerHeartbeat, Family::report}, {kFrame, Family::report},
    {kTaskDone, Family::report},       {kTaskFailed, Family::report},      {kHierarchyDone, Family::report},
    {kSubmit, Family::request},        {kRefine, Family::request},         {kStatus, Family::request},
    {kFetch, Family::request},         {kCancelJob, Family::request},      {kRequeue, Family::request},        {kWorkers, Family::request},
    {kAddSlurm, Family::request},      {kRemoveSlurm, Family::request},    {kSlurmAccepted, Family::reply},
    {kGoodbye, Family::report},
    {kSubmitted, Family::reply},       {kAccepted, Family::reply},         {kStatusReply, Family::reply},
    {kFetchReply, Family::reply},      {kWorkersReply, Family::reply},     {kError, Family::reply},
}};

const char* noun(Family f) {
  switch (f) {
    case Family::command: return "scheduler command";
    case Family::report: return "worker report";
    case Family::request: return "client request";
    case Family::reply: return "scheduler reply";
  }
  return "message";
}

// What a JSON value is, for "expected ..., got <this>"; strings are not echoed (they may be long).
std::string describe(const Json& v) {
  if (v.is_number() || v.is_boolean()) return std::string(v.type_name()) + " " + v.dump();
  return v.type_name();
}

bool dumps(const std::string& s) {
  try {
    (void)Json(s).dump();
    return true;
  } catch (const Json::exception&) {
    return false;
  }
}

// The path of the first string (key or value) of j that is not valid UTF-8, or "" if there is none.
// Only called after dump() failed; the depth is that of the encoders' headers (a few levels).
std::string bad_string_path(const Json& j, const std::string& path) {
  if (j.is_string()) return dumps(j.get_ref<const std::string&>()) ? "" : (path.empty() ? "(value)" : path);
  if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) {
      std::string p = bad_string_path(j[i], path + "[" + std::to_string(i) + "]");
      if (!p.empty()) return p;
    }
  }
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string name = path.empty() ? it.key() : path + "." + it.key();
      if (!dumps(it.key())) return name;
      std::string p = bad_string_path(it.value(), name);
      if (!p.empty()) return p;
    }
  }
  return "";
}

// Error text from the JSON parser, which quotes the bytes it read: bytes outside printable ASCII
// become '?', so that the message can itself be sent (a Refused reason must be valid UTF-8), and a
// long text is cut (the parser quotes up to the whole part: megabytes in a log line otherwise).
std::string printable(const std::string& text) {
  constexpr std::size_t kMaxShown = 200;
  std::string out = text.size() <= kMaxShown ? text : text.substr(0, kMaxShown) + "...";
  for (char& c : out)
    if (c < 0x20 || c > 0x7e) c = '?';
  return out;
}

// A type name as messages show it: an absurdly long one (unknown anyway) is shortened, at a UTF-8
// character boundary (a cut inside a character would make every text that quotes it invalid UTF-8,
// which JSON encoders refuse).
std::string shown_type(const std::string& type) {
  constexpr std::size_t kMaxShown = 64;
  if (type.size() <= kMaxShown) return type;
  std::size_t n = kMaxShown;
  while (n > 0 && (static_cast<unsigned char>(type[n]) & 0xC0) == 0x80) --n;  // continuation bytes
  return type.substr(0, n) + "...";
}

// Deepest nesting of arrays and objects accepted in part 0. The headers nest 3 deep; a deeper one is
// refused while parsing, before the (recursive) JSON value is built: 100 000 levels overflowed the
// stack.
constexpr int kMaxDepth = 32;

// Part 0 parsed: a JSON object with a string "type" and an integer "v" (not compared here). The
// type is read first, leniently, so that a version error can name it.
Json parse_header(const Parts& parts, std::string& type) {
  type = "message";
  if (parts.empty()) throw ProtocolError("message: no parts (part 0 must be the JSON header)");
  if (parts[0].size() > kMaxMessageBytes)
    throw ProtocolError("message: part 0: " + std::to_string(parts[0].size()) + " bytes, over the limit of " +
                        std::to_string(kMaxMessageBytes));
  // The parser takes a NUL for the end of its input: a header followed by a NUL and anything at all
  // would be accepted. JSON text never holds a raw NUL.
  if (const std::size_t nul = parts[0].find('\0'); nul != std::string::npos)
    throw ProtocolError("message: part 0: a NUL byte at offset " + std::to_string(nul) +
                        "; JSON text cannot hold one");
  Json h;
  try {
    h = Json::parse(parts[0], [](int depth, Json::parse_event_t, Json&) {
      if (depth > kMaxDepth)
        throw ProtocolError("message: part 0: JSON nested deeper than " + std::to_string(kMaxDepth) + " levels");
      return true;
    });
  } catch (const Json::exception& e) {
    throw ProtocolError("message: part 0 is not JSON: " + printable(e.what()));
  }
  if (!h.is_object()) throw ProtocolError("message: part 0 is JSON but not an object (got " + describe(h) + ")");
  const auto t = h.find("type");
  if (t != h.end() && t->is_string()) type = shown_type(t->get<std::string>());
  const Fields f(h, type, "");
  (void)f.integer("v");  // "missing", or not an integer
  const Where w{&f, "type"};
  if (t == h.end()) w.fail("missing");
  if (!t->is_string()) w.fail("expected a string, got " + describe(*t));
  return h;
}

}  // namespace

std::optional<Family> family_of(const std::string& type) {
  for (const auto& [name, family] : kTypes)
    if (type == name) return family;
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------------
// Encoding.

Json header(const char* type) {
  Json h = Json::object();
  h["v"] = kProtocolVersion;
  h["type"] = type;
  return h;
}

Json number(double x) {
  if (std::isfinite(x)) return x;
  if (std::isnan(x)) return "nan";
  return x > 0 ? "inf" : "-inf";
}

Json numbers(const std::vector<double>& xs) {
  Json a = Json::array();
  for (double x : xs) a.push_back(number(x));
  return a;
}

std::string doubles_part(const std::vector<double>& xs) {
  std::string bytes(xs.size() * sizeof(double), '\0');
  if (!xs.empty()) std::memcpy(bytes.data(), xs.data(), bytes.size());
  return bytes;
}

void require_triples(const char* type, const char* field, const std::vector<double>& xs) {
  if (xs.size() % 3 != 0)
    throw ProtocolError(std::string(type) + ": field '" + field + "': " + std::to_string(xs.size()) +
                        " numbers, expected a multiple of 3");
}

std::string dump(const Json& j, int indent, const std::string& what) {
  try {
    return j.dump(indent);
  } catch (const Json::exception& e) {
    const std::string path = bad_string_path(j, "");
    if (path.empty()) throw ProtocolError(what + ": cannot write JSON: " + e.what());
    throw ProtocolError(what + ": field '" + path + "': not valid UTF-8 (" + e.what() + ")");
  }
}

Parts finish(const Json& header, Parts data, std::size_t limit) {
  const std::string type = header.at("type").get<std::string>();
  Parts parts;
  parts.reserve(data.size() + 1);
  parts.push_back(dump(header, -1, type));
  for (std::string& d : data) parts.push_back(std::move(d));
  std::size_t total = 0;
  for (const std::string& p : parts) total += p.size();
  if (total > limit)
    throw ProtocolError(type + ": message of " + std::to_string(total) + " bytes, over the limit of " +
                        std::to_string(limit));
  return parts;
}

// ---------------------------------------------------------------------------------------------------
// Typed values.

std::string Where::str() const {
  std::string s = fields->type() + ": field '" + fields->path() + name;
  if (index >= 0) s += "[" + std::to_string(index) + "]";
  return s + "'";
}

void Where::fail(const std::string& what) const { throw ProtocolError(str() + ": " + what); }

int64_t to_int64(const Json& v, const Where& w) {
  if (v.is_number_unsigned()) {
    const auto u = v.get<uint64_t>();
    if (u > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()))
      w.fail(std::to_string(u) + " is out of range for a 64-bit integer");
    return static_cast<int64_t>(u);
  }
  if (v.is_number_integer()) return v.get<int64_t>();
  w.fail("expected an integer, got " + describe(v));
}

int to_int(const Json& v, const Where& w) {
  const int64_t x = to_int64(v, w);
  if (x < std::numeric_limits<int>::min() || x > std::numeric_limits<int>::max())
    w.fail(std::to_string(x) + " is out of range for a 32-bit integer");
  return static_cast<int>(x);
}

int to_count(const Json& v, const Where& w) {
  const int x = to_int(v, w);
  if (x < 0) w.fail(std::to_string(x) + " is negative");
  return x;
}

int64_t to_id(const Json& v, const Where& w) {
  const int64_t x = to_int64(v, w);
  if (x < 0) w.fail(std::to_string(x) + " is negative (ids are >= 0)");
  return x;
}

double to_number(const Json& v, const Where& w) {
  if (v.is_number()) return v.get<double>();
  if (v.is_string()) {
    const auto& s = v.get_ref<const std::string&>();
    if (s == "inf") return std::numeric_limits<double>::infinity();
    if (s == "-inf") return -std::numeric_limits<double>::infinity();
    if (s == "nan") return std::numeric_limits<double>::quiet_NaN();
  }
  w.fail("expected a number (or \"inf\", \"-inf\", \"nan\"), got " + describe(v));
}

bool to_bool(const Json& v, const Where& w) {
  if (!v.is_boolean()) w.fail("expected a boolean, got " + describe(v));
  return v.get<bool>();
}

std::string to_text(const Json& v, const Where& w) {
  if (!v.is_string()) w.fail("expected a string, got " + describe(v));
  return v.get<std::string>();
}

// ---------------------------------------------------------------------------------------------------
// Fields.

Fields::Fields(const Json& object, std::string type, std::string path)
    : object_(&object), type_(std::move(type)), path_(std::move(path)) {}

bool Fields::has(const char* name) const { return object_->find(name) != object_->end(); }

const Json& Fields::get(const char* name) const {
  const auto it = object_->find(name);
  if (it == object_->end()) Where{this, name}.fail("missing");
  return *it;
}

std::optional<double> Fields::optional_number(const char* name) const {
  if (!has(name)) return std::nullopt;
  return number(name);
}

const Json& Fields::array(const char* name) const {
  const Json& a = get(name);
  if (!a.is_array()) Where{this, name}.fail("expected an array, got " + describe(a));
  return a;
}

std::vector<double> Fields::numbers(const char* name) const {
  const Json& a = array(name);
  std::vector<double> xs;
  xs.reserve(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) xs.push_back(to_number(a[i], {this, name, long(i)}));
  return xs;
}

std::vector<int> Fields::counts(const char* name) const {
  const Json& a = array(name);
  std::vector<int> xs;
  xs.reserve(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) xs.push_back(to_count(a[i], {this, name, long(i)}));
  return xs;
}

std::vector<std::string> Fields::texts(const char* name) const {
  const Json& a = array(name);
  std::vector<std::string> xs;
  xs.reserve(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) xs.push_back(to_text(a[i], {this, name, long(i)}));
  return xs;
}

Fields Fields::object(const char* name) const {
  const Json& o = get(name);
  if (!o.is_object()) Where{this, name}.fail("expected an object, got " + describe(o));
  return Fields(o, type_, path_ + name + ".");
}

std::vector<Fields> Fields::objects(const char* name) const {
  const Json& a = array(name);
  std::vector<Fields> out;
  out.reserve(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!a[i].is_object()) Where{this, name, long(i)}.fail("expected an object, got " + describe(a[i]));
    out.emplace_back(a[i], type_, path_ + name + "[" + std::to_string(i) + "].");
  }
  return out;
}

// ---------------------------------------------------------------------------------------------------
// Message.

Message::Message(const Parts& parts, std::size_t limit) : parts_(parts) {
  header_ = parse_header(parts, type_);
  const int64_t v = fields().integer("v");
  if (v != kProtocolVersion)
    throw ProtocolError(type_ + ": protocol version " + std::to_string(v) + ", this program speaks " +
                        std::to_string(kProtocolVersion));
  std::size_t total = 0;
  for (const std::string& p : parts) total += p.size();  // each part is in memory: no overflow
  if (total > limit)
    throw ProtocolError(type_ + ": message of " + std::to_string(total) + " bytes in " +
                        std::to_string(parts.size()) + " parts, over the limit of " + std::to_string(limit));
}

int64_t Message::vertex_count(const char* name) const {
  const Fields f = fields();
  const Where w{&f, name};
  const int64_t n = to_int64(f.get(name), w);
  if (n < 0) w.fail(std::to_string(n) + " is negative");
  if (n > kMaxVertices)
    w.fail(std::to_string(n) + " vertices cannot fit in a message (at most kMaxMessageBytes / 24 = " +
           std::to_string(kMaxVertices) + ")");
  return n;
}

std::size_t Message::byte_count(const char* name) const {
  const Fields f = fields();
  const Where w{&f, name};
  const int64_t n = to_int64(f.get(name), w);
  if (n < 0) w.fail(std::to_string(n) + " is negative");
  if (static_cast<uint64_t>(n) > kMaxMessageBytes)
    w.fail(std::to_string(n) + " bytes is over the message limit of " + std::to_string(kMaxMessageBytes));
  return static_cast<std::size_t>(n);
}

void Message::expect_parts(std::size_t n) const {
  if (parts_.size() != n)
    throw ProtocolError(type_ + ": " + std::to_string(parts_.size()) + (parts_.size() == 1 ? " part" : " parts") +
                        ", expected " + std::to_string(n));
}

const std::string& Message::part(std::size_t index) const {
  if (index >= parts_.size())
    throw ProtocolError(type_ + ": part " + std::to_string(index) + " is missing (" + std::to_string(parts_.size()) +
                        " parts)");
  return parts_[index];
}

std::vector<double> Message::doubles(std::size_t index, int64_t vertices) const {
  const std::string& p = part(index);
  // vertices <= kMaxVertices (vertex_count), so 24 * vertices cannot overflow.
  const std::size_t expected = static_cast<std::size_t>(vertices) * 3 * sizeof(double);
  if (vertices < 0 || vertices > kMaxVertices || p.size() != expected)
    throw ProtocolError(type_ + ": part " + std::to_string(index) + ": " + std::to_string(p.size()) +
                        " bytes, expected 3 * " + std::to_string(vertices) + " * 8 = " + std::to_string(expected));
  std::vector<double> xs(static_cast<std::size_t>(vertices) * 3);
  if (expected > 0) std::memcpy(xs.data(), p.data(), expected);  // parts have no alignment guarantee
  return xs;
}

std::string Message::blob(std::size_t index, std::size_t bytes, const char* field) const {
  const std::string& p = part(index);
  if (p.size() != bytes)
    throw ProtocolError(type_ + ": part " + std::to_string(index) + ": " + std::to_string(p.size()) +
                        " bytes, expected " + std::to_string(bytes) + " (field '" + field + "')");
  return p;
}

std::string peek_type(const Parts& parts) {
  std::string type;
  parse_header(parts, type);
  return type;
}

void refuse_type(const std::string& type, Family wanted) {
  const std::optional<Family> family = family_of(type);
  if (!family) throw ProtocolError(type + ": unknown message type");
  throw ProtocolError(type + ": not a " + noun(wanted) + " (it is a " + noun(*family) + ")");
}

// ---------------------------------------------------------------------------------------------------
// Scenes.

Json scene_file_json(const SceneFile& f) {
  if (is_plain_text(f.content)) return Json{{"path", f.path}, {"content", f.content}};
  return Json{{"path", f.path}, {"content_base64", base64_encode(f.content)}};
}

SceneFile read_scene_file(const Fields& f) {
  const bool text = f.has("content"), bytes = f.has("content_base64");
  if (text == bytes) Where{&f, "content"}.fail("needs exactly one of content and content_base64");
  if (text) return {f.text("path"), f.text("content")};
  std::optional<std::string> decoded = base64_decode(f.text("content_base64"));
  if (!decoded) Where{&f, "content_base64"}.fail("not padded base64");
  return {f.text("path"), std::move(*decoded)};
}

Json scene_json(const SceneSource& s) {
  Json files = Json::array();
  for (const SceneFile& f : s.files) files.push_back(scene_file_json(f));
  Json j = Json::object();
  j["name"] = s.name;
  j["text"] = s.text;
  j["files"] = std::move(files);
  return j;
}

SceneSource read_scene(const Fields& f) {
  SceneSource s;
  s.name = f.text("name");
  s.text = f.text("text");
  for (const Fields& file : f.objects("files")) s.files.push_back(read_scene_file(file));
  return s;
}

}  // namespace pd::protocol::wire
