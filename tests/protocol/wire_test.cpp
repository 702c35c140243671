#include "protocol/wire.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <set>

#include "protocol/protocol.h"
#include "support/protocol_cases.h"

namespace pd::protocol {
namespace {

using wire::Json;

using namespace test;  // error_of, has: the helpers shared by the protocol tests

uint64_t bits(double x) {
  uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

Parts header_only(const std::string& type, int version = kProtocolVersion) {
  return {Json{{"v", version}, {"type", type}}.dump()};
}

// Every type name with its family, written out independently of wire.h's table.
const std::vector<std::pair<std::string, std::string>> kAllTypes = {
    {"welcome", "command"},          {"assign", "command"},     {"below_frame", "command"},
    {"cancel_task", "command"},      {"heartbeat", "command"},  {"refused", "command"},
    {"hello", "report"},             {"worker_heartbeat", "report"}, {"frame", "report"},
    {"task_done", "report"},         {"task_failed", "report"}, {"hierarchy_done", "report"},
    {"submit", "request"},           {"refine", "request"},     {"status", "request"},
    {"fetch", "request"},            {"cancel_job", "request"}, {"workers", "request"},
    {"submitted", "reply"},          {"accepted", "reply"},     {"status_reply", "reply"},
    {"fetch_reply", "reply"},        {"workers_reply", "reply"}, {"error", "reply"}};

struct Decoder {
  std::string family;
  std::string noun;  // as the "not a ..." error says it
  std::function<void(const Parts&)> decode;
};

const std::vector<Decoder>& decoders() {
  static const std::vector<Decoder> d = {
      {"command", "scheduler command", [](const Parts& p) { decode_command(p); }},
      {"report", "worker report", [](const Parts& p) { decode_report(p); }},
      {"request", "client request", [](const Parts& p) { decode_request(p); }},
      {"reply", "scheduler reply", [](const Parts& p) { decode_reply(p); }}};
  return d;
}

TEST(ProtocolWire, DoublesPartIsLittleEndianFloat64WithoutHeader) {
  const std::string part = wire::doubles_part({1.0, -2.0});
  ASSERT_EQ(part.size(), 16u);
  const unsigned char one[8] = {0, 0, 0, 0, 0, 0, 0xF0, 0x3F};
  const unsigned char minus_two[8] = {0, 0, 0, 0, 0, 0, 0, 0xC0};
  EXPECT_EQ(std::memcmp(part.data(), one, 8), 0);
  EXPECT_EQ(std::memcmp(part.data() + 8, minus_two, 8), 0);
  EXPECT_TRUE(wire::doubles_part({}).empty());
}

TEST(ProtocolWire, HeaderDoublesRoundTripBitForBitAndNonFiniteAsStrings) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(wire::number(inf), Json("inf"));
  EXPECT_EQ(wire::number(-inf), Json("-inf"));
  EXPECT_EQ(wire::number(std::nan("")), Json("nan"));
  const std::vector<double> xs = {-0.0, 4.9e-324, std::numeric_limits<double>::denorm_min(), 1.0 / 3.0,
                                  std::numeric_limits<double>::max(), -1e-300, 0.1, inf, -inf};
  const Json parsed = Json::parse(Json{{"xs", wire::numbers(xs)}}.dump());
  const wire::Fields f(parsed, "frame", "");
  const std::vector<double> back = f.numbers("xs");
  ASSERT_EQ(back.size(), xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i) EXPECT_EQ(bits(back[i]), bits(xs[i])) << "element " << i;
  EXPECT_TRUE(std::isnan(wire::to_number(Json("nan"), {&f, "x"})));
}

TEST(ProtocolWire, TypedReadersNameTheTypeAndFieldAndSayWhatIsWrong) {
  const Json j = Json::parse(R"({"s": "text", "i": 7, "f": 1.5, "b": true, "neg": -3, "big": 3000000000,
      "huge": 18446744073709551615, "xs": [1, "two"], "o": {"files": [{"path": 3}]}, "n": null})");
  const wire::Fields f(j, "frame", "");
  EXPECT_EQ(f.integer("i"), 7);
  EXPECT_EQ(f.number("i"), 7.0);
  EXPECT_EQ(f.text("s"), "text");
  EXPECT_TRUE(f.boolean("b"));
  EXPECT_EQ(f.integer("neg"), -3);
  EXPECT_EQ(wire::to_int64(j["big"], {&f, "big"}), 3000000000);
  EXPECT_EQ(error_of([&] { f.integer("level"); }), "frame: field 'level': missing");
  EXPECT_EQ(error_of([&] { f.integer("s"); }), "frame: field 's': expected an integer, got string");
  EXPECT_EQ(error_of([&] { f.integer("f"); }), "frame: field 'f': expected an integer, got number 1.5");
  EXPECT_TRUE(has(error_of([&] { f.integer("big"); }), "frame: field 'big': 3000000000 is out of range"));
  EXPECT_TRUE(has(error_of([&] { f.id("huge"); }), "frame: field 'huge': 18446744073709551615 is out of range"));
  EXPECT_TRUE(has(error_of([&] { f.id("neg"); }), "frame: field 'neg': -3 is negative"));
  EXPECT_TRUE(has(error_of([&] { f.count("neg"); }), "frame: field 'neg': -3 is negative"));
  EXPECT_TRUE(has(error_of([&] { f.number("s"); }), "frame: field 's': expected a number"));
  EXPECT_TRUE(has(error_of([&] { f.number("n"); }), "frame: field 'n': expected a number"));
  EXPECT_TRUE(has(error_of([&] { f.number("n"); }), "got null"));
  EXPECT_EQ(error_of([&] { f.boolean("i"); }), "frame: field 'i': expected a boolean, got number 7");
  EXPECT_EQ(error_of([&] { f.text("b"); }), "frame: field 'b': expected a string, got boolean true");
  EXPECT_EQ(error_of([&] { f.numbers("s"); }), "frame: field 's': expected an array, got string");
  EXPECT_TRUE(has(error_of([&] { f.numbers("xs"); }), "frame: field 'xs[1]': expected a number"));
  EXPECT_TRUE(has(error_of([&] { f.texts("xs"); }), "frame: field 'xs[0]': expected a string, got number 1"));
  EXPECT_TRUE(has(error_of([&] { f.object("s"); }), "frame: field 's': expected an object, got string"));
  EXPECT_TRUE(has(error_of([&] { f.object("o").objects("files")[0].text("path"); }),
                  "frame: field 'o.files[0].path': expected a string, got number 3"));
  EXPECT_TRUE(has(error_of([&] { f.objects("xs"); }), "frame: field 'xs[0]': expected an object"));
  EXPECT_FALSE(f.optional_number("own_kappa").has_value());
  EXPECT_TRUE(has(error_of([&] { f.optional_number("n"); }), "frame: field 'n': expected a number"));
}

TEST(ProtocolWire, MessageRefusesBadEnvelopesNamingTheProblem) {
  auto open = [](const Parts& p) { return error_of([&] { wire::Message m(p); }); };
  EXPECT_TRUE(has(open({}), "message: no parts"));
  EXPECT_TRUE(has(open({"{\"v\": 1, \"type\": "}), "message: part 0 is not JSON"));
  EXPECT_TRUE(has(open({"[1, 2]"}), "message: part 0 is JSON but not an object"));
  EXPECT_EQ(open({R"({"type": "frame"})"}), "frame: field 'v': missing");
  EXPECT_EQ(open({R"({"v": "1", "type": "frame"})"}), "frame: field 'v': expected an integer, got string");
  EXPECT_EQ(open(header_only("frame", kProtocolVersion + 1)),
            "frame: protocol version " + std::to_string(kProtocolVersion + 1) + ", this program speaks " + std::to_string(kProtocolVersion));
  EXPECT_EQ(open({R"({"v": 1})"}), "message: field 'type': missing");
  EXPECT_EQ(open({R"({"v": 1, "type": 4})"}), "message: field 'type': expected a string, got number 4");
  EXPECT_EQ(open(header_only("frame")), "(no ProtocolError thrown)");
  // A whole header followed by a NUL and garbage: the parser alone would stop at the NUL.
  std::string trailing = header_only("frame")[0];
  trailing += std::string(1, '\0') + "garbage";
  EXPECT_EQ(open({trailing}), "message: part 0: a NUL byte at offset " + std::to_string(header_only("frame")[0].size()) +
                                  "; JSON text cannot hold one");
  // The parser's message quotes what it read: raw bytes are shown as '?' so the text stays sendable.
  const std::string garbage = open({"\xff\xfe\x01{"});
  EXPECT_TRUE(has(garbage, "message: part 0 is not JSON"));
  EXPECT_EQ(garbage.find_first_of("\xff\xfe\x01"), std::string::npos) << garbage;
  EXPECT_NO_THROW(encode(Refused{garbage}));
  // An absurdly long type name is shortened in messages.
  EXPECT_EQ(open(header_only(std::string(1000, 't'), kProtocolVersion + 1)),
            std::string(64, 't') + "...: protocol version " + std::to_string(kProtocolVersion + 1) +
                ", this program speaks " + std::to_string(kProtocolVersion));
}

// Found by the farm's fuzzer (tests/integration/fuzz_test.cpp): each of these once ended the scheduler.
TEST(ProtocolWire, HostileHeadersGiveShortValidUtf8ErrorsAndNeverOverflowTheStack) {
  auto open = [](const Parts& p) { return error_of([&] { wire::Message m(p); }); };
  // A long type whose byte 64 is inside a multibyte character: cut before the character, so the
  // error text stays valid UTF-8 (a JSON log line or a Refused reason with it would throw).
  const std::string type = std::string(63, 'a') + "\xc3\xa9\xe2\x82\xac";  // 63 + 'e-acute' (2) + euro (3)
  const std::string cut = open(header_only(type, kProtocolVersion + 1));
  EXPECT_EQ(cut.substr(0, 66), std::string(63, 'a') + "...") << cut;
  EXPECT_NO_THROW(Json(cut).dump()) << "not valid UTF-8";
  EXPECT_NO_THROW(encode(Refused{cut}));
  // Deep nesting is refused while parsing, before any value is built.
  for (int depth : {33, 1000, 200000}) {
    const std::string deep = R"({"v": 2, "type": "frame", "x": )" + std::string(depth, '[') + std::string(depth, ']') + "}";
    EXPECT_EQ(open({deep}), "message: part 0: JSON nested deeper than 32 levels") << depth;
  }
  const std::string ok = R"({"v": 2, "type": "frame", "x": )" + std::string(31, '[') + std::string(31, ']') + "}";
  EXPECT_FALSE(has(open({ok}), "nested"));
  // The parser quotes what it read; a megabyte of it is cut to a short text.
  const std::string unterminated = R"({"v": 2, "type": ")" + std::string(1 << 20, 'q');
  const std::string err = open({unterminated});
  EXPECT_TRUE(has(err, "message: part 0 is not JSON"));
  EXPECT_LT(err.size(), 300u) << err.substr(0, 400);
}

