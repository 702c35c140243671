#pragma once
// Internal to protocol/ (not included by users of protocol.h): what the four message families share
// to build and read the wire format described at the top of protocol.h.
//
// Encoding: header(type) starts part 0, number() puts a double into it, doubles_part() turns a
// float64 array into a data part, finish() dumps part 0 and checks the whole message's size.
// Decoding: Message opens part 0 (JSON object, version, type) and checks part counts and sizes;
// Fields reads typed header fields, throwing ProtocolError "<type>: field '<name>': <what>".
//
// Conventions beyond protocol.h:
//  - Doubles in part 0 (stats, seconds, kappa, ...) are JSON numbers when finite; JSON has no
//    infinity or NaN, so those are the strings "inf", "-inf" and "nan" (e.g. a contact_min_gap of
//    +inf with no contact). Finite doubles round-trip bit for bit (shortest round-trip digits).
//  - Ids (attempt, task, job, worker, id) are int64 >= 0; counts, levels, frames and frame ranges
//    are int >= 0; priority is any int.
//  - Strings in part 0 must be valid UTF-8 (JSON text); encoding an invalid one throws
//    ProtocolError naming the field.
//  - Fields that are not part of a message are ignored.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "protocol/protocol.h"

namespace pd::protocol::wire {

// Ordered, so that headers and `pd status --json` list keys in the structs' field order.
using Json = nlohmann::ordered_json;

// The "type" of every message, once.
constexpr char kWelcome[] = "welcome";
constexpr char kAssign[] = "assign";
constexpr char kBelowFrame[] = "below_frame";
constexpr char kGuideFrame[] = "guide_frame";
constexpr char kCancelTask[] = "cancel_task";
constexpr char kHeartbeat[] = "heartbeat";  // the scheduler's
constexpr char kRefused[] = "refused";
constexpr char kHello[] = "hello";
constexpr char kWorkerHeartbeat[] = "worker_heartbeat";
constexpr char kFrame[] = "frame";
constexpr char kTaskDone[] = "task_done";
constexpr char kTaskFailed[] = "task_failed";
constexpr char kHierarchyDone[] = "hierarchy_done";
constexpr char kGoodbye[] = "goodbye";
constexpr char kSubmit[] = "submit";
constexpr char kRefine[] = "refine";
constexpr char kStatus[] = "status";
constexpr char kFetch[] = "fetch";
constexpr char kCancelJob[] = "cancel_job";
constexpr char kRequeue[] = "requeue";
constexpr char kWorkers[] = "workers";
constexpr char kAddSlurm[] = "add_slurm_workers";
constexpr char kRemoveSlurm[] = "remove_slurm_workers";
constexpr char kSubmitted[] = "submitted";
constexpr char kAccepted[] = "accepted";
constexpr char kStatusReply[] = "status_reply";
constexpr char kFetchReply[] = "fetch_reply";
constexpr char kWorkersReply[] = "workers_reply";
constexpr char kSlurmAccepted[] = "slurm_accepted";
constexpr char kError[] = "error";

enum class Family { command, report, request, reply };

// The family of a known type name; nullopt for an unknown one.
std::optional<Family> family_of(const std::string& type);

// A float64 array part: more than this many vertices (3 doubles each) cannot fit in a message.
constexpr int64_t kMaxVertices = static_cast<int64_t>(kMaxMessageBytes / 24);

// ---------------------------------------------------------------------------------------------------
// Encoding.

// {"v": kProtocolVersion, "type": type}; the encoder adds the fields.
Json header(const char* type);
// A double as a JSON value: a number when finite, else "inf", "-inf" or "nan".
Json number(double x);
Json numbers(const std::vector<double>& xs);
// xs as little-endian float64, 8 bytes each.
std::string doubles_part(const std::vector<double>& xs);
// Throws ProtocolError "<type>: field '<field>': <size> numbers, expected a multiple of 3" unless
// xs.size() is a multiple of 3 (positions, centres of mass).
void require_triples(const char* type, const char* field, const std::vector<double>& xs);
// Part 0 is header dumped compactly, then the data parts; ProtocolError for an invalid UTF-8 string
// in the header or a message over `limit` bytes.
Parts finish(const Json& header, Parts data = {}, std::size_t limit = kMaxMessageBytes);
// JSON text with the given indent (-1: compact); ProtocolError "<what>: field '<path>': not valid
// UTF-8" for an invalid string.
std::string dump(const Json& j, int indent, const std::string& what);

// ---------------------------------------------------------------------------------------------------
// Decoding.

class Fields;

// Where a value sits, for error messages: field `name` of `fields`, element `index` if >= 0.
struct Where {
  const Fields* fields;
  std::string name;
  long index = -1;
  std::string str() const;  // "<type>: field '<path><name>[<index>]'"
  [[noreturn]] void fail(const std::string& what) const;
};

int64_t to_int64(const Json& v, const Where& w);
int to_int(const Json& v, const Where& w);      // fits int
int to_count(const Json& v, const Where& w);    // fits int, >= 0
int64_t to_id(const Json& v, const Where& w);   // int64, >= 0
double to_number(const Json& v, const Where& w);  // a number, or "inf", "-inf", "nan"
bool to_bool(const Json& v, const Where& w);
std::string to_text(const Json& v, const Where& w);

// The fields of one JSON object of a message (the header or an object inside it). Refers to the
// object: it must outlive the Fields.
class Fields {
 public:
  // path: the prefix of the object's field names in messages, e.g. "" or "jobs[0].".
  Fields(const Json& object, std::string type, std::string path);

