#include <gtest/gtest.h>

#include <limits>

#include "protocol/protocol.h"
#include "support/protocol_cases.h"

namespace pd::protocol {
namespace {

using namespace test;  // the helpers shared by the protocol tests

// The shared helpers bound to this file's family, the worker reports.
std::string error_of(const Parts& parts) { return test::error_of(parts, decode_report); }
int check_every_field_required(const Parts& parts) { return test::check_every_field_required(parts, decode_report); }
int check_every_field_typed(const Parts& parts) { return test::check_every_field_typed(parts, decode_report); }

template <typename T>
T round_trip(const T& m) {
  return test::round_trip<Report>(m, decode_report);
}

FrameReport sample_frame() {
  FrameReport m;
  m.attempt = 17;
  m.task = 4;
  m.level = 1;
  m.frame = 33;
  m.positions = {-0.0, std::numeric_limits<double>::denorm_min(), 1.0 / 3.0, 1e300, -2.5,
                 std::numeric_limits<double>::quiet_NaN()};
  // Names not in alphabetical order and non-finite values: order and values must survive.
  m.stats = {{"newton_iterations", 4.0},
             {"kinetic_energy", 1.0e-17},
             {"contact_min_gap", std::numeric_limits<double>::infinity()},
             {"energy_bending", -0.0},
             {"assemble_seconds", 4.9e-324}};
  m.center_of_mass = {0.1, 0.2, 0.3, -1.0, -0.0, 2.2e-310};
  return m;
}

HierarchyDone sample_hierarchy() {
  HierarchyDone m;
  m.attempt = 2;
  m.task = 1;
  m.hash = "e3b0c442";
  m.levels = 3;
  m.vertices = {64, 256, 1024};
  m.blob = std::string("\x89HDF\r\n\x1a\n\0\0\0\xfe", 12);
  return m;
}

TEST(ProtocolReports, HelloAndHeartbeatRoundTrip) {
  const Hello h = round_trip(Hello{"w1", "0.4.0", 16, "node-07", "4711_3", "Haswell"});
  EXPECT_EQ(h.name, "w1");
  EXPECT_EQ(h.blas_kernel, "Haswell");
  EXPECT_EQ(h.slurm_job, "4711_3");
  EXPECT_EQ(h.version, "0.4.0");
  EXPECT_EQ(h.cores, 16);
  EXPECT_EQ(h.host, "node-07");
  EXPECT_EQ(round_trip(WorkerHeartbeat{99}).attempt, 99);
  EXPECT_EQ(round_trip(WorkerHeartbeat{0}).attempt, 0);
  const WorkerHeartbeat ping = round_trip(WorkerHeartbeat{4, 123456789});
  EXPECT_EQ(ping.attempt, 4);
  EXPECT_EQ(ping.ping, 123456789);
}

TEST(ProtocolReports, FrameReportRoundTripsBitForBitKeepingStatOrder) {
  const FrameReport m = sample_frame();
  const Parts parts = encode(m);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[1].size(), 6 * sizeof(double));
  EXPECT_EQ(header(parts)["vertices"], 2);
  const FrameReport b = round_trip(m);
  EXPECT_EQ(b.attempt, m.attempt);
  EXPECT_EQ(b.task, m.task);
  EXPECT_EQ(b.level, m.level);
  EXPECT_EQ(b.frame, m.frame);
  EXPECT_TRUE(same_bits(b.positions, m.positions));
  ASSERT_EQ(b.stats.size(), m.stats.size());
  for (std::size_t i = 0; i < m.stats.size(); ++i) {
    EXPECT_EQ(b.stats[i].first, m.stats[i].first);
    EXPECT_TRUE(same_bits(b.stats[i].second, m.stats[i].second)) << m.stats[i].first;
  }
  EXPECT_TRUE(same_bits(b.center_of_mass, m.center_of_mass));
  const FrameReport empty = round_trip(FrameReport{});
  EXPECT_TRUE(empty.positions.empty() && empty.stats.empty() && empty.center_of_mass.empty());
}

TEST(ProtocolReports, TaskDoneFailedAndHierarchyDoneRoundTrip) {
  const TaskDone d = round_trip(TaskDone{5, 6, 2, true, 12.75});
  EXPECT_EQ(d.attempt, 5);
  EXPECT_EQ(d.task, 6);
  EXPECT_EQ(d.unconverged_steps, 2);
  EXPECT_TRUE(d.vertical_start);
  EXPECT_TRUE(same_bits(d.seconds, 12.75));
  EXPECT_FALSE(round_trip(TaskDone{5, 6, 0, false, 0.0}).vertical_start);
  const Goodbye g = round_trip(Goodbye{9, "stopping on a signal during attempt 9"});
  EXPECT_EQ(g.attempt, 9);
  EXPECT_EQ(g.reason, "stopping on a signal during attempt 9");
  const TaskFailed f = round_trip(TaskFailed{7, 8, "scenes/flag.json: no safe upsampling at frame 12"});
  EXPECT_EQ(f.attempt, 7);
  EXPECT_EQ(f.task, 8);
  EXPECT_EQ(f.message, "scenes/flag.json: no safe upsampling at frame 12");
  EXPECT_EQ(f.failure, FailureKind::error);
  const TaskFailed refused = round_trip(TaskFailed{7, 8, "safe upsampling: ...", FailureKind::vertical_start_refused});
  EXPECT_EQ(refused.failure, FailureKind::vertical_start_refused);
  const HierarchyDone m = sample_hierarchy();
  const Parts parts = encode(m);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[1], m.blob);
  const HierarchyDone h = round_trip(m);
  EXPECT_EQ(h.attempt, m.attempt);
  EXPECT_EQ(h.task, m.task);
  EXPECT_EQ(h.hash, m.hash);
  EXPECT_EQ(h.levels, m.levels);
  EXPECT_EQ(h.vertices, m.vertices);
  EXPECT_EQ(h.blob, m.blob);
}