TEST(ProtocolWire, TotalSizeIsCheckedAgainstTheLimitWhenEncodingAndDecoding) {
  Parts parts = header_only("fetch_reply");
  parts.push_back(std::string(200, 'x'));
  EXPECT_TRUE(has(error_of([&] { wire::Message m(parts, 100); }),
                  "fetch_reply: message of " + std::to_string(parts[0].size() + 200) +
                      " bytes in 2 parts, over the limit of 100"));
  EXPECT_EQ(error_of([&] { wire::Message m(parts, parts[0].size() + 200); }), "(no ProtocolError thrown)");
  EXPECT_TRUE(has(error_of([&] { wire::finish(wire::header("fetch_reply"), {std::string(200, 'x')}, 100); }),
                  "fetch_reply: message of"));
}

TEST(ProtocolWire, PartCountsAndSizesAreCheckedWithExactMessages) {
  Parts parts = header_only("frame");
  parts.push_back(std::string(96, '\0'));
  parts.push_back("");
  const wire::Message msg(parts);
  EXPECT_EQ(error_of([&] { msg.expect_parts(2); }), "frame: 3 parts, expected 2");
  EXPECT_EQ(error_of([&] { msg.doubles(1, 5); }), "frame: part 1: 96 bytes, expected 3 * 5 * 8 = 120");
  EXPECT_EQ(msg.doubles(1, 4).size(), 12u);
  EXPECT_EQ(msg.doubles(2, 0).size(), 0u);
  EXPECT_EQ(error_of([&] { msg.blob(2, 3, "bytes"); }), "frame: part 2: 0 bytes, expected 3 (field 'bytes')");
  EXPECT_TRUE(has(error_of([&] { msg.doubles(3, 0); }), "frame: part 3 is missing"));
  const Parts header = header_only("frame");
  const wire::Message one(header);
  EXPECT_EQ(error_of([&] { one.expect_parts(2); }), "frame: 1 part, expected 2");
}

