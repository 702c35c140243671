#include "support/fuzz_messages.h"

#include <poll.h>
#include <pthread.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <stdexcept>
#include <utility>
#include <variant>

#include <nlohmann/json.hpp>

#include "util/process_setup.h"

namespace pd::test {

namespace {

using Json = nlohmann::ordered_json;
using protocol::Parts;

constexpr char kPlaceholder[] = "@@FUZZ@@";  // a string value later replaced by raw bytes in the dumped text
constexpr int64_t kId = 424242;              // no test farm gives ids this large

protocol::SceneSource fuzz_scene() { return {"fuzz.json", "{}", {{"mesh.obj", "v 0 0 0\n"}}}; }

std::vector<Parts> commands() {
  protocol::AssignTask level;
  level.attempt = kId;
  level.task = kId + 1;
  level.job = kId + 2;
  level.level = 1;
  level.first = 0;
  level.last = 5;
  level.start = 2;
  level.frames = 5;
  level.levels = 2;
  level.hessian = "lagged";
  level.scene_hash = "f022";
  level.scene = fuzz_scene();
  level.hierarchy_hash = "fuzzhash";
  level.hierarchy_blob = std::string("HDF5 but not really");
  level.own_before = std::vector<double>{0.0, 0.1, 0.2};
  level.own_start = std::vector<double>{1.0, 1.1, 1.2};
  level.own_kappa = 1e3;
  protocol::AssignTask hierarchy = level;
  hierarchy.kind = protocol::TaskKind::hierarchy;
  hierarchy.start = 0;
  hierarchy.hierarchy_blob.reset();
  hierarchy.own_before.reset();
  hierarchy.own_start.reset();
  hierarchy.own_kappa.reset();
  return {protocol::encode(protocol::Welcome{kId, 1000}),
          protocol::encode(level),
          protocol::encode(hierarchy),
          protocol::encode(protocol::BelowFrame{kId, kId + 1, 0, 3, {0.0, 1.0, 2.0, 3.0, 4.0, 5.0}}),
          protocol::encode(protocol::GuideFrame{kId, kId + 1, 1, 4, {0.0, 1.0, 2.0, 3.0, 4.0, 5.0}}),
          protocol::encode(protocol::CancelTask{kId, kId + 1, "fuzz"}),
          protocol::encode(protocol::SchedulerHeartbeat{7}),
          protocol::encode(protocol::Refused{"fuzz"})};
}

std::vector<Parts> reports() {
  protocol::FrameReport frame;
  frame.attempt = kId;
  frame.task = kId + 1;
  frame.level = 0;
  frame.frame = 1;
  frame.positions = {0.0, 0.5, 1.0, 1.5, 2.0, 2.5};
  frame.stats = {{"solve_seconds", 0.01}, {"contact_min_gap", std::numeric_limits<double>::infinity()}};
  frame.center_of_mass = {0.0, 0.0, 0.0};
  protocol::HierarchyDone done;
  done.attempt = kId;
  done.task = kId + 1;
  done.hash = "fuzzhash";
  done.levels = 2;
  done.vertices = {4, 8};
  done.blob = "HDF5 but not really";
  return {protocol::encode(protocol::Hello{"fuzz", "0.0", 1, "fuzzhost", "", blas_kernel_in_use()}),
          protocol::encode(protocol::WorkerHeartbeat{kId, 0}),
          protocol::encode(frame),
          protocol::encode(protocol::TaskDone{kId, kId + 1, 0, false, 1.5}),
          protocol::encode(protocol::TaskFailed{kId, kId + 1, "fuzz"}),
          protocol::encode(done)};
}

std::vector<Parts> requests() {
  protocol::SubmitJob submit;
  submit.scene = fuzz_scene();
  return {protocol::encode(submit),
          protocol::encode(protocol::RefineJob{kId, 2}),
          protocol::encode(protocol::StatusRequest{kId}),
          protocol::encode(protocol::FetchRequest{kId}),
          protocol::encode(protocol::CancelJob{kId}),
          protocol::encode(protocol::RequeueJob{kId}),
          protocol::encode(protocol::WorkersRequest{}),
          protocol::encode(protocol::AddSlurmWorkers{2, "short", "1:00:00", 1, "1G", 2}),
          protocol::encode(protocol::RemoveSlurmWorkers{"4711_1", true})};
}

std::vector<Parts> replies() {
  protocol::JobStatus job;
  job.id = kId;
  job.name = "fuzz";
  job.levels.push_back({0, 1, 6, 4});
  protocol::TaskStatus task;
  task.id = kId + 1;
  task.worker = "w";
  job.tasks.push_back(task);
  protocol::WorkerStatus worker;
  worker.id = kId;
  worker.name = "w";
  worker.state = "idle";
  return {protocol::encode(protocol::Submitted{kId}),
          protocol::encode(protocol::Accepted{kId, "fuzz"}),
          protocol::encode(protocol::StatusReply{{job}}),
          protocol::encode(protocol::FetchReply{kId, "HDF5 but not really"}),
          protocol::encode(protocol::WorkersReply{{worker}, {{"4711_0", "RUNNING", "w", false, false, 1.0, "None"}}, 1}),
          protocol::encode(protocol::SlurmAccepted{"4711", {"4711_0"}, "fuzz"}),
          protocol::encode(protocol::ErrorReply{"fuzz"})};
}

// Pointers to every object member of j, at any depth (inside arrays too), and to every array element.
void collect_pointers(const Json& j, const Json::json_pointer& at, std::vector<Json::json_pointer>& members,
                      std::vector<Json::json_pointer>& elements) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      members.push_back(at / it.key());
      collect_pointers(it.value(), at / it.key(), members, elements);
    }
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) {
      elements.push_back(at / i);
      collect_pointers(j[i], at / i, members, elements);
    }
  }
}