TEST(ProtocolReports, EncodingRefusesPositionsOrCentresNotInTriples) {
  FrameReport m = sample_frame();
  m.positions.pop_back();
  EXPECT_THROW(encode(m), ProtocolError);
  m = sample_frame();
  m.center_of_mass.push_back(1.0);
  EXPECT_THROW(encode(m), ProtocolError);
}

TEST(ProtocolReports, MessagesOfOtherFamiliesAreRefused) {
  EXPECT_EQ(error_of(encode(BelowFrame{})), "below_frame: not a worker report (it is a scheduler command)");
  EXPECT_EQ(error_of(encode(StatusRequest{})), "status: not a worker report (it is a client request)");
  EXPECT_EQ(error_of(encode(Submitted{})), "submitted: not a worker report (it is a scheduler reply)");
}

TEST(ProtocolReports, EveryRequiredFieldIsCheckedByName) {
  EXPECT_EQ(check_every_field_required(encode(Hello{"w", "1", 2, "h", "9", "k"})), 6);
  EXPECT_EQ(check_every_field_required(encode(WorkerHeartbeat{3})), 2);
  EXPECT_EQ(check_every_field_required(encode(sample_frame())), 7);
  EXPECT_EQ(check_every_field_required(encode(TaskDone{1, 2, 3, true, 4.0})), 5);
  EXPECT_EQ(check_every_field_required(encode(TaskFailed{1, 2, "m"})), 4);
  EXPECT_EQ(check_every_field_required(encode(Goodbye{1, "m"})), 2);
  EXPECT_EQ(check_every_field_required(encode(sample_hierarchy())), 6);
}

TEST(ProtocolReports, EveryFieldOfTheWrongTypeIsRefusedByName) {
  EXPECT_EQ(check_every_field_typed(encode(Hello{"w", "1", 2, "h", "9", "k"})), 6);
  EXPECT_EQ(check_every_field_typed(encode(WorkerHeartbeat{3})), 2);
  EXPECT_EQ(check_every_field_typed(encode(sample_frame())), 7);
  EXPECT_EQ(check_every_field_typed(encode(TaskDone{1, 2, 3, true, 4.0})), 5);
  EXPECT_EQ(check_every_field_typed(encode(TaskFailed{1, 2, "m"})), 4);
  EXPECT_EQ(check_every_field_typed(encode(Goodbye{1, "m"})), 2);
  EXPECT_EQ(check_every_field_typed(encode(sample_hierarchy())), 6);
}