TEST(ProtocolWire, VertexAndByteCountsAreBoundedBeforeAnyAllocation) {
  auto count_error = [](const Json& n) {
    const Parts p = {Json{{"v", kProtocolVersion}, {"type", "frame"}, {"vertices", n}}.dump()};
    return error_of([&] { wire::Message(p).vertex_count("vertices"); });
  };
  EXPECT_EQ(count_error(-1), "frame: field 'vertices': -1 is negative");
  EXPECT_TRUE(has(count_error(wire::kMaxVertices + 1),
                  "frame: field 'vertices': " + std::to_string(wire::kMaxVertices + 1) + " vertices cannot fit"));
  EXPECT_TRUE(has(count_error(int64_t{1} << 62), "cannot fit in a message"));
  EXPECT_EQ(count_error(wire::kMaxVertices), "(no ProtocolError thrown)");
  const Parts p = {Json{{"v", kProtocolVersion}, {"type", "fetch_reply"}, {"bytes", kMaxMessageBytes + 1}}.dump()};
  EXPECT_TRUE(has(error_of([&] { wire::Message(p).byte_count("bytes"); }),
                  "fetch_reply: field 'bytes': 1073741825 bytes is over the message limit"));
}

TEST(ProtocolWire, InvalidUtf8IsRefusedWhenEncodingNamingTheField) {
  Hello hello;
  hello.name = "w\xff";
  EXPECT_TRUE(has(error_of([&] { encode(hello); }), "hello: field 'name': not valid UTF-8"));
  SubmitJob submit;
  // A file's content that is not plain text travels as base64 (a PC2 cache); a path must be UTF-8.
  submit.scene.files = {{"a.obj", "ok"}, {"b\xe9.obj", "v 1 2 3\n"}};
  EXPECT_TRUE(has(error_of([&] { encode(submit); }), "submit: field 'scene.files[1].path': not valid UTF-8"));
  submit.scene.files = {{"a.obj", "ok"}, {"b.obj", "v 1 2 3\n# caf\xe9\n"}};
  EXPECT_EQ(std::get<SubmitJob>(decode_request(encode(submit))).scene.files[1].content, "v 1 2 3\n# caf\xe9\n");
  StatusReply status;
  status.jobs.resize(1);
  status.jobs[0].name = "\xc3";
  EXPECT_TRUE(has(error_of([&] { to_json_text(status); }), "status: field 'jobs[0].name': not valid UTF-8"));
}

