#include <gtest/gtest.h>

#include "protocol/protocol.h"
#include "support/protocol_cases.h"

namespace pd::protocol {
namespace {

using namespace test;  // the helpers shared by the protocol tests

// The shared helpers bound to this file's family, the client requests.
std::string error_of(const Parts& parts) { return test::error_of(parts, decode_request); }
int check_every_field_required(const Parts& parts) { return test::check_every_field_required(parts, decode_request); }
int check_every_field_typed(const Parts& parts) { return test::check_every_field_typed(parts, decode_request); }

template <typename T>
T round_trip(const T& m) {
  EXPECT_EQ(encode(m).size(), 1u);  // no request has data parts
  return test::round_trip<Request>(m, decode_request);
}

SubmitJob sample_submit() {
  SubmitJob m;
  m.scene = {"../scenes/cube trampoline.json", "{\n  \"name\": \"cube-trampoline\"\n}\n",
             {{"meshes/cube.obj", "v 0 0 0\nv 1 0 0\n"}, {"meshes/ñet.obj", ""}, {"tab\there", "\u00e9\u4e2d"}}};
  m.preview_only = true;
  m.levels = 4;
  m.subsets = 3;
  m.priority = -2;
  m.frames = 120;
  m.preview_chunk = 10;
  m.hessian = "coarse";
  m.stitch = 12;
  return m;
}

TEST(ProtocolRequests, SubmitJobRoundTripsEveryField) {
  const SubmitJob m = sample_submit();
  const SubmitJob b = round_trip(m);
  EXPECT_EQ(b.scene.name, m.scene.name);
  EXPECT_EQ(b.scene.text, m.scene.text);
  ASSERT_EQ(b.scene.files.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(b.scene.files[i].path, m.scene.files[i].path);
    EXPECT_EQ(b.scene.files[i].content, m.scene.files[i].content);
  }
  EXPECT_EQ(b.preview_only, m.preview_only);
  EXPECT_EQ(b.levels, m.levels);
  EXPECT_EQ(b.subsets, m.subsets);
  EXPECT_EQ(b.priority, m.priority);
  EXPECT_EQ(b.frames, m.frames);
  EXPECT_EQ(b.preview_chunk, m.preview_chunk);
  EXPECT_EQ(b.hessian, m.hessian);
  EXPECT_EQ(b.stitch, 12);
  const SubmitJob d = round_trip(SubmitJob{});
  EXPECT_EQ(d.hessian, "auto");
  EXPECT_TRUE(d.scene.files.empty());
  EXPECT_FALSE(d.preview_only);
}

TEST(ProtocolRequests, JobRequestsRoundTrip) {
  const RefineJob r = round_trip(RefineJob{12, 4});
  EXPECT_EQ(r.job, 12);
  EXPECT_EQ(r.subsets, 4);
  EXPECT_EQ(round_trip(StatusRequest{0}).job, 0);
  EXPECT_EQ(round_trip(StatusRequest{(int64_t{1} << 40) + 3}).job, (int64_t{1} << 40) + 3);
  EXPECT_EQ(round_trip(FetchRequest{5}).job, 5);
  EXPECT_EQ(round_trip(CancelJob{6}).job, 6);
  EXPECT_EQ(round_trip(RequeueJob{7}).job, 7);
  round_trip(WorkersRequest{});
  // status, fetch and cancel_job share a shape but keep their own types.
  EXPECT_TRUE(std::holds_alternative<FetchRequest>(decode_request(encode(FetchRequest{5}))));
  EXPECT_TRUE(std::holds_alternative<CancelJob>(decode_request(encode(CancelJob{5}))));
  EXPECT_TRUE(std::holds_alternative<RequeueJob>(decode_request(encode(RequeueJob{5}))));
}

AddSlurmWorkers sample_add_slurm() {
  AddSlurmWorkers m;
  m.count = 8;
  m.partition = "gpu-short";
  m.time_limit = "1-02:00:00";
  m.cpus = 4;
  m.memory = "16G";
  m.keep = 6;
  return m;
}

TEST(ProtocolRequests, SlurmRequestsRoundTripEveryField) {
  const AddSlurmWorkers m = sample_add_slurm();
  const AddSlurmWorkers b = round_trip(m);
  EXPECT_EQ(b.count, 8);
  EXPECT_EQ(b.partition, "gpu-short");
  EXPECT_EQ(b.time_limit, "1-02:00:00");
  EXPECT_EQ(b.cpus, 4);
  EXPECT_EQ(b.memory, "16G");
  EXPECT_EQ(b.keep, 6);
  EXPECT_EQ(round_trip(AddSlurmWorkers{}).keep, -1);  // "leave the target" survives the wire
  const RemoveSlurmWorkers r = round_trip(RemoveSlurmWorkers{"4711_2", true});
  EXPECT_EQ(r.slurm_job, "4711_2");
  EXPECT_TRUE(r.now);
  EXPECT_FALSE(round_trip(RemoveSlurmWorkers{"4711", false}).now);
}

TEST(ProtocolRequests, MessagesOfOtherFamiliesAreRefused) {
  EXPECT_EQ(error_of(encode(Welcome{})), "welcome: not a client request (it is a scheduler command)");
  EXPECT_EQ(error_of(encode(Hello{})), "hello: not a client request (it is a worker report)");
  EXPECT_EQ(error_of(encode(StatusReply{})), "status_reply: not a client request (it is a scheduler reply)");
}

TEST(ProtocolRequests, EveryRequiredFieldIsCheckedByName) {
  EXPECT_EQ(check_every_field_required(encode(sample_submit())), 9);
  EXPECT_EQ(check_every_field_required(encode(RefineJob{1, 2, 16})), 3);
  EXPECT_EQ(check_every_field_required(encode(StatusRequest{1})), 1);
  EXPECT_EQ(check_every_field_required(encode(FetchRequest{1})), 1);
  EXPECT_EQ(check_every_field_required(encode(CancelJob{1})), 1);
  EXPECT_EQ(check_every_field_required(encode(RequeueJob{1})), 1);
  EXPECT_EQ(check_every_field_required(encode(sample_add_slurm())), 6);
  EXPECT_EQ(check_every_field_required(encode(RemoveSlurmWorkers{"1", true})), 2);
  const Parts parts = encode(sample_submit());
  int checked = 0;
  for (const char* name : {"name", "text", "files"}) {
    Json h = header(parts);
    h["scene"].erase(name);
    EXPECT_EQ(error_of(with_header(parts, h)), std::string("submit: field 'scene.") + name + "': missing");
    ++checked;
  }
  for (const char* name : {"path", "content"}) {
    Json h = header(parts);
    h["scene"]["files"][1].erase(name);  // files[2] is not plain text: it travels as content_base64
    EXPECT_EQ(error_of(with_header(parts, h)),
              std::string("submit: field 'scene.files[1].") + name +
                  (name == std::string("path") ? "': missing" : "': needs exactly one of content and content_base64"));
    ++checked;
  }
  EXPECT_EQ(checked, 5);
}

TEST(ProtocolRequests, EveryFieldOfTheWrongTypeIsRefusedByName) {
  EXPECT_EQ(check_every_field_typed(encode(sample_submit())), 9);
  EXPECT_EQ(check_every_field_typed(encode(RefineJob{1, 2, 16})), 3);
  EXPECT_EQ(check_every_field_typed(encode(StatusRequest{1})), 1);
  EXPECT_EQ(check_every_field_typed(encode(FetchRequest{1})), 1);
  EXPECT_EQ(check_every_field_typed(encode(CancelJob{1})), 1);
  EXPECT_EQ(check_every_field_typed(encode(RequeueJob{1})), 1);
  EXPECT_EQ(check_every_field_typed(encode(sample_add_slurm())), 6);
  EXPECT_EQ(check_every_field_typed(encode(RemoveSlurmWorkers{"1", true})), 2);
  const Parts parts = encode(sample_submit());
  Json h = header(parts);
  h["scene"]["files"] = Json::array({"meshes/cube.obj"});
  EXPECT_TRUE(has(error_of(with_header(parts, h)), "submit: field 'scene.files[0]': expected an object, got string"));
  h["scene"]["files"] = Json::object();
  EXPECT_TRUE(has(error_of(with_header(parts, h)), "submit: field 'scene.files': expected an array, got object"));
}

TEST(ProtocolRequests, OutOfRangeValuesAreRefusedByName) {
  const Parts submit = encode(sample_submit());
  EXPECT_TRUE(has(error_of(with_field(submit, "subsets", -1)), "submit: field 'subsets': -1 is negative"));
  EXPECT_TRUE(
      has(error_of(with_field(submit, "frames", int64_t{1} << 33)), "submit: field 'frames': 8589934592 is out"));
  EXPECT_TRUE(has(error_of(with_field(submit, "priority", -(int64_t{1} << 33))), "submit: field 'priority'"));
  EXPECT_EQ(decode_request(with_field(submit, "priority", -7)).index(), 0u);  // priorities may be negative
  EXPECT_EQ(error_of(with_field(submit, "preview_only", "yes")),
            "submit: field 'preview_only': expected a boolean, got string");
  EXPECT_TRUE(has(error_of(with_field(encode(CancelJob{3}), "job", -3)), "cancel_job: field 'job': -3 is negative"));
  EXPECT_EQ(error_of(with_field(encode(FetchRequest{3}), "job", 3.0)),
            "fetch: field 'job': expected an integer, got number 3.0");
}

TEST(ProtocolRequests, WrongPartCountsAreRefused) {
  Parts submit = encode(sample_submit());
  submit.push_back("scene bytes");
  EXPECT_EQ(error_of(submit), "submit: 2 parts, expected 1");
  Parts workers = encode(WorkersRequest{});
  workers.push_back("");
  EXPECT_EQ(error_of(workers), "workers: 2 parts, expected 1");
  Parts fetch = encode(FetchRequest{1});
  fetch.push_back("");
  fetch.push_back("");
  EXPECT_EQ(error_of(fetch), "fetch: 3 parts, expected 1");
  Parts refine = encode(RefineJob{1, 2});
  refine.push_back("");
  EXPECT_EQ(error_of(refine), "refine: 2 parts, expected 1");
}

}  // namespace
}  // namespace pd::protocol
