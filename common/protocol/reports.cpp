// Reports, worker -> scheduler (protocol/protocol.h); the wire format is protocol/wire.h's.
#include <array>

#include "protocol/protocol.h"
#include "protocol/wire.h"

namespace pd::protocol {

using wire::Json;
using wire::Message;

// ---------------------------------------------------------------------------------------------------
// Encoding.

Parts encode(const Hello& m) {
  Json h = wire::header(wire::kHello);
  h["name"] = m.name;
  h["version"] = m.version;
  h["cores"] = m.cores;
  h["host"] = m.host;
  h["slurm_job"] = m.slurm_job;
  h["blas_kernel"] = m.blas_kernel;
  return wire::finish(h);
}

Parts encode(const WorkerHeartbeat& m) {
  Json h = wire::header(wire::kWorkerHeartbeat);
  h["attempt"] = m.attempt;
  h["ping"] = m.ping;
  return wire::finish(h);
}

// "stats" is a JSON array of [name, value] pairs, not an object: it keeps the statistics' order
// (and shows a repeated name to the receiver instead of silently keeping one value).
Parts encode(const FrameReport& m) {
  wire::require_triples(wire::kFrame, "positions", m.positions);
  wire::require_triples(wire::kFrame, "center_of_mass", m.center_of_mass);
  Json h = wire::header(wire::kFrame);
  h["attempt"] = m.attempt;
  h["task"] = m.task;
  h["level"] = m.level;
  h["frame"] = m.frame;
  h["vertices"] = m.positions.size() / 3;
  Json stats = Json::array();
  for (const auto& [name, value] : m.stats) stats.push_back(Json::array({name, wire::number(value)}));
  h["stats"] = std::move(stats);
  h["center_of_mass"] = wire::numbers(m.center_of_mass);
  return wire::finish(h, {wire::doubles_part(m.positions)});
}

Parts encode(const TaskDone& m) {
  Json h = wire::header(wire::kTaskDone);
  h["attempt"] = m.attempt;
  h["task"] = m.task;
  h["unconverged_steps"] = m.unconverged_steps;
  h["vertical_start"] = m.vertical_start;
  h["seconds"] = wire::number(m.seconds);
  return wire::finish(h);
}

Parts encode(const TaskFailed& m) {
  Json h = wire::header(wire::kTaskFailed);
  h["attempt"] = m.attempt;
  h["task"] = m.task;
  h["message"] = m.message;
  h["failure"] = to_string(m.failure);
  return wire::finish(h);
}

Parts encode(const HierarchyDone& m) {
  Json h = wire::header(wire::kHierarchyDone);
  h["attempt"] = m.attempt;
  h["task"] = m.task;
  h["hash"] = m.hash;
  h["levels"] = m.levels;
  h["vertices"] = m.vertices;
  h["bytes"] = m.blob.size();
  return wire::finish(h, {m.blob});
}

Parts encode(const Goodbye& m) {
  Json h = wire::header(wire::kGoodbye);
  h["attempt"] = m.attempt;
  h["reason"] = m.reason;
  return wire::finish(h);
}

Parts encode(const Report& m) {
  return std::visit([](const auto& r) { return encode(r); }, m);
}

// ---------------------------------------------------------------------------------------------------
// Decoding.

namespace {

Report decode_hello(const Message& msg) {
  msg.expect_parts(1);
  const wire::Fields f = msg.fields();
  Hello m;
  m.name = f.text("name");
  m.version = f.text("version");
  m.cores = f.count("cores");
  m.host = f.text("host");
  m.slurm_job = f.text("slurm_job");
  m.blas_kernel = f.text("blas_kernel");
  return m;
}

Report decode_worker_heartbeat(const Message& msg) {
  msg.expect_parts(1);
  const wire::Fields f = msg.fields();
  return WorkerHeartbeat{f.id("attempt"), f.id("ping")};
}

std::vector<Stat> read_stats(const wire::Fields& f) {
  const Json& a = f.array("stats");
  std::vector<Stat> stats;
  stats.reserve(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    const wire::Where w{&f, "stats", long(i)};
    if (!a[i].is_array() || a[i].size() != 2) w.fail("expected a [name, number] pair");
    stats.emplace_back(wire::to_text(a[i][0], w), wire::to_number(a[i][1], w));
  }
  return stats;
}

Report decode_frame(const Message& msg) {
  const wire::Fields f = msg.fields();
  FrameReport m;
  m.attempt = f.id("attempt");
  m.task = f.id("task");
  m.level = f.count("level");
  m.frame = f.count("frame");
  m.stats = read_stats(f);
  m.center_of_mass = f.numbers("center_of_mass");
  if (m.center_of_mass.size() % 3 != 0)
    wire::Where{&f, "center_of_mass"}.fail(std::to_string(m.center_of_mass.size()) +
                                           " numbers, expected a multiple of 3");
  const int64_t n = msg.vertex_count("vertices");
  msg.expect_parts(2);
  m.positions = msg.doubles(1, n);
  return m;
}

Report decode_task_done(const Message& msg) {
  msg.expect_parts(1);
  const wire::Fields f = msg.fields();
  TaskDone m;
  m.attempt = f.id("attempt");
  m.task = f.id("task");
  m.unconverged_steps = f.count("unconverged_steps");
  m.vertical_start = f.boolean("vertical_start");
  m.seconds = f.number("seconds");
  return m;
}

Report decode_task_failed(const Message& msg) {
  msg.expect_parts(1);
  const wire::Fields f = msg.fields();
  TaskFailed m;
  m.attempt = f.id("attempt");
  m.task = f.id("task");
  m.message = f.text("message");
  m.failure = parse_failure_kind(f.text("failure"), "task_failed: field 'failure'");
  return m;
}

Report decode_hierarchy_done(const Message& msg) {
  const wire::Fields f = msg.fields();
  HierarchyDone m;
  m.attempt = f.id("attempt");
  m.task = f.id("task");
  m.hash = f.text("hash");
  m.levels = f.count("levels");
  m.vertices = f.counts("vertices");
  const std::size_t bytes = msg.byte_count("bytes");
  msg.expect_parts(2);
  m.blob = msg.blob(1, bytes, "bytes");
  return m;
}

Report decode_goodbye(const Message& msg) {
  msg.expect_parts(1);
  const wire::Fields f = msg.fields();
  return Goodbye{f.id("attempt"), f.text("reason")};
}

using Decoder = Report (*)(const Message&);
constexpr std::array<std::pair<const char*, Decoder>, 7> kDecoders{{
    {wire::kHello, decode_hello},
    {wire::kWorkerHeartbeat, decode_worker_heartbeat},
    {wire::kFrame, decode_frame},
    {wire::kTaskDone, decode_task_done},
    {wire::kTaskFailed, decode_task_failed},
    {wire::kHierarchyDone, decode_hierarchy_done},
    {wire::kGoodbye, decode_goodbye},
}};

}  // namespace

Report decode_report(const Parts& parts) {
  const Message msg(parts);
  return wire::dispatch(msg, kDecoders, wire::Family::report);
}

}  // namespace pd::protocol