TEST(ProtocolWire, MessageTypeReadsTheTypeWithoutCheckingVersionOrFields) {
  EXPECT_EQ(message_type(header_only("frame", 7)), "frame");
  EXPECT_EQ(message_type(header_only("no_such_type")), "no_such_type");
  EXPECT_EQ(message_type(encode(Welcome{})), "welcome");
  EXPECT_TRUE(has(error_of([] { message_type({}); }), "message: no parts"));
  EXPECT_TRUE(has(error_of([] { message_type({"null"}); }), "message: part 0 is JSON but not an object"));
  EXPECT_EQ(error_of([] { message_type({R"({"v": 1.5, "type": "x"})"}); }),
            "x: field 'v': expected an integer, got number 1.5");
  EXPECT_EQ(error_of([] { message_type({R"({"v": 1, "type": []})"}); }),
            "message: field 'type': expected a string, got array");
}

// Every decoder against every type name: types of another family are refused as such before any
// field is read (the header has none), and unknown types are refused as unknown.
TEST(ProtocolWire, EachDecoderAcceptsOnlyItsOwnFamilysTypes) {
  int refused = 0;
  for (const auto& [type, family] : kAllTypes) {
    ASSERT_TRUE(wire::family_of(type).has_value()) << type;
    for (const Decoder& d : decoders()) {
      const std::string e = error_of([&] { d.decode(header_only(type)); });
      if (d.family == family) {
        EXPECT_FALSE(has(e, "not a ")) << e;
      } else {
        EXPECT_EQ(e, type + ": not a " + d.noun + " (it is a " +
                         std::find_if(decoders().begin(), decoders().end(), [&](const Decoder& x) {
                           return x.family == family;
                         })->noun + ")");
        ++refused;
      }
    }
  }
  EXPECT_EQ(refused, 24 * 3);
  for (const Decoder& d : decoders())
    EXPECT_EQ(error_of([&] { d.decode(header_only("teleport")); }), "teleport: unknown message type");
}

