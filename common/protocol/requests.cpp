// Requests, client -> scheduler (protocol/protocol.h); the wire format is protocol/wire.h's.
#include <array>

#include "protocol/protocol.h"
#include "protocol/wire.h"

namespace pd::protocol {

using wire::Json;
using wire::Message;

namespace {

// The requests that name just a job.
Parts encode_job(const char* type, int64_t job) {
  Json h = wire::header(type);
  h["job"] = job;
  return wire::finish(h);
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Encoding.

Parts encode(const SubmitJob& m) {
  Json h = wire::header(wire::kSubmit);
  h["scene"] = wire::scene_json(m.scene);
  h["preview_only"] = m.preview_only;
  h["levels"] = m.levels;
  h["subsets"] = m.subsets;
  h["priority"] = m.priority;
  h["frames"] = m.frames;
  h["preview_chunk"] = m.preview_chunk;
  h["hessian"] = m.hessian;
  h["stitch"] = m.stitch;
  return wire::finish(h);
}

Parts encode(const RefineJob& m) {
  Json h = wire::header(wire::kRefine);
  h["job"] = m.job;
  h["subsets"] = m.subsets;
  h["stitch"] = m.stitch;
  return wire::finish(h);
}

Parts encode(const StatusRequest& m) { return encode_job(wire::kStatus, m.job); }
Parts encode(const FetchRequest& m) { return encode_job(wire::kFetch, m.job); }
Parts encode(const CancelJob& m) { return encode_job(wire::kCancelJob, m.job); }
Parts encode(const RequeueJob& m) { return encode_job(wire::kRequeue, m.job); }
Parts encode(const WorkersRequest&) { return wire::finish(wire::header(wire::kWorkers)); }

Parts encode(const AddSlurmWorkers& m) {
  Json h = wire::header(wire::kAddSlurm);
  h["count"] = m.count;
  h["partition"] = m.partition;
  h["time_limit"] = m.time_limit;
  h["cpus"] = m.cpus;
  h["memory"] = m.memory;
  h["keep"] = m.keep;
  return wire::finish(h);
}

Parts encode(const RemoveSlurmWorkers& m) {
  Json h = wire::header(wire::kRemoveSlurm);
  h["slurm_job"] = m.slurm_job;
  h["now"] = m.now;
  return wire::finish(h);
}

Parts encode(const Request& m) {
  return std::visit([](const auto& r) { return encode(r); }, m);
}

// ---------------------------------------------------------------------------------------------------
// Decoding.

namespace {

Request decode_submit(const Message& msg) {
  msg.expect_parts(1);
  const wire::Fields f = msg.fields();
  SubmitJob m;
  m.scene = wire::read_scene(f.object("scene"));
  m.preview_only = f.boolean("preview_only");
  m.levels = f.count("levels");
  m.subsets = f.count("subsets");
  m.priority = f.integer("priority");
  m.frames = f.count("frames");
  m.preview_chunk = f.count("preview_chunk");
  m.hessian = f.text("hessian");
  m.stitch = f.count("stitch");
  return m;
}

Request decode_refine(const Message& msg) {
  msg.expect_parts(1);
  const wire::Fields f = msg.fields();
  RefineJob m;
  m.job = f.id("job");
  m.subsets = f.count("subsets");
  m.stitch = f.count("stitch");
  return m;
}

// StatusRequest, FetchRequest, CancelJob, RequeueJob: {"job"}.
template <typename T>
Request decode_job(const Message& msg) {
  msg.expect_parts(1);
  T m;
  m.job = msg.fields().id("job");
  return m;
}

Request decode_workers(const Message& msg) {
  msg.expect_parts(1);
  return WorkersRequest{};
}

Request decode_add_slurm(const Message& msg) {
  msg.expect_parts(1);
  const wire::Fields f = msg.fields();
  AddSlurmWorkers m;
  m.count = f.count("count");
  m.partition = f.text("partition");
  m.time_limit = f.text("time_limit");
  m.cpus = f.count("cpus");
  m.memory = f.text("memory");
  m.keep = f.integer("keep");
  return m;
}

Request decode_remove_slurm(const Message& msg) {
  msg.expect_parts(1);
  const wire::Fields f = msg.fields();
  RemoveSlurmWorkers m;
  m.slurm_job = f.text("slurm_job");
  m.now = f.boolean("now");
  return m;
}

using Decoder = Request (*)(const Message&);
constexpr std::array<std::pair<const char*, Decoder>, 9> kDecoders{{
    {wire::kSubmit, decode_submit},
    {wire::kRefine, decode_refine},
    {wire::kStatus, decode_job<StatusRequest>},
    {wire::kFetch, decode_job<FetchRequest>},
    {wire::kCancelJob, decode_job<CancelJob>},
    {wire::kRequeue, decode_job<RequeueJob>},
    {wire::kWorkers, decode_workers},
    {wire::kAddSlurm, decode_add_slurm},
    {wire::kRemoveSlurm, decode_remove_slurm},
}};

}  // namespace

Request decode_request(const Parts& parts) {
  const Message msg(parts);
  return wire::dispatch(msg, kDecoders, wire::Family::request);
}

}  // namespace pd::protocol