// A value of some JSON type, from the awkward ones.
Json odd_value(uint64_t k) {
  switch (k % 16) {
    case 0: return nullptr;
    case 1: return true;
    case 2: return "text";
    case 3: return "";
    case 4: return Json::array();
    case 5: return Json::array({1, 2, 3});
    case 6: return Json::object();
    case 7: return Json{{"v", 2}};
    case 8: return 1.5;
    case 9: return -1;
    case 10: return 1e300;
    case 11: return std::numeric_limits<uint64_t>::max();
    case 12: return std::numeric_limits<int64_t>::min();
    case 13: return 0;
    case 14: return "inf";
    default: return Json::array({Json::array({"x", "nan"})});
  }
}

// Replaces the first quoted placeholder in text with raw (unquoted) text, or its inside with bytes.
std::string splice(std::string text, const std::string& replacement, bool keep_quotes) {
  const std::string needle = keep_quotes ? std::string(kPlaceholder) : "\"" + std::string(kPlaceholder) + "\"";
  const std::size_t at = text.find(needle);
  if (at != std::string::npos) text.replace(at, needle.size(), replacement);
  return text;
}

}  // namespace

uint64_t fuzz_seed() {
  const char* s = std::getenv("PD_FUZZ_SEED");
  return s && *s ? std::strtoull(s, nullptr, 0) : 20240611;
}

const char* family_name(Family f) {
  switch (f) {
    case Family::command: return "command";
    case Family::report: return "report";
    case Family::request: return "request";
    case Family::reply: return "reply";
  }
  return "?";
}

std::vector<Parts> valid_messages(Family family) {
  switch (family) {
    case Family::command: return commands();
    case Family::report: return reports();
    case Family::request: return requests();
    case Family::reply: return replies();
  }
  return {};
}

namespace {

std::optional<std::string> decode_here(Family family, const Parts& parts) {
  try {
    switch (family) {
      case Family::command: (void)protocol::decode_command(parts); break;
      case Family::report: (void)protocol::decode_report(parts); break;
      case Family::request: (void)protocol::decode_request(parts); break;
      case Family::reply: (void)protocol::decode_reply(parts); break;
    }
  } catch (const protocol::ProtocolError& e) {
    return std::string(e.what());
  }
  return std::nullopt;
}

// Decoding recurses once per nesting level of part 0 (nlohmann's ordered_json copies a nested value
// recursively when an object's member vector grows): about 100 000 levels overflow an 8 MB stack.
// Headers that could nest that deep are decoded on a thread with kBigStack bytes of stack, so that a
// test survives to see what the scheduler made of the same bytes.
constexpr std::size_t kBigStack = std::size_t{512} << 20;
constexpr std::size_t kShallowHeader = 16384;  // bytes: at most ~8000 levels, far below the 8 MB limit

struct DecodeCall {
  Family family;
  const Parts* parts;
  std::optional<std::string> result;
  std::exception_ptr error;
};

void* decode_call(void* p) {
  auto* c = static_cast<DecodeCall*>(p);
  try {
    c->result = decode_here(c->family, *c->parts);
  } catch (...) {
    c->error = std::current_exception();
  }
  return nullptr;
}

}  // namespace

