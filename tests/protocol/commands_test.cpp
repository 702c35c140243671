#include <gtest/gtest.h>

#include <limits>

#include "protocol/protocol.h"
#include "support/protocol_cases.h"

namespace pd::protocol {
namespace {

using namespace test;  // the helpers shared by the protocol tests

// The shared helpers bound to this file's family, the scheduler commands.
std::string error_of(const Parts& parts) { return test::error_of(parts, decode_command); }
int check_every_field_required(const Parts& parts) { return test::check_every_field_required(parts, decode_command); }
int check_every_field_typed(const Parts& parts) { return test::check_every_field_typed(parts, decode_command); }

template <typename T>
T round_trip(const T& m) {
  return test::round_trip<Command>(m, decode_command);
}

// Positions that must survive bit for bit: signed zero, denormals, non-finite values (the
// scheduler decides about those), a non-terminating fraction.
std::vector<double> tricky_positions(int vertices, double offset) {
  std::vector<double> x(3 * vertices);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = offset + 0.125 * double(i);
  x[0] = -0.0;
  x[1] = std::numeric_limits<double>::denorm_min();
  x[2] = 1.0 / 3.0;
  if (x.size() > 5) {
    x[3] = 2.2e-310;  // another denormal
    x[4] = std::numeric_limits<double>::infinity();
    x[5] = std::numeric_limits<double>::quiet_NaN();
  }
  return x;
}

AssignTask full_assign() {
  AssignTask m;
  m.attempt = 41;
  m.task = 12;
  m.job = 3;
  m.kind = TaskKind::level;
  m.level = 2;
  m.first = 10;
  m.last = 20;
  m.start = 14;
  m.frames = 40;
  m.levels = 3;
  m.hessian = "galerkin";
  m.scene_hash = "0123456789abcdef";
  // A binary file (a PC2 cache's header: NUL bytes, bytes >= 0x80) travels as base64.
  m.scene = protocol::SceneSource{"scenes/flag.json", "{\"frames\": 40}\n",
                                  {{"meshes/flag.obj", "v 0 0 0\n"},
                                   {"b é.obj", "o \"q\"\n"},
                                   {"body/walk.pc2", std::string("POINTCACHE2\0\x01\0\0\0\xff\x80", 18)}}};
  m.hierarchy_hash = "9f86d081";
  m.hierarchy_blob = std::string("\x89HDF\r\n\x1a\n\0\0\xff", 11);
  m.own_before = tricky_positions(4, 1.0);
  m.own_start = tricky_positions(4, -2.0);
  m.own_kappa = 1.25e-7;
  return m;
}

AssignTask plain_assign() {
  AssignTask m = full_assign();
  m.kind = TaskKind::hierarchy;
  m.scene.reset();  // this worker was sent the scene with an earlier task
  m.hierarchy_blob.reset();
  m.own_before.reset();
  m.own_start.reset();
  m.own_kappa.reset();
  return m;
}

void expect_same(const AssignTask& a, const AssignTask& b) {
  EXPECT_EQ(a.attempt, b.attempt);
  EXPECT_EQ(a.task, b.task);
  EXPECT_EQ(a.job, b.job);
  EXPECT_EQ(a.kind, b.kind);
  EXPECT_EQ(a.level, b.level);
  EXPECT_EQ(a.first, b.first);
  EXPECT_EQ(a.last, b.last);
  EXPECT_EQ(a.start, b.start);
  EXPECT_EQ(a.frames, b.frames);
  EXPECT_EQ(a.levels, b.levels);
  EXPECT_EQ(a.hessian, b.hessian);
  EXPECT_EQ(a.scene_hash, b.scene_hash);
  ASSERT_EQ(a.scene.has_value(), b.scene.has_value());
  if (a.scene) {
    EXPECT_EQ(a.scene->name, b.scene->name);
    EXPECT_EQ(a.scene->text, b.scene->text);
    ASSERT_EQ(a.scene->files.size(), b.scene->files.size());
    for (std::size_t i = 0; i < a.scene->files.size(); ++i) {
      EXPECT_EQ(a.scene->files[i].path, b.scene->files[i].path);
      EXPECT_EQ(a.scene->files[i].content, b.scene->files[i].content);
    }
  }
  EXPECT_EQ(a.hierarchy_hash, b.hierarchy_hash);
  EXPECT_EQ(a.hierarchy_blob, b.hierarchy_blob);
  ASSERT_EQ(a.own_before.has_value(), b.own_before.has_value());
  ASSERT_EQ(a.own_start.has_value(), b.own_start.has_value());
  if (a.own_before) {
    EXPECT_TRUE(same_bits(*a.own_before, *b.own_before));
  }
  if (a.own_start) {
    EXPECT_TRUE(same_bits(*a.own_start, *b.own_start));
  }
  ASSERT_EQ(a.own_kappa.has_value(), b.own_kappa.has_value());
  if (a.own_kappa) {
    EXPECT_TRUE(same_bits({*a.own_kappa}, {*b.own_kappa}));
  }
  EXPECT_EQ(a.stitch, b.stitch);
}

// A stitch task (first 10, last 13): its guide frames 11, 12, 13 come as GuideFrame commands.
AssignTask stitch_assign() {
  AssignTask m = full_assign();
  m.first = 10;
  m.last = 13;
  m.start = 10;
  m.stitch = true;
  return m;
}

TEST(ProtocolCommands, AssignTaskOfAStitchSaysSoAndCarriesNoGuideFrames) {
  const AssignTask m = stitch_assign();
  const Parts parts = encode(m);
  ASSERT_EQ(parts.size(), 4u);  // header, blob, own_before, own_start
  EXPECT_EQ(header(parts)["stitch"], true);
  expect_same(round_trip(m), m);
  EXPECT_FALSE(header(encode(full_assign())).contains("stitch"));
}

TEST(ProtocolCommands, AStitchWithoutOwnFramesOrOfAHierarchyTaskIsRefusedBothWays) {
  AssignTask no_own = stitch_assign();
  no_own.own_before.reset();
  no_own.own_start.reset();
  EXPECT_THROW(encode(no_own), ProtocolError);
  const Parts parts = encode(stitch_assign());
  Json h = header(parts);
  h.erase("own_vertices");
  EXPECT_TRUE(has(error_of(with_header(parts, h)), "assign: field 'stitch': a stitch is a level task"));
  h = header(parts);
  h["kind"] = "hierarchy";
  EXPECT_TRUE(has(error_of(with_header(parts, h)), "assign: field 'stitch'"));
  h = header(parts);
  h["stitch"] = "yes";
  EXPECT_TRUE(has(error_of(with_header(parts, h)), "stitch"));
}

TEST(ProtocolCommands, GuideFrameRoundTripsBitForBitUnderItsOwnType) {
  const GuideFrame m{5, 6, 2, 11, tricky_positions(4, 0.25)};
  const Parts parts = encode(m);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(header(parts)["type"], "guide_frame");
  const Command c = decode_command(parts);
  ASSERT_TRUE(std::holds_alternative<GuideFrame>(c));
  const GuideFrame& g = std::get<GuideFrame>(c);
  EXPECT_EQ(g.attempt, 5);
  EXPECT_EQ(g.task, 6);
  EXPECT_EQ(g.level, 2);
  EXPECT_EQ(g.frame, 11);
  EXPECT_TRUE(same_bits(g.positions, m.positions));
  EXPECT_THROW(encode(GuideFrame{5, 6, 2, 11, {1.0, 2.0}}), ProtocolError);  // not triples
}

TEST(ProtocolCommands, WelcomeRoundTrips) {
  const Welcome w = round_trip(Welcome{7, 250});
  EXPECT_EQ(w.worker, 7);
  EXPECT_EQ(w.heartbeat_ms, 250);
}

TEST(ProtocolCommands, AssignTaskWithBlobAndOwnFramesRoundTripsEveryFieldBitForBit) {
  const AssignTask m = full_assign();
  const Parts parts = encode(m);
  // Text files as they are, the binary one as base64.
  const Json files = header(parts)["scene"]["files"];
  EXPECT_EQ(files[0]["content"], "v 0 0 0\n");
  EXPECT_EQ(files[2]["content_base64"], "UE9JTlRDQUNIRTIAAQAAAP+A");
  EXPECT_FALSE(files[2].contains("content"));
  ASSERT_EQ(parts.size(), 4u);  // header, blob, own_before, own_start
  EXPECT_EQ(parts[1], *m.hierarchy_blob);
  EXPECT_EQ(header(parts)["hierarchy_bytes"], 11);
  EXPECT_EQ(header(parts)["own_vertices"], 4);
  expect_same(round_trip(m), m);
}

TEST(ProtocolCommands, AssignTaskWithoutOptionalsOmitsThemInsteadOfNull) {
  const AssignTask m = plain_assign();
  const Parts parts = encode(m);
  ASSERT_EQ(parts.size(), 1u);
  const Json h = header(parts);
  for (const char* name : {"hierarchy_bytes", "own_vertices", "own_kappa", "hierarchy_blob", "own_before", "scene"})
    EXPECT_FALSE(h.contains(name)) << name;
  EXPECT_EQ(h["scene_hash"], "0123456789abcdef");
  expect_same(round_trip(m), m);
}

TEST(ProtocolCommands, AssignTaskDataPartsKeepTheirOrderWhenOnlyOneKindIsPresent) {
  AssignTask blob_only = full_assign();
  blob_only.own_before.reset();
  blob_only.own_start.reset();
  EXPECT_EQ(encode(blob_only).size(), 2u);
  expect_same(round_trip(blob_only), blob_only);
  AssignTask own_only = full_assign();
  own_only.hierarchy_blob.reset();
  own_only.own_kappa = std::numeric_limits<double>::infinity();  // carried as "inf"
  EXPECT_EQ(encode(own_only).size(), 3u);
  expect_same(round_trip(own_only), own_only);
  AssignTask empty_own = plain_assign();  // a level with no vertices yet still has both parts
  empty_own.own_before = std::vector<double>{};
  empty_own.own_start = std::vector<double>{};
  EXPECT_EQ(encode(empty_own).size(), 3u);
  expect_same(round_trip(empty_own), empty_own);
}

TEST(ProtocolCommands, BelowFrameCancelHeartbeatRefusedRoundTrip) {
  const BelowFrame b{5, 6, 1, 9, tricky_positions(3, 0.5)};
  const BelowFrame b2 = round_trip(b);
  EXPECT_EQ(b2.attempt, 5);
  EXPECT_EQ(b2.task, 6);
  EXPECT_EQ(b2.level, 1);
  EXPECT_EQ(b2.frame, 9);
  EXPECT_TRUE(same_bits(b2.positions, b.positions));
  EXPECT_TRUE(round_trip(BelowFrame{}).positions.empty());
  const CancelTask c = round_trip(CancelTask{8, 9, "job 3 cancelled"});
  EXPECT_EQ(c.attempt, 8);
  EXPECT_EQ(c.task, 9);
  EXPECT_EQ(c.reason, "job 3 cancelled");
  EXPECT_EQ(round_trip(SchedulerHeartbeat{}).pong, 0);
  EXPECT_EQ(round_trip(SchedulerHeartbeat{(int64_t{1} << 50) + 7}).pong, (int64_t{1} << 50) + 7);
  EXPECT_EQ(encode(SchedulerHeartbeat{}).size(), 1u);
  EXPECT_EQ(round_trip(Refused{"stale attempt 4"}).reason, "stale attempt 4");
}

TEST(ProtocolCommands, EncodingRefusesInconsistentShapes) {
  AssignTask half = full_assign();
  half.own_start.reset();
  EXPECT_THROW(encode(half), ProtocolError);
  AssignTask uneven = full_assign();
  uneven.own_start->push_back(1.0);
  EXPECT_THROW(encode(uneven), ProtocolError);
  AssignTask not_triples = full_assign();
  not_triples.own_before->pop_back();
  not_triples.own_start->pop_back();
  EXPECT_THROW(encode(not_triples), ProtocolError);
  EXPECT_THROW(encode(BelowFrame{1, 1, 0, 0, {1.0, 2.0}}), ProtocolError);
}

TEST(ProtocolCommands, MessagesOfOtherFamiliesAreRefused) {
  EXPECT_EQ(error_of(encode(FrameReport{})), "frame: not a scheduler command (it is a worker report)");
  EXPECT_EQ(error_of(encode(SubmitJob{})), "submit: not a scheduler command (it is a client request)");
  EXPECT_EQ(error_of(encode(ErrorReply{"x"})), "error: not a scheduler command (it is a scheduler reply)");
}

TEST(ProtocolCommands, EveryRequiredFieldIsCheckedByName) {
  EXPECT_EQ(check_every_field_required(encode(Welcome{1, 2})), 2);
  EXPECT_EQ(check_every_field_required(encode(plain_assign())), 13);
  EXPECT_EQ(check_every_field_required(encode(BelowFrame{1, 2, 3, 4, {1, 2, 3}})), 5);
  EXPECT_EQ(check_every_field_required(encode(GuideFrame{1, 2, 3, 4, {1, 2, 3}})), 5);
  EXPECT_EQ(check_every_field_required(encode(CancelTask{1, 2, "r"})), 3);
  EXPECT_EQ(check_every_field_required(encode(Refused{"r"})), 1);
  EXPECT_EQ(check_every_field_required(encode(SchedulerHeartbeat{5})), 1);
  // The scene's own fields, and a file's (a file needs one of content and content_base64).
  const Parts parts = encode(full_assign());
  int checked = 0;
  for (const char* name : {"name", "text", "files"}) {
    Json h = header(parts);
    h["scene"].erase(name);
    EXPECT_EQ(error_of(with_header(parts, h)), std::string("assign: field 'scene.") + name + "': missing");
    ++checked;
  }
  for (const char* name : {"path", "content"}) {
    Json h = header(parts);
    h["scene"]["files"][1].erase(name);
    EXPECT_EQ(error_of(with_header(parts, h)),
              std::string("assign: field 'scene.files[1].") + name +
                  (name == std::string("path") ? "': missing" : "': needs exactly one of content and content_base64"));
    ++checked;
  }
  Json both = header(parts);
  both["scene"]["files"][1]["content_base64"] = "AAAA";
  EXPECT_EQ(error_of(with_header(parts, both)),
            "assign: field 'scene.files[1].content': needs exactly one of content and content_base64");
  Json bad = header(parts);
  bad["scene"]["files"][2]["content_base64"] = "UE9J*";
  EXPECT_EQ(error_of(with_header(parts, bad)), "assign: field 'scene.files[2].content_base64': not padded base64");
  for (const char* hash : {"", "../../etc", "ABCDEF", "0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef0"}) {
    Json h = header(parts);
    h["scene_hash"] = hash;
    EXPECT_EQ(error_of(with_header(parts, h)), "assign: field 'scene_hash': not 1 to 64 lower-case hex digits") << hash;
    ++checked;
  }
  EXPECT_EQ(checked, 9);
}

TEST(ProtocolCommands, EveryFieldOfTheWrongTypeIsRefusedByName) {
  EXPECT_EQ(check_every_field_typed(encode(Welcome{1, 2})), 2);
  EXPECT_EQ(check_every_field_typed(encode(full_assign())), 17);  // the optional ones too
  EXPECT_EQ(check_every_field_typed(encode(BelowFrame{1, 2, 3, 4, {1, 2, 3}})), 5);
  EXPECT_EQ(check_every_field_typed(encode(GuideFrame{1, 2, 3, 4, {1, 2, 3}})), 5);
  EXPECT_EQ(check_every_field_typed(encode(CancelTask{1, 2, "r"})), 3);
  EXPECT_EQ(check_every_field_typed(encode(Refused{"r"})), 1);
  EXPECT_EQ(check_every_field_typed(encode(SchedulerHeartbeat{5})), 1);
}

TEST(ProtocolCommands, OutOfRangeValuesAreRefusedByName) {
  const Parts a = encode(plain_assign());
  EXPECT_TRUE(has(error_of(with_field(a, "attempt", -1)), "assign: field 'attempt': -1 is negative"));
  EXPECT_TRUE(has(error_of(with_field(a, "level", 3000000000LL)), "assign: field 'level': 3000000000 is out of range"));
  EXPECT_TRUE(has(error_of(with_field(a, "first", -2)), "assign: field 'first': -2 is negative"));
  EXPECT_EQ(error_of(with_field(a, "frames", 1.5)), "assign: field 'frames': expected an integer, got number 1.5");
  EXPECT_EQ(error_of(with_field(a, "kind", "sideways")),
            "assign: field 'kind': unknown task kind 'sideways' (allowed: hierarchy, level)");
  EXPECT_TRUE(has(error_of(with_field(a, "own_kappa", nullptr)), "assign: field 'own_kappa': expected a number"));
  EXPECT_TRUE(has(error_of(with_field(encode(Welcome{}), "heartbeat_ms", -5)), "welcome: field 'heartbeat_ms'"));
}

TEST(ProtocolCommands, WrongPartCountsAreRefused) {
  Parts extra = encode(Welcome{});
  extra.push_back("x");
  EXPECT_EQ(error_of(extra), "welcome: 2 parts, expected 1");
  Parts plain = encode(plain_assign());
  plain.push_back("");
  EXPECT_EQ(error_of(plain), "assign: 2 parts, expected 1");
  Parts full = encode(full_assign());
  full.push_back("");
  EXPECT_EQ(error_of(full), "assign: 5 parts, expected 4");
  full.resize(3);
  EXPECT_EQ(error_of(full), "assign: 3 parts, expected 4");
  Parts below = encode(BelowFrame{1, 2, 3, 4, {1, 2, 3}});
  below.push_back("");
  EXPECT_EQ(error_of(below), "below_frame: 3 parts, expected 2");
  below.resize(1);
  EXPECT_EQ(error_of(below), "below_frame: 1 part, expected 2");
  Parts heartbeat = encode(SchedulerHeartbeat{});
  heartbeat.push_back("");
  EXPECT_EQ(error_of(heartbeat), "heartbeat: 2 parts, expected 1");
}

TEST(ProtocolCommands, AnAttemptStartOutsideItsTaskIsRefused) {
  const Parts parts = encode(full_assign());  // frames (10, 20]
  EXPECT_EQ(error_of(with_field(parts, "start", 9)), "assign: field 'start': 9 outside [first, last) = [10, 20)");
  EXPECT_EQ(error_of(with_field(parts, "start", 20)), "assign: field 'start': 20 outside [first, last) = [10, 20)");
  EXPECT_EQ(std::get<AssignTask>(decode_command(with_field(parts, "start", 19))).start, 19);
}

TEST(ProtocolCommands, WrongPartSizesAreRefused) {
  Parts below = encode(BelowFrame{1, 2, 3, 4, tricky_positions(3, 0.0)});
  below[1].pop_back();
  EXPECT_EQ(error_of(below), "below_frame: part 1: 71 bytes, expected 3 * 3 * 8 = 72");
  below[1] += "ab";
  EXPECT_EQ(error_of(below), "below_frame: part 1: 73 bytes, expected 3 * 3 * 8 = 72");
  Parts full = encode(full_assign());
  full[2].pop_back();
  EXPECT_EQ(error_of(full), "assign: part 2: 95 bytes, expected 3 * 4 * 8 = 96");
  full = encode(full_assign());
  full[3] += "z";
  EXPECT_EQ(error_of(full), "assign: part 3: 97 bytes, expected 3 * 4 * 8 = 96");
}

TEST(ProtocolCommands, HierarchyBytesMustMatchTheBlob) {
  const Parts full = encode(full_assign());
  EXPECT_EQ(error_of(with_field(full, "hierarchy_bytes", 12)),
            "assign: part 1: 11 bytes, expected 12 (field 'hierarchy_bytes')");
  EXPECT_EQ(error_of(with_field(full, "hierarchy_bytes", 10)),
            "assign: part 1: 11 bytes, expected 10 (field 'hierarchy_bytes')");
  EXPECT_TRUE(
      has(error_of(with_field(full, "hierarchy_bytes", -1)), "assign: field 'hierarchy_bytes': -1 is negative"));
  EXPECT_TRUE(has(error_of(with_field(full, "hierarchy_bytes", int64_t{1} << 40)),
                  "assign: field 'hierarchy_bytes': 1099511627776 bytes is over the message limit"));
  // Without the size field the blob is an unexpected part.
  Json h = header(full);
  h.erase("hierarchy_bytes");
  EXPECT_EQ(error_of(with_header(full, h)), "assign: 4 parts, expected 3");
}

TEST(ProtocolCommands, NegativeAndHugeVertexCountsAreRefusedBeforeAllocating) {
  const Parts below = encode(BelowFrame{1, 2, 3, 4, {1, 2, 3}});
  EXPECT_EQ(error_of(with_field(below, "vertices", -1)), "below_frame: field 'vertices': -1 is negative");
  EXPECT_TRUE(has(error_of(with_field(below, "vertices", int64_t{1} << 61)),
                  "below_frame: field 'vertices': 2305843009213693952 vertices cannot fit in a message"));
  EXPECT_TRUE(has(error_of(with_field(below, "vertices", std::numeric_limits<uint64_t>::max())),
                  "below_frame: field 'vertices': 18446744073709551615 is out of range"));
  const Parts full = encode(full_assign());
  EXPECT_EQ(error_of(with_field(full, "own_vertices", -4)), "assign: field 'own_vertices': -4 is negative");
  EXPECT_TRUE(has(error_of(with_field(full, "own_vertices", int64_t{1} << 55)),
                  "assign: field 'own_vertices': 36028797018963968 vertices cannot fit"));
  // A count within the bound but not matching the part is a size error, not an allocation.
  EXPECT_EQ(error_of(with_field(below, "vertices", 44739242)),
            "below_frame: part 1: 24 bytes, expected 3 * 44739242 * 8 = 1073741808");
}

}  // namespace
}  // namespace pd::protocol
