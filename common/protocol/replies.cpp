// Replies, scheduler -> client (protocol/protocol.h); the wire format is protocol/wire.h's. The
// status and workers replies carry the same JSON that `pd status --json` / `pd workers --json`
// print: keys are the structs' field names in their order, states and kinds by name.
#include <array>

#include "protocol/protocol.h"
#include "protocol/wire.h"

namespace pd::protocol {

using wire::Fields;
using wire::Json;
using wire::Message;

namespace {

Json level_json(const LevelProgress& l) {
  Json j = Json::object();
  j["level"] = l.level;
  j["frames_done"] = l.frames_done;
  j["frames_total"] = l.frames_total;
  j["vertices"] = l.vertices;
  return j;
}

Json task_json(const TaskStatus& t) {
  Json j = Json::object();
  j["id"] = t.id;
  j["kind"] = to_string(t.kind);
  j["level"] = t.level;
  j["first"] = t.first;
  j["last"] = t.last;
  j["state"] = to_string(t.state);
  j["frames_done"] = t.frames_done;
  j["worker"] = t.worker;
  j["attempts"] = t.attempts;
  j["reason"] = t.reason;
  j["horizontal"] = t.horizontal;
  j["stitch"] = t.stitch;
  return j;
}

Json job_json(const JobStatus& s) {
  Json j = Json::object();
  j["id"] = s.id;
  j["name"] = s.name;
  j["state"] = to_string(s.state);
  j["reason"] = s.reason;
  j["priority"] = s.priority;
  j["frames"] = s.frames;
  j["subsets"] = s.subsets;
  j["stitch"] = s.stitch;
  j["seams"] = s.seams;
  j["preview_only"] = s.preview_only;
  j["elapsed_seconds"] = wire::number(s.elapsed_seconds);
  j["eta_seconds"] = wire::number(s.eta_seconds);
  j["levels"] = Json::array();
  for (const LevelProgress& l : s.levels) j["levels"].push_back(level_json(l));
  j["tasks"] = Json::array();
  for (const TaskStatus& t : s.tasks) j["tasks"].push_back(task_json(t));
  return j;
}

Json worker_json(const WorkerStatus& w) {
  Json j = Json::object();
  j["id"] = w.id;
  j["name"] = w.name;
  j["host"] = w.host;
  j["version"] = w.version;
  j["cores"] = w.cores;
  j["state"] = w.state;
  j["task"] = w.task;
  j["seen_seconds_ago"] = wire::number(w.seen_seconds_ago);
  j["tasks_done"] = w.tasks_done;
  j["slurm_job"] = w.slurm_job;
  return j;
}

Json slurm_json(const SlurmWorkerStatus& w) {
  Json j = Json::object();
  j["slurm_job"] = w.slurm_job;
  j["state"] = w.state;
  j["worker"] = w.worker;
  j["draining"] = w.draining;
  j["replacement"] = w.replacement;
  j["submitted_seconds_ago"] = wire::number(w.submitted_seconds_ago);
  j["reason"] = w.reason;
  return j;
}

// Fills `into` (a header, or an empty object for to_json_text) with the reply's fields.
void put_fields(Json& into, const StatusReply& m) {
  into["jobs"] = Json::array();
  for (const JobStatus& s : m.jobs) into["jobs"].push_back(job_json(s));
}

void put_fields(Json& into, const WorkersReply& m) {
  into["workers"] = Json::array();
  for (const WorkerStatus& w : m.workers) into["workers"].push_back(worker_json(w));
  into["slurm"] = Json::array();
  for (const SlurmWorkerStatus& w : m.slurm) into["slurm"].push_back(slurm_json(w));
  into["slurm_keep"] = m.slurm_keep;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Encoding.

Parts encode(const Submitted& m) {
  Json h = wire::header(wire::kSubmitted);
  h["job"] = m.job;
  return wire::finish(h);
}

Parts encode(const Accepted& m) {
  Json h = wire::header(wire::kAccepted);
  h["job"] = m.job;
  h["message"] = m.message;
  return wire::finish(h);
}

Parts encode(const StatusReply& m) {
  Json h = wire::header(wire::kStatusReply);
  put_fields(h, m);
  return wire::finish(h);
}

Parts encode(const FetchReply& m) {
  Json h = wire::header(wire::kFetchReply);
  h["job"] = m.job;
  h["bytes"] = m.blob.size();
  return wire::finish(h, {m.blob});
}

Parts encode(const WorkersReply& m) {
  Json h = wire::header(wire::kWorkersReply);
  put_fields(h, m);
  return wire::finish(h);
}

Parts encode(const SlurmAccepted& m) {
  Json h = wire::header(wire::kSlurmAccepted);
  h["slurm_job"] = m.slurm_job;
  h["tasks"] = m.tasks;
  h["message"] = m.message;
  return wire::finish(h);
}

Parts encode(const ErrorReply& m) {
  Json h = wire::header(wire::kError);
  h["message"] = m.message;
  return wire::finish(h);
}

Parts encode(const Reply& m) {
  return std::visit([](const auto& r) { return encode(r); }, m);
}

std::string to_json_text(const StatusReply& m) {
  Json j = Json::object();
  put_fields(j, m);
  return wire::dump(j, 2, "status");
}

std::string to_json_text(const WorkersReply& m) {
  Json j = Json::object();
  put_fields(j, m);
  return wire::dump(j, 2, "workers");
}

// ---------------------------------------------------------------------------------------------------
// Decoding.

namespace {

LevelProgress read_level(const Fields& f) {
  LevelProgress l;
  l.level = f.count("level");
  l.frames_done = f.count("frames_done");
  l.frames_total = f.count("frames_total");
  l.vertices = f.count("vertices");
  return l;
}

TaskStatus read_task(const Fields& f) {
  TaskStatus t;
  t.id = f.id("id");
  t.kind = parse_task_kind(f.text("kind"), wire::Where{&f, "kind"}.str());
  t.level = f.count("level");
  t.first = f.count("first");
  t.last = f.count("last");
  t.state = parse_task_state(f.text("state"), wire::Where{&f, "state"}.str());
  t.frames_done = f.count("frames_done");
  t.worker = f.text("worker");
  t.attempts = f.count("attempts");
  t.reason = f.text("reason");
  t.horizontal = f.boolean("horizontal");
  t.stitch = f.boolean("stitch");
  return t;
}

JobStatus read_job(const Fields& f) {
  JobStatus s;
  s.id = f.id("id");
  s.name = f.text("name");
  s.state = parse_job_state(f.text("state"), wire::Where{&f, "state"}.str());
  s.reason = f.text("reason");
  s.priority = f.integer("priority");
  s.frames = f.count("frames");
  s.subsets = f.count("subsets");
  s.stitch = f.count("stitch");
  s.seams = f.texts("seams");
  s.preview_only = f.boolean("preview_only");
  s.elapsed_seconds = f.number("elapsed_seconds");
  s.eta_seconds = f.number("eta_seconds");
  for (const Fields& l : f.objects("levels")) s.levels.push_back(read_level(l));
  for (const Fields& t : f.objects("tasks")) s.tasks.push_back(read_task(t));
  return s;
}

WorkerStatus read_worker(const Fields& f) {
  WorkerStatus w;
  w.id = f.id("id");
  w.name = f.text("name");
  w.host = f.text("host");
  w.version = f.text("version");
  w.cores = f.count("cores");
  w.state = f.text("state");
  w.task = f.id("task");
  w.seen_seconds_ago = f.number("seen_seconds_ago");
  w.tasks_done = f.count("tasks_done");
  w.slurm_job = f.text("slurm_job");
  return w;
}

SlurmWorkerStatus read_slurm_worker(const Fields& f) {
  SlurmWorkerStatus w;
  w.slurm_job = f.text("slurm_job");
  w.state = f.text("state");
  w.worker = f.text("worker");
  w.draining = f.boolean("draining");
  w.replacement = f.boolean("replacement");
  w.submitted_seconds_ago = f.number("submitted_seconds_ago");
  w.reason = f.text("reason");
  return w;
}

Reply decode_submitted(const Message& msg) {
  msg.expect_parts(1);
  return Submitted{msg.fields().id("job")};
}

Reply decode_accepted(const Message& msg) {
  msg.expect_parts(1);
  const Fields f = msg.fields();
  Accepted m;
  m.job = f.id("job");
  m.message = f.text("message");
  return m;
}

Reply decode_status_reply(const Message& msg) {
  msg.expect_parts(1);
  StatusReply m;
  for (const Fields& j : msg.fields().objects("jobs")) m.jobs.push_back(read_job(j));
  return m;
}

Reply decode_fetch_reply(const Message& msg) {
  const Fields f = msg.fields();
  FetchReply m;
  m.job = f.id("job");
  const std::size_t bytes = msg.byte_count("bytes");
  msg.expect_parts(2);
  m.blob = msg.blob(1, bytes, "bytes");
  return m;
}

Reply decode_workers_reply(const Message& msg) {
  msg.expect_parts(1);
  WorkersReply m;
  const Fields f = msg.fields();
  for (const Fields& w : f.objects("workers")) m.workers.push_back(read_worker(w));
  for (const Fields& w : f.objects("slurm")) m.slurm.push_back(read_slurm_worker(w));
  m.slurm_keep = f.count("slurm_keep");
  return m;
}

Reply decode_slurm_accepted(const Message& msg) {
  msg.expect_parts(1);
  const Fields f = msg.fields();
  SlurmAccepted m;
  m.slurm_job = f.text("slurm_job");
  m.tasks = f.texts("tasks");
  m.message = f.text("message");
  return m;
}

Reply decode_error(const Message& msg) {
  msg.expect_parts(1);
  return ErrorReply{msg.fields().text("message")};
}

using Decoder = Reply (*)(const Message&);
constexpr std::array<std::pair<const char*, Decoder>, 7> kDecoders{{
    {wire::kSubmitted, decode_submitted},
    {wire::kAccepted, decode_accepted},
    {wire::kStatusReply, decode_status_reply},
    {wire::kFetchReply, decode_fetch_reply},
    {wire::kWorkersReply, decode_workers_reply},
    {wire::kSlurmAccepted, decode_slurm_accepted},
    {wire::kError, decode_error},
}};

}  // namespace

Reply decode_reply(const Parts& parts) {
  const Message msg(parts);
  return wire::dispatch(msg, kDecoders, wire::Family::reply);
}

std::string message_type(const Parts& parts) { return wire::peek_type(parts); }

}  // namespace pd::protocol