std::optional<std::string> decode_error(Family family, const Parts& parts) {
  if (parts.empty() || parts[0].size() <= kShallowHeader) return decode_here(family, parts);
  DecodeCall call{family, &parts, std::nullopt, nullptr};
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, kBigStack);
  pthread_t thread;
  const int rc = pthread_create(&thread, &attr, decode_call, &call);
  pthread_attr_destroy(&attr);
  if (rc != 0) throw std::runtime_error("decode_error: cannot start a thread: " + std::string(std::strerror(rc)));
  pthread_join(thread, nullptr);
  if (call.error) std::rethrow_exception(call.error);
  return call.result;
}

bool decode_crashes(Family family, const Parts& parts) {
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("decode_crashes: fork: ") + std::strerror(errno));
  if (pid == 0) {
    const rlimit no_core{0, 0};
    setrlimit(RLIMIT_CORE, &no_core);  // a crash here is the expected finding, not a core file to keep
    try {
      (void)decode_here(family, parts);
    } catch (...) {
      // an exception other than ProtocolError is not a crash
    }
    _exit(0);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFSIGNALED(status);
}

MessageFuzzer::MessageFuzzer(Family target, uint64_t seed, std::size_t oversize_bytes)
    : target_(target), rng_(seed), oversize_bytes_(oversize_bytes), own_(valid_messages(target)) {
  for (Family f : {Family::command, Family::report, Family::request, Family::reply}) {
    if (f == target) continue;
    for (Parts& p : valid_messages(f)) others_.push_back(std::move(p));
  }
}

std::vector<std::string> MessageFuzzer::kinds() {
  // clang-format off
  return {"truncate", "extend", "flip_bits", "invalid_utf8", "non_json", "json_non_object", "missing_field",
          "extra_field", "mistyped_field", "wrong_version", "unknown_type", "other_family_type",
          "other_family_message", "extra_parts", "missing_parts", "wrong_part_size", "huge_count", "many_tiny_parts",
          "empty", "deep_nesting", "raw_token", "oversized"};
  // clang-format on
}

std::string MessageFuzzer::random_bytes(std::size_t n) {
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng_() & 0xff);
  return s;
}

Parts MessageFuzzer::base(bool own_family) { return own_family || others_.empty() ? pick(own_) : pick(others_); }

FuzzMessage MessageFuzzer::next() {
  using Mutation = std::string (MessageFuzzer::*)(FuzzMessage&);
  // Weights per mille; the oversized part is rare (a few MB each).
  // clang-format off
  static const std::array<std::pair<Mutation, unsigned>, 22> kTable{{
      {&MessageFuzzer::truncate, 90},         {&MessageFuzzer::extend, 50},
      {&MessageFuzzer::flip_bits, 90},        {&MessageFuzzer::invalid_utf8, 50},
      {&MessageFuzzer::non_json, 50},         {&MessageFuzzer::json_non_object, 30},
      {&MessageFuzzer::missing_field, 90},    {&MessageFuzzer::extra_field, 20},
      {&MessageFuzzer::mistyped_field, 110},  {&MessageFuzzer::wrong_version, 50},
      {&MessageFuzzer::unknown_type, 50},     {&MessageFuzzer::other_family_type, 40},
      {&MessageFuzzer::other_family_message, 30}, {&MessageFuzzer::extra_parts, 40},
      {&MessageFuzzer::missing_parts, 40},    {&MessageFuzzer::wrong_part_size, 50},
      {&MessageFuzzer::huge_count, 50},       {&MessageFuzzer::many_tiny_parts, 10},
      {&MessageFuzzer::empty, 20},            {&MessageFuzzer::deep_nesting, 5},
      {&MessageFuzzer::raw_token, 40},        {&MessageFuzzer::oversized, 1},
  }};
  // clang-format on
  unsigned total = 0;
  for (const auto& [f, w] : kTable) total += w;
  uint64_t r = below(total);
  for (const auto& [f, w] : kTable) {
    if (r < w) {
      if (f == &MessageFuzzer::oversized && oversize_bytes_ == 0) break;
      FuzzMessage m;
      m.kind = (this->*f)(m);
      return m;
    }
    r -= w;
  }
  FuzzMessage m;
  m.kind = truncate(m);
  return m;
}

