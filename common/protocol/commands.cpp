// Commands, scheduler -> worker (protocol/protocol.h); the wire format is protocol/wire.h's.
#include <array>

#include "protocol/protocol.h"
#include "protocol/wire.h"

namespace pd::protocol {

using wire::Json;
using wire::Message;

// ---------------------------------------------------------------------------------------------------
// Encoding.

Parts encode(const Welcome& m) {
  Json h = wire::header(wire::kWelcome);
  h["worker"] = m.worker;
  h["heartbeat_ms"] = m.heartbeat_ms;
  return wire::finish(h);
}

// Data parts, in order: the hierarchy blob when present ("hierarchy_bytes"), then own_before and
// own_start when present ("own_vertices" = n, 3 n doubles each). "stitch": true only with own frames.
Parts encode(const AssignTask& m) {
  Json h = wire::header(wire::kAssign);
  h["attempt"] = m.attempt;
  h["task"] = m.task;
  h["job"] = m.job;
  h["kind"] = to_string(m.kind);
  h["level"] = m.level;
  h["first"] = m.first;
  h["last"] = m.last;
  h["start"] = m.start;
  h["frames"] = m.frames;
  h["levels"] = m.levels;
  h["hessian"] = m.hessian;
  h["scene_hash"] = m.scene_hash;
  if (m.scene) h["scene"] = wire::scene_json(*m.scene);
  h["hierarchy_hash"] = m.hierarchy_hash;
  Parts data;
  if (m.hierarchy_blob) {
    h["hierarchy_bytes"] = m.hierarchy_blob->size();
    data.push_back(*m.hierarchy_blob);
  }
  if (m.own_before.has_value() != m.own_start.has_value())
    throw ProtocolError("assign: field 'own_before' / 'own_start': both must be present or both absent");
  if (m.own_before) {
    wire::require_triples(wire::kAssign, "own_before", *m.own_before);
    if (m.own_start->size() != m.own_before->size())
      throw ProtocolError("assign: field 'own_start': " + std::to_string(m.own_start->size()) +
                          " numbers, own_before has " + std::to_string(m.own_before->size()));
    h["own_vertices"] = m.own_before->size() / 3;
    data.push_back(wire::doubles_part(*m.own_before));
    data.push_back(wire::doubles_part(*m.own_start));
  }
  if (m.own_kappa) h["own_kappa"] = wire::number(*m.own_kappa);
  if (m.stitch) {
    if (!m.own_before || m.kind != TaskKind::level)
      throw ProtocolError("assign: field 'stitch': a stitch is a level task continuing from own frames, none given");
    h["stitch"] = true;
  }
  return wire::finish(h, std::move(data));
}

namespace {

// BelowFrame and GuideFrame: the same fields under their own type.
template <typename FedFrame>
Parts encode_fed_frame(const char* type, const FedFrame& m) {
  wire::require_triples(type, "positions", m.positions);
  Json h = wire::header(type);
  h["attempt"] = m.attempt;
  h["task"] = m.task;
  h["level"] = m.level;
  h["frame"] = m.frame;
  h["vertices"] = m.positions.size() / 3;
  return wire::finish(h, {wire::doubles_part(m.positions)});
}

}  // namespace

Parts encode(const BelowFrame& m) { return encode_fed_frame(wire::kBelowFrame, m); }

Parts encode(const GuideFrame& m) { return encode_fed_frame(wire::kGuideFrame, m); }

Parts encode(const CancelTask& m) {
  Json h = wire::header(wire::kCancelTask);
  h["attempt"] = m.attempt;
  h["task"] = m.task;
  h["reason"] = m.reason;
  return wire::finish(h);
}

Parts encode(const SchedulerHeartbeat& m) {
  Json h = wire::header(wire::kHeartbeat);
  h["pong"] = m.pong;
  return wire::finish(h);
}

Parts encode(const Refused& m) {
  Json h = wire::header(wire::kRefused);
  h["reason"] = m.reason;
  return wire::finish(h);
}

Parts encode(const Command& m) {
  return std::visit([](const auto& c) { return encode(c); }, m);
}

// ---------------------------------------------------------------------------------------------------
// Decoding.

namespace {

Command decode_welcome(const Message& msg) {
  msg.expect_parts(1);
  const wire::Fields f = msg.fields();
  Welcome m;
  m.worker = f.id("worker");
  m.heartbeat_ms = f.count("heartbeat_ms");
  return m;
}

Command decode_assign(const Message& msg) {
  const wire::Fields f = msg.fields();
  AssignTask m;
  m.attempt = f.id("attempt");
  m.task = f.id("task");
  m.job = f.id("job");
  m.kind = parse_task_kind(f.text("kind"), wire::Where{&f, "kind"}.str());
  m.level = f.count("level");
  m.first = f.count("first");
  m.last = f.count("last");
  m.start = f.count("start");
  if (m.start < m.first || (m.start >= m.last && m.kind == TaskKind::level))
    throw ProtocolError("assign: field 'start': " + std::to_string(m.start) + " outside [first, last) = [" +
                        std::to_string(m.first) + ", " + std::to_string(m.last) + ")");
  m.frames = f.count("frames");
  m.levels = f.count("levels");
  m.hessian = f.text("hessian");
  m.scene_hash = f.text("scene_hash");
  // A worker names a folder after it: lower-case hex only (farm::scene_source_hash's digits).
  if (m.scene_hash.empty() || m.scene_hash.size() > 64 ||
      m.scene_hash.find_first_not_of("0123456789abcdef") != std::string::npos)
    throw ProtocolError("assign: field 'scene_hash': not 1 to 64 lower-case hex digits");
  if (f.has("scene")) m.scene = wire::read_scene(f.object("scene"));
  m.hierarchy_hash = f.text("hierarchy_hash");
  m.own_kappa = f.optional_number("own_kappa");
  const bool has_blob = f.has("hierarchy_bytes");
  const std::size_t blob_bytes = has_blob ? msg.byte_count("hierarchy_bytes") : 0;
  const bool has_own = f.has("own_vertices");
  const int64_t own_vertices = has_own ? msg.vertex_count("own_vertices") : 0;
  m.stitch = f.has("stitch") && f.boolean("stitch");
  if (m.stitch && (!has_own || m.kind != TaskKind::level))
    throw ProtocolError("assign: field 'stitch': a stitch is a level task continuing from own frames, none given");
  msg.expect_parts(1 + (has_blob ? 1 : 0) + (has_own ? 2 : 0));
  std::size_t next = 1;
  if (has_blob) m.hierarchy_blob = msg.blob(next++, blob_bytes, "hierarchy_bytes");
  if (has_own) {
    m.own_before = msg.doubles(next++, own_vertices);
    m.own_start = msg.doubles(next++, own_vertices);
  }
  return m;
}

// BelowFrame and GuideFrame: the same fields, one frame of positions as data part 1.
template <typename FedFrame>
Command decode_fed_frame(const Message& msg) {
  const wire::Fields f = msg.fields();
  FedFrame m;
  m.attempt = f.id("attempt");
  m.task = f.id("task");
  m.level = f.count("level");
  m.frame = f.count("frame");
  const int64_t n = msg.vertex_count("vertices");
  msg.expect_parts(2);
  m.positions = msg.doubles(1, n);
  return m;
}

Command decode_cancel_task(const Message& msg) {
  msg.expect_parts(1);
  const wire::Fields f = msg.fields();
  CancelTask m;
  m.attempt = f.id("attempt");
  m.task = f.id("task");
  m.reason = f.text("reason");
  return m;
}

Command decode_heartbeat(const Message& msg) {
  msg.expect_parts(1);
  return SchedulerHeartbeat{msg.fields().id("pong")};
}

Command decode_refused(const Message& msg) {
  msg.expect_parts(1);
  return Refused{msg.fields().text("reason")};
}

using Decoder = Command (*)(const Message&);
constexpr std::array<std::pair<const char*, Decoder>, 7> kDecoders{{
    {wire::kWelcome, decode_welcome},
    {wire::kAssign, decode_assign},
    {wire::kBelowFrame, decode_fed_frame<BelowFrame>},
    {wire::kGuideFrame, decode_fed_frame<GuideFrame>},
    {wire::kCancelTask, decode_cancel_task},
    {wire::kHeartbeat, decode_heartbeat},
    {wire::kRefused, decode_refused},
}};

}  // namespace

Command decode_command(const Parts& parts) {
  const Message msg(parts);
  return wire::dispatch(msg, kDecoders, wire::Family::command);
}

}  // namespace pd::protocol