TEST(ProtocolWire, EveryDecoderRefusesMalformedEnvelopes) {
  const std::vector<std::pair<Parts, std::string>> cases = {
      {{}, "message: no parts"},
      {{""}, "message: part 0 is not JSON"},
      {{"\x01\x02garbage"}, "message: part 0 is not JSON"},
      {{"{\"v\":1,\"type\":\"welcome\"} trailing"}, "message: part 0 is not JSON"},
      {{"\"just a string\""}, "message: part 0 is JSON but not an object"},
      {{"[]"}, "message: part 0 is JSON but not an object"},
      {{R"({"type": "welcome"})"}, "welcome: field 'v': missing"},
      {{R"({"v": 1.0, "type": "welcome"})"}, "welcome: field 'v': expected an integer"},
      {header_only("welcome", kProtocolVersion + 1),
       "welcome: protocol version " + std::to_string(kProtocolVersion + 1) + ", this program speaks " + std::to_string(kProtocolVersion)},
      {header_only("welcome", 0), "welcome: protocol version 0, this program speaks " + std::to_string(kProtocolVersion)},
      {{R"({"v": 1})"}, "message: field 'type': missing"},
      {{R"({"v": 1, "type": null})"}, "message: field 'type': expected a string, got null"},
      {header_only("teleport"), "teleport: unknown message type"},
      {{std::string(100000, '[')}, "message: part 0: JSON nested deeper than 32 levels"},
  };
  int checked = 0;
  for (const Decoder& d : decoders()) {
    for (const auto& [parts, expected] : cases) {
      EXPECT_TRUE(has(error_of([&] { d.decode(parts); }), expected)) << d.family;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 4 * 14);
}

// One message of every type, each with data parts where it has them.
std::vector<Parts> samples() {
  AssignTask assign;
  assign.scene_hash = "00ff";
  assign.scene = protocol::SceneSource{"s.json", "{}", {{"m.obj", "v 0 0 0\n"}}};
  assign.hierarchy_blob = std::string("\x89HDF\0\xff", 6);
  assign.own_before = std::vector<double>(6, 0.5);
  assign.own_start = std::vector<double>(6, -0.5);
  assign.own_kappa = 3.0;
  FrameReport frame;
  frame.positions = {1, 2, 3, 4, 5, 6};
  frame.stats = {{"kinetic_energy", 1.5}};
  frame.center_of_mass = {0, 1, 2};
  HierarchyDone hier;
  hier.vertices = {4, 16};
  hier.blob = "hdf5 bytes";
  StatusReply status;
  status.jobs.resize(1);
  status.jobs[0].levels.resize(2);
  status.jobs[0].tasks.resize(2);
  WorkersReply workers;
  workers.workers.resize(2);
  SubmitJob submit;
  submit.scene = *assign.scene;
  return {encode(Welcome{}),
          encode(assign),
          encode(BelowFrame{1, 2, 0, 3, {1, 2, 3}}),
          encode(GuideFrame{1, 2, 1, 4, {1, 2, 3}}),
          encode(CancelTask{}),
          encode(SchedulerHeartbeat{}),
          encode(Refused{"late"}),
          encode(Hello{}),
          encode(WorkerHeartbeat{}),
          encode(frame),
          encode(TaskDone{}),
          encode(TaskFailed{}),
          encode(hier),
          encode(submit),
          encode(RefineJob{}),
          encode(StatusRequest{}),
          encode(FetchRequest{}),
          encode(CancelJob{}),
          encode(RequeueJob{}),
          encode(WorkersRequest{}),
          encode(Submitted{}),
          encode(Accepted{}),
          encode(status),
          encode(FetchReply{1, "job file"}),
          encode(workers),
          encode(ErrorReply{"no job 17"})};
}

// Values of every JSON type and of awkward shapes, to put where a field was.
std::vector<Json> odd_values() {
  return {nullptr, -1, int64_t{1} << 40, std::numeric_limits<uint64_t>::max(), -(int64_t{1} << 62), 1e300, 0.5,
          "x", "inf", true, Json::array(), Json::object(), Json::array({1, "a", nullptr}),
          Json::array({Json::array({"a"})}), Json::array({Json::array({1, 2, 3})}), Json{{"a", 1}}};
}

// Every JSON pointer of part 0's values: leaves and the arrays and objects holding them (not the root).
std::vector<Json::json_pointer> value_pointers(const Json& h) {
  std::set<std::string> seen;
  std::vector<Json::json_pointer> out;
  const Json leaves = h.flatten();
  for (auto it = leaves.begin(); it != leaves.end(); ++it) {
    for (Json::json_pointer p(it.key()); !p.empty(); p = p.parent_pointer())
      if (seen.insert(p.to_string()).second) out.push_back(p);
  }
  return out;
}

// Mutates one message at random: garbage in part 0, bytes flipped, part 0 truncated, a (possibly
// nested) field replaced by a value of another type or shape (most often: that is where the typed
// readers must hold), garbage in a data part, or a part added or removed.
Parts mutate(Parts p, std::mt19937& rng) {
  auto garbage = [&](std::size_t n) {
    std::string s(n, '\0');
    for (char& c : s) c = static_cast<char>(rng() % 256);
    return s;
  };
  switch (rng() % 9) {
    case 0: p[0] = garbage(rng() % 64); break;
    case 1:
      for (int k = 0; k < 3 && !p[0].empty(); ++k) p[0][rng() % p[0].size()] = static_cast<char>(rng() % 256);
      break;
    case 2: p[0].resize(rng() % (p[0].size() + 1)); break;
    case 3:
    case 4:
    case 5: {
      Json h = Json::parse(p[0]);
      const std::vector<Json::json_pointer> where = value_pointers(h);
      const std::vector<Json> values = odd_values();
      h[where[rng() % where.size()]] = values[rng() % values.size()];
      p[0] = h.dump();
      break;
    }
    case 6:
      if (p.size() > 1) p[1 + rng() % (p.size() - 1)] = garbage(rng() % 80);
      else p.push_back(garbage(rng() % 16));
      break;
    default:
      if (rng() % 2 && p.size() > 1) p.pop_back();
      else p.push_back(garbage(rng() % 16));
  }
  return p;
}

// Decodes p with every decoder; counts refusals and successes, fails on anything but ProtocolError.
void decode_expecting_only_protocol_errors(const Parts& p, int& thrown, int& decoded) {
  for (const Decoder& d : decoders()) {
    try {
      d.decode(p);
      ++decoded;
    } catch (const ProtocolError&) {
      ++thrown;
    } catch (const std::exception& e) {
      ADD_FAILURE() << d.family << " decoder threw a non-ProtocolError: " << e.what() << " for " << p[0];
    } catch (...) {
      ADD_FAILURE() << d.family << " decoder threw something that is not an exception for " << p[0];
    }
  }
}

TEST(ProtocolWire, EveryHeaderValueReplacedByAnyShapeOnlyEverThrowsProtocolError) {
  int thrown = 0, decoded = 0, cases = 0;
  for (const Parts& base : samples()) {
    const Json h = Json::parse(base[0]);
    for (const Json::json_pointer& where : value_pointers(h)) {
      for (const Json& value : odd_values()) {
        Json changed = h;
        changed[where] = value;
        Parts p = base;
        p[0] = changed.dump();
        decode_expecting_only_protocol_errors(p, thrown, decoded);
        ++cases;
      }
    }
  }
  EXPECT_EQ(thrown + decoded, 4 * cases);  // no decode escaped with another exception
  EXPECT_GT(cases, 24 * 16 * 3);           // every sample has a few values
  EXPECT_GT(thrown, 3 * cases);            // and most replacements are refused by their own family too
}

TEST(ProtocolWire, RandomGarbageOnlyEverThrowsProtocolError) {
  std::mt19937 rng(20240611);
  const std::vector<Parts> base = samples();
  const int cases = 1000;
  int thrown = 0, decoded = 0;
  for (int i = 0; i < cases; ++i)
    decode_expecting_only_protocol_errors(mutate(base[rng() % base.size()], rng), thrown, decoded);
  EXPECT_EQ(thrown + decoded, cases * 4);  // no decode escaped with another exception
  EXPECT_GT(thrown, cases * 3 + cases / 2);  // beyond the other families' refusals, most are refused
  EXPECT_GT(decoded, 0);  // and some mutations (a data part's bits, a value of the right type) are valid
}

}  // namespace
}  // namespace pd::protocol