std::string MessageFuzzer::truncate(FuzzMessage& m) {
  m.parts = base(chance(85));
  const std::size_t at = below(m.parts[0].size());
  m.parts[0].resize(at);
  m.mutation = "part 0 cut to " + std::to_string(at) + " bytes";
  return "truncate";
}

std::string MessageFuzzer::extend(FuzzMessage& m) {
  static const std::vector<std::string> kTails = {"}", "]", "x", ",", "{}", "\"", " null", "\x00", "\xff", "{\"v\":2}"};
  m.parts = base(chance(85));
  const std::string tail = chance(50) ? pick(kTails) : random_bytes(1 + below(64));
  m.parts[0] += tail;
  m.mutation = "part 0 extended by " + std::to_string(tail.size()) + " bytes";
  return "extend";
}

std::string MessageFuzzer::flip_bits(FuzzMessage& m) {
  m.parts = base(chance(85));
  const std::size_t part = chance(80) ? 0 : below(m.parts.size());
  std::string& p = m.parts[part];
  const uint64_t flips = 1 + below(8);
  for (uint64_t k = 0; k < flips && !p.empty(); ++k) p[below(p.size())] ^= static_cast<char>(1u << below(8));
  m.mutation = std::to_string(flips) + " bits flipped in part " + std::to_string(part);
  return "flip_bits";
}

std::string MessageFuzzer::invalid_utf8(FuzzMessage& m) {
  // clang-format off
  static const std::vector<std::string> kBad = {"\xff", "\xc3", "\xc0\xaf", "\xed\xa0\x80", "\xf4\x90\x80\x80",
                                                "a\x80" "b", "\xe2\x82", "\xf8\x88\x80\x80\x80", "\xc3\x28"};
  // clang-format on
  m.parts = base(chance(85));
  Json h = Json::parse(m.parts[0]);
  std::vector<Json::json_pointer> members, elements;
  collect_pointers(h, Json::json_pointer(), members, elements);
  const std::string bad = pick(kBad);
  if (chance(30) || members.empty()) {
    h[kPlaceholder] = 1;  // in a key
  } else {
    h[pick(members)] = std::string(kPlaceholder) + "tail";
  }
  m.parts[0] = splice(h.dump(), bad, true);
  m.mutation = "invalid UTF-8 (" + std::to_string(bad.size()) + " bytes) in a string of part 0";
  return "invalid_utf8";
}

std::string MessageFuzzer::non_json(FuzzMessage& m) {
  // clang-format off
  static const std::vector<std::string> kJunk = {"", " ", "{", "}", "nul", "{\"v\":", "{'v':2}", std::string(1, '\0'),
                                                 "v=2&type=frame", "<xml/>", "{\"v\":2,\"type\":\"frame\"",
                                                 "\xef\xbb\xbf{}"};
  // clang-format on
  m.parts = base(chance(85));
  m.parts[0] = chance(50) ? pick(kJunk) : random_bytes(1 + below(300));
  m.mutation = "part 0 not JSON (" + std::to_string(m.parts[0].size()) + " bytes)";
  return "non_json";
}

std::string MessageFuzzer::json_non_object(FuzzMessage& m) {
  static const std::vector<std::string> kValues = {
      "[]", "42", "\"frame\"", "null", "true", "[{\"v\":2,\"type\":\"frame\"}]", "-0.5", "\"{\\\"v\\\":2}\"", "[[[]]]"};
  m.parts = base(chance(85));
  m.parts[0] = pick(kValues);
  m.mutation = "part 0 is " + m.parts[0];
  return "json_non_object";
}

std::string MessageFuzzer::missing_field(FuzzMessage& m) {
  m.parts = base(chance(85));
  Json h = Json::parse(m.parts[0]);
  std::vector<Json::json_pointer> members, elements;
  collect_pointers(h, Json::json_pointer(), members, elements);
  const Json::json_pointer p = pick(members);
  h[p.parent_pointer()].erase(p.back());
  m.parts[0] = h.dump();
  m.mutation = "field " + p.to_string() + " removed";
  return "missing_field";
}

std::string MessageFuzzer::extra_field(FuzzMessage& m) {
  m.parts = base(chance(85));
  Json h = Json::parse(m.parts[0]);
  const std::string key = chance(50) ? "extra" : "x" + std::to_string(below(1000));
  h[key] = odd_value(below(16));
  m.parts[0] = h.dump();
  m.mutation = "extra field " + key;
  return "extra_field";
}