TEST(ProtocolReports, MalformedStatsCentresAndCountsAreRefusedByName) {
  const Parts frame = encode(sample_frame());
  EXPECT_TRUE(has(error_of(with_field(frame, "stats", Json::parse(R"([["a", 1], ["b"]])"))),
                  "frame: field 'stats[1]': expected a [name, number] pair"));
  EXPECT_TRUE(has(error_of(with_field(frame, "stats", Json::parse(R"([[1, 1]])"))),
                  "frame: field 'stats[0]': expected a string, got number 1"));
  EXPECT_TRUE(has(error_of(with_field(frame, "stats", Json::parse(R"([["a", "fast"]])"))),
                  "frame: field 'stats[0]': expected a number"));
  EXPECT_TRUE(has(error_of(with_field(frame, "stats", Json::parse(R"({"a": 1})"))),
                  "frame: field 'stats': expected an array, got object"));
  EXPECT_EQ(error_of(with_field(frame, "center_of_mass", Json::array({1, 2, 3, 4}))),
            "frame: field 'center_of_mass': 4 numbers, expected a multiple of 3");
  EXPECT_TRUE(has(error_of(with_field(frame, "center_of_mass", Json::array({1, nullptr, 3}))),
                  "frame: field 'center_of_mass[1]': expected a number"));
  EXPECT_TRUE(has(error_of(with_field(frame, "level", -1)), "frame: field 'level': -1 is negative"));
  EXPECT_TRUE(has(error_of(with_field(frame, "task", -7)), "frame: field 'task': -7 is negative"));
  EXPECT_TRUE(has(error_of(with_field(encode(Hello{}), "cores", 1e10)), "hello: field 'cores': expected an integer"));
  EXPECT_TRUE(has(error_of(with_field(encode(TaskDone{}), "vertical_start", 1)),
                  "task_done: field 'vertical_start': expected a boolean, got number 1"));
  EXPECT_TRUE(has(error_of(with_field(encode(sample_hierarchy()), "vertices", Json::array({64, -1}))),
                  "hierarchy_done: field 'vertices[1]': -1 is negative"));
}

TEST(ProtocolReports, WrongPartCountsAreRefused) {
  Parts frame = encode(sample_frame());
  frame.push_back("");
  EXPECT_EQ(error_of(frame), "frame: 3 parts, expected 2");
  frame.resize(1);
  EXPECT_EQ(error_of(frame), "frame: 1 part, expected 2");
  Parts hier = encode(sample_hierarchy());
  hier.push_back("");
  EXPECT_EQ(error_of(hier), "hierarchy_done: 3 parts, expected 2");
  hier.resize(1);
  EXPECT_EQ(error_of(hier), "hierarchy_done: 1 part, expected 2");
  Parts hello = encode(Hello{});
  hello.push_back("");
  EXPECT_EQ(error_of(hello), "hello: 2 parts, expected 1");
  Parts done = encode(TaskDone{});
  done.push_back("x");
  EXPECT_EQ(error_of(done), "task_done: 2 parts, expected 1");
}

TEST(ProtocolReports, WrongPartSizesAreRefused) {
  Parts frame = encode(sample_frame());
  frame[1].pop_back();
  EXPECT_EQ(error_of(frame), "frame: part 1: 47 bytes, expected 3 * 2 * 8 = 48");
  frame[1] += "xy";
  EXPECT_EQ(error_of(frame), "frame: part 1: 49 bytes, expected 3 * 2 * 8 = 48");
  Parts hier = encode(sample_hierarchy());
  hier[1].pop_back();
  EXPECT_EQ(error_of(hier), "hierarchy_done: part 1: 11 bytes, expected 12 (field 'bytes')");
  hier[1] += "ab";
  EXPECT_EQ(error_of(hier), "hierarchy_done: part 1: 13 bytes, expected 12 (field 'bytes')");
  EXPECT_TRUE(has(error_of(with_field(encode(sample_hierarchy()), "bytes", -12)),
                  "hierarchy_done: field 'bytes': -12 is negative"));
}

TEST(ProtocolReports, NegativeAndHugeVertexCountsAreRefusedBeforeAllocating) {
  const Parts frame = encode(sample_frame());
  EXPECT_EQ(error_of(with_field(frame, "vertices", -2)), "frame: field 'vertices': -2 is negative");
  EXPECT_TRUE(has(error_of(with_field(frame, "vertices", int64_t{1} << 62)),
                  "frame: field 'vertices': 4611686018427387904 vertices cannot fit in a message"));
  EXPECT_TRUE(has(error_of(with_field(frame, "vertices", 44739243)),
                  "frame: field 'vertices': 44739243 vertices cannot fit"));
  EXPECT_EQ(error_of(with_field(frame, "vertices", 5)), "frame: part 1: 48 bytes, expected 3 * 5 * 8 = 120");
}

}  // namespace
}  // namespace pd::protocol