  const std::string& type() const { return type_; }
  const std::string& path() const { return path_; }
  bool has(const char* name) const;
  const Json& get(const char* name) const;  // ProtocolError "...: missing"

  int64_t id(const char* name) const { return to_id(get(name), {this, name}); }
  int integer(const char* name) const { return to_int(get(name), {this, name}); }
  int count(const char* name) const { return to_count(get(name), {this, name}); }
  double number(const char* name) const { return to_number(get(name), {this, name}); }
  bool boolean(const char* name) const { return to_bool(get(name), {this, name}); }
  std::string text(const char* name) const { return to_text(get(name), {this, name}); }
  std::optional<double> optional_number(const char* name) const;

  const Json& array(const char* name) const;  // a JSON array
  std::vector<double> numbers(const char* name) const;
  std::vector<int> counts(const char* name) const;
  std::vector<std::string> texts(const char* name) const;
  Fields object(const char* name) const;
  std::vector<Fields> objects(const char* name) const;  // an array of objects

 private:
  const Json* object_;
  std::string type_;
  std::string path_;
};

// A received message: part 0 parsed and checked (not empty, a JSON object, "v" == kProtocolVersion,
// "type" a string, total size within `limit`). Refers to `parts`: they must outlive it.
class Message {
 public:
  explicit Message(const Parts& parts, std::size_t limit = kMaxMessageBytes);
  Message(Parts&&, std::size_t = kMaxMessageBytes) = delete;  // would dangle
  Message(const Message&) = delete;
  Message& operator=(const Message&) = delete;

  const std::string& type() const { return type_; }
  Fields fields() const { return Fields(header_, type_, ""); }

  // A vertex count field: int64 in 0..kMaxVertices (checked before anything is allocated).
  int64_t vertex_count(const char* name) const;
  // A byte count field: int64 in 0..kMaxMessageBytes.
  std::size_t byte_count(const char* name) const;

  // ProtocolError "<type>: 3 parts, expected 2" unless there are n parts.
  void expect_parts(std::size_t n) const;
  // Part `index` as 3 * vertices doubles; ProtocolError "<type>: part 1: 96 bytes, expected 3 * 5 *
  // 8 = 120" for another size.
  std::vector<double> doubles(std::size_t index, int64_t vertices) const;
  // Part `index` as bytes, which must be `bytes` long (the header field `field` gave the size).
  std::string blob(std::size_t index, std::size_t bytes, const char* field) const;

 private:
  const std::string& part(std::size_t index) const;

  const Parts& parts_;
  Json header_;
  std::string type_;
};

// Part 0's type name, without checking the version or the rest (protocol.h message_type).
std::string peek_type(const Parts& parts);

// Throws ProtocolError "<type>: not a <family noun> (it is a ...)" or "<type>: unknown message type".
[[noreturn]] void refuse_type(const std::string& type, Family wanted);

// Decodes msg with the table entry of its type; refuse_type for a type not in the table.
template <typename Variant, std::size_t N>
Variant dispatch(const Message& msg, const std::array<std::pair<const char*, Variant (*)(const Message&)>, N>& table,
                 Family family) {
  for (const auto& [name, decode] : table)
    if (msg.type() == name) return decode(msg);
  refuse_type(msg.type(), family);
}

// A job's scene in a header: {"name", "text", "files": [file, ...]}.
Json scene_json(const SceneSource& s);
// One scene file: {"path", "content"} when its bytes are plain text (OBJ files), {"path",
// "content_base64"} otherwise (PC2 caches): a JSON string holds UTF-8 text only. The job store keeps
// a job's files in the same form.
Json scene_file_json(const SceneFile& f);
SceneFile read_scene_file(const Fields& f);  // exactly one of the two content keys, valid base64
SceneSource read_scene(const Fields& f);  // f: the scene object

}  // namespace pd::protocol::wire