std::string MessageFuzzer::mistyped_field(FuzzMessage& m) {
  m.parts = base(chance(85));
  Json h = Json::parse(m.parts[0]);
  std::vector<Json::json_pointer> members, elements;
  collect_pointers(h, Json::json_pointer(), members, elements);
  const bool element = !elements.empty() && chance(20);
  const Json::json_pointer p = element ? pick(elements) : pick(members);
  const uint64_t k = below(16);
  h[p] = odd_value(k);
  m.parts[0] = h.dump();
  m.mutation = "field " + p.to_string() + " set to " + odd_value(k).dump();
  return "mistyped_field";
}

std::string MessageFuzzer::wrong_version(FuzzMessage& m) {
  static const std::vector<Json> kVersions = {0, 1, 3, -1, 2147483648LL, "2", 2.0, nullptr, Json::array({2}), 99};
  m.parts = base(chance(85));
  Json h = Json::parse(m.parts[0]);
  const Json v = pick(kVersions);
  if (chance(15)) {
    h.erase("v");
  } else {
    h["v"] = v;
  }
  m.parts[0] = h.dump();
  m.mutation = "v = " + (h.contains("v") ? h["v"].dump() : std::string("(removed)"));
  return "wrong_version";
}

std::string MessageFuzzer::unknown_type(FuzzMessage& m) {
  // clang-format off
  static const std::vector<std::string> kTypes = {"", "FRAME", "frame ", " hello", "fram", "hello\n", "heartbeat2",
                                                  "null", std::string("fr\0ame", 6), "\xc3\xa9t\xc3\xa9",
                                                  "frame\xf0\x9f\x98\x80"};
  // clang-format on
  static const std::vector<std::string> kWide = {"\xc3\xa9", "\xe2\x82\xac", "\xf0\x9d\x84\x9e"};  // 2, 3, 4 bytes
  m.parts = base(chance(85));
  Json h = Json::parse(m.parts[0]);
  std::string type;
  if (chance(50)) {
    type = pick(kTypes);
  } else {
    // Long names: ASCII then multi-byte characters around byte 64, where messages shorten a type.
    type = std::string(50 + below(20), 'a');
    const uint64_t n = 1 + below(4);
    for (uint64_t k = 0; k < n; ++k) type += pick(kWide);
    if (chance(30)) type += std::string(below(2000), 'z');
  }
  h["type"] = type;
  m.parts[0] = h.dump();
  m.mutation = "type of " + std::to_string(type.size()) + " bytes";
  return "unknown_type";
}

std::string MessageFuzzer::other_family_type(FuzzMessage& m) {
  m.parts = base(true);
  Json h = Json::parse(m.parts[0]);
  const Json other = Json::parse(pick(others_)[0]);
  h["type"] = other["type"];
  m.parts[0] = h.dump();
  m.mutation = "type set to " + other["type"].get<std::string>();
  return "other_family_type";
}

std::string MessageFuzzer::other_family_message(FuzzMessage& m) {
  m.parts = base(false);
  m.mutation = "a valid " + Json::parse(m.parts[0])["type"].get<std::string>() + " of another family";
  return "other_family_message";
}

std::string MessageFuzzer::extra_parts(FuzzMessage& m) {
  m.parts = base(chance(85));
  const uint64_t n = 1 + below(3);
  for (uint64_t k = 0; k < n; ++k) m.parts.push_back(chance(50) ? std::string() : random_bytes(below(64)));
  m.mutation = std::to_string(n) + " parts added";
  return "extra_parts";
}

std::string MessageFuzzer::missing_parts(FuzzMessage& m) {
  m.parts = base(chance(85));
  if (m.parts.size() > 1 && chance(60)) {
    m.parts.pop_back();
    m.mutation = "last data part dropped";
  } else if (m.parts.size() > 1) {
    m.parts.erase(m.parts.begin());
    m.mutation = "part 0 dropped (a data part comes first)";
  } else {
    m.parts.push_back(m.parts[0]);
    m.parts[0] = random_bytes(below(24));
    m.mutation = "header moved to part 1";
  }
  return "missing_parts";
}

std::string MessageFuzzer::wrong_part_size(FuzzMessage& m) {
  // Prefer messages that have data parts (frame, hierarchy_done, assign, below_frame, fetch_reply).
  for (int tries = 0; tries < 8; ++tries) {
    m.parts = base(chance(85));
    if (m.parts.size() > 1) break;
  }
  if (m.parts.size() == 1) m.parts.push_back(std::string());
  const std::size_t part = 1 + below(m.parts.size() - 1);
  std::string& p = m.parts[part];
  const std::size_t before = p.size();
  switch (below(4)) {
    case 0: p.resize(p.size() + 1 + below(24), '\x7f'); break;
    case 1: p.resize(p.empty() ? 0 : below(p.size())); break;
    case 2: p.clear(); break;
    default: p.resize(p.size() + 8, '\0'); break;  // one double too many
  }
  m.mutation = "part " + std::to_string(part) + " resized from " + std::to_string(before) + " to " +
               std::to_string(p.size()) + " bytes";
  return "wrong_part_size";
}

std::string MessageFuzzer::huge_count(FuzzMessage& m) {
  // clang-format off
  static const std::vector<const char*> kFields = {"vertices", "bytes", "hierarchy_bytes", "own_vertices", "levels",
                                                   "frame", "level", "cores", "attempt", "task", "job", "frames",
                                                   "subsets", "priority", "heartbeat_ms", "unconverged_steps"};
  // clang-format on
  static const std::vector<Json> kHuge = {2147483648LL,
                                          9007199254740993LL,
                                          4611686018427387904LL,
                                          std::numeric_limits<int64_t>::max(),
                                          std::numeric_limits<uint64_t>::max(),
                                          static_cast<int64_t>(protocol::kMaxMessageBytes / 24),
                                          static_cast<int64_t>(protocol::kMaxMessageBytes / 24 + 1),
                                          static_cast<int64_t>(protocol::kMaxMessageBytes),
                                          static_cast<int64_t>(protocol::kMaxMessageBytes + 1),
                                          std::numeric_limits<int64_t>::min(),
                                          -2147483649LL,
                                          1e19};
  m.parts = base(chance(85));
  Json h = Json::parse(m.parts[0]);
  std::vector<std::string> present;
  for (const char* f : kFields)
    if (h.contains(f)) present.push_back(f);
  const std::string field = present.empty() ? std::string(pick(kFields)) : pick(present);
  const Json value = pick(kHuge);
  h[field] = value;
  m.parts[0] = h.dump();
  m.mutation = field + " = " + value.dump();
  return "huge_count";
}

std::string MessageFuzzer::many_tiny_parts(FuzzMessage& m) {
  m.parts = base(chance(85));
  const uint64_t n = 100 + below(3000);
  for (uint64_t k = 0; k < n; ++k) m.parts.push_back(std::string(below(3), 'p'));
  m.mutation = std::to_string(n) + " tiny parts added";
  return "many_tiny_parts";
}

std::string MessageFuzzer::empty(FuzzMessage& m) {
  static const std::vector<Parts> kEmpty = {{""}, {"", ""}, {"{}"}, {" "}, {"", "{\"v\":2,\"type\":\"hello\"}"}};
  m.parts = pick(kEmpty);
  m.mutation = "empty: " + std::to_string(m.parts.size()) + " parts";
  return "empty";
}

std::string MessageFuzzer::deep_nesting(FuzzMessage& m) {
  // 100 000 levels overflow pd-scheduler's 8 MB stack (about 58 000 in some builds); 200 000 any build's.
  static const std::vector<std::size_t> kDepths = {100, 1000, 10000, 100000, 200000};
  m.parts = base(chance(85));
  Json h = Json::parse(m.parts[0]);
  std::vector<Json::json_pointer> members, elements;
  collect_pointers(h, Json::json_pointer(), members, elements);
  const std::size_t depth = pick(kDepths);
  const bool objects = chance(30), balanced = chance(70);
  std::string value;
  value.reserve(depth * 6);
  for (std::size_t k = 0; k < depth; ++k) value += objects ? "{\"a\":" : "[";
  value += "0";
  if (balanced)
    for (std::size_t k = 0; k < depth; ++k) value += objects ? "}" : "]";
  h[pick(members)] = kPlaceholder;
  m.parts[0] = splice(h.dump(), value, false);
  m.mutation = std::string(balanced ? "balanced " : "unclosed ") + (objects ? "objects" : "arrays") + " nested " +
               std::to_string(depth) + " deep";
  return "deep_nesting";
}

std::string MessageFuzzer::raw_token(FuzzMessage& m) {
  static const std::vector<std::string> kTokens = {"1e400",
                                                   "-1e400",
                                                   "-0",
                                                   "1.0",
                                                   "2.5e1",
                                                   "01",
                                                   "0x10",
                                                   "NaN",
                                                   "Infinity",
                                                   "-",
                                                   "+1",
                                                   "1e",
                                                   ".5",
                                                   "tru",
                                                   "'single'",
                                                   "\"\\ud800\"",
                                                   "\"\\udc00\\ud800\"",
                                                   "\"\\u0000\"",
                                                   "\"\\x41\"",
                                                   "18446744073709551616",
                                                   "-9223372036854775809",
                                                   "99999999999999999999999",
                                                   "\"a\tb\"",
                                                   "[1,]",
                                                   "{\"a\":}",
                                                   "{\"a\" 1}",
                                                   "[1 2]"};
  m.parts = base(chance(85));
  Json h = Json::parse(m.parts[0]);
  std::vector<Json::json_pointer> members, elements;
  collect_pointers(h, Json::json_pointer(), members, elements);
  const std::string token = pick(kTokens);
  h[pick(members)] = kPlaceholder;
  m.parts[0] = splice(h.dump(), token, false);
  m.mutation = "a field's value written as " + token;
  return "raw_token";
}

std::string MessageFuzzer::oversized(FuzzMessage& m) {
  const std::size_t n = oversize_bytes_ + below(oversize_bytes_ / 4 + 1);
  m.parts = base(true);
  switch (below(5)) {
    case 0: {  // a valid header padded with a long string, one required field gone
      Json h = Json::parse(m.parts[0]);
      h["pad"] = std::string(n, 'x');
      h.erase("v");
      m.parts[0] = h.dump();
      m.mutation = "header of " + std::to_string(m.parts[0].size()) + " bytes (padding, no v)";
      break;
    }
    case 1:  // a data part of n bytes, whatever the header declares
      if (m.parts.size() == 1) m.parts.emplace_back();
      m.parts[1] = random_bytes(n);
      m.mutation = "part 1 of " + std::to_string(n) + " bytes";
      break;
    case 2:  // an unterminated string
      m.parts[0] = "\"" + std::string(n, 'a');
      m.mutation = "part 0 an unterminated string of " + std::to_string(n) + " bytes";
      break;
    case 3:
      m.parts[0] = random_bytes(n);
      m.mutation = "part 0 of " + std::to_string(n) + " random bytes";
      break;
    default:
      m.parts.push_back(std::string(n, '\0'));
      m.mutation = "an extra part of " + std::to_string(n) + " bytes";
      break;
  }
  return "oversized";
}

bool valid_utf8(const std::string& s) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t n = 0;
    uint32_t cp = 0;
    if (c < 0x80) {
      ++i;
      continue;
    }
    if ((c & 0xe0) == 0xc0) {
      n = 1;
      cp = c & 0x1f;
    } else if ((c & 0xf0) == 0xe0) {
      n = 2;
      cp = c & 0x0f;
    } else if ((c & 0xf8) == 0xf0) {
      n = 3;
      cp = c & 0x07;
    } else
      return false;
    for (std::size_t k = 1; k <= n; ++k) {
      if (i + k >= s.size()) return false;
      const auto d = static_cast<unsigned char>(s[i + k]);
      if ((d & 0xc0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3f);
    }
    static constexpr uint32_t kMin[] = {0, 0x80, 0x800, 0x10000};
    if (cp < kMin[n] || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return false;
    i += n + 1;
  }
  return true;
}

std::string describe_parts(const Parts& parts, std::size_t bytes) {
  std::string s = std::to_string(parts.size()) + " parts (";
  for (std::size_t k = 0; k < parts.size() && k < 4; ++k) s += (k ? ", " : "") + std::to_string(parts[k].size());
  if (parts.size() > 4) s += ", ...";
  s += " bytes)";
  if (parts.empty()) return s;
  s += ", part 0: ";
  const std::string& p = parts[0];
  for (std::size_t k = 0; k < p.size() && k < bytes; ++k) {
    const auto c = static_cast<unsigned char>(p[k]);
    if (c >= 0x20 && c < 0x7f && c != '\\') {
      s += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      s += buf;
    }
  }
  if (p.size() > bytes) s += "...";
  return s;
}

}  // namespace pd::test
