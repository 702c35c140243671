#include <gtest/gtest.h>

#include <limits>

#include "protocol/protocol.h"
#include "support/protocol_cases.h"

namespace pd::protocol {
namespace {

using namespace test;  // the helpers shared by the protocol tests

// The shared helpers bound to this file's family, the scheduler replies. The field checks take the
// JSON pointer of the object to go over inside part 0 and the prefix its fields are named with.
std::string error_of(const Parts& parts) { return test::error_of(parts, decode_reply); }

int check_every_field_required(const Parts& parts, const std::string& pointer, const std::string& prefix) {
  return test::check_every_field_required(parts, decode_reply, pointer, prefix);
}

int check_every_field_typed(const Parts& parts, const std::string& pointer, const std::string& prefix) {
  return test::check_every_field_typed(parts, decode_reply, pointer, prefix);
}

template <typename T>
T round_trip(const T& m) {
  return test::round_trip<Reply>(m, decode_reply);
}

StatusReply sample_status() {
  JobStatus a;
  a.id = 1;
  a.name = "cube-trampoline";
  a.state = JobState::running;
  a.priority = 5;
  a.frames = 40;
  a.subsets = 2;
  a.stitch = 16;
  a.seams = {"frame 20, the even split (motion 0.8x the median, contact steady)"};
  a.elapsed_seconds = 12.5;
  a.eta_seconds = -1.0;
  a.levels = {{0, 41, 41, 128}, {1, 12, 41, 0}};
  a.tasks = {{2, TaskKind::hierarchy, 0, 0, 0, TaskState::done, 0, "w2", 1, ""},
             {3, TaskKind::level, 1, 0, 40, TaskState::running, 5, "w1", 1, ""},
             {4, TaskKind::level, 2, 20, 40, TaskState::blocked, 0, "", 0, "task 3 failed"},
             {5, TaskKind::level, 1, 20, 40, TaskState::waiting, 0, "", 1, "continues horizontally: ...", true},
             {6, TaskKind::level, 1, 20, 35, TaskState::waiting, 0, "", 0, "", false, true}};
  JobStatus b;
  b.id = 2;
  b.name = "flag";
  b.state = JobState::failed;
  b.reason = "scene: no objects";
  b.preview_only = true;
  b.elapsed_seconds = std::numeric_limits<double>::denorm_min();
  b.eta_seconds = std::numeric_limits<double>::infinity();
  return StatusReply{{a, b}};
}

WorkersReply sample_workers() {
  return WorkersReply{{{1, "w1", "node-1", "0.4.0", 8, "busy", 3, 0.25, 7, "4711_0"},
                       {2, "w2", "node-2", "0.4.0", 4, "lost", 0, 31.0, 0, ""}},
                      {{"4711_0", "RUNNING", "slurm-4711_0", false, true, 12.5, "None"},
                       {"4711_1", "CANCELLED", "", true, false, 0.5, "scancel"}},
                      3};
}

void expect_same(const JobStatus& a, const JobStatus& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.state, b.state);
  EXPECT_EQ(a.reason, b.reason);
  EXPECT_EQ(a.priority, b.priority);
  EXPECT_EQ(a.frames, b.frames);
  EXPECT_EQ(a.subsets, b.subsets);
  EXPECT_EQ(a.stitch, b.stitch);
  EXPECT_EQ(a.seams, b.seams);
  EXPECT_EQ(a.preview_only, b.preview_only);
  EXPECT_TRUE(same_bits(a.elapsed_seconds, b.elapsed_seconds));
  EXPECT_TRUE(same_bits(a.eta_seconds, b.eta_seconds));
  ASSERT_EQ(a.levels.size(), b.levels.size());
  for (std::size_t i = 0; i < a.levels.size(); ++i) {
    EXPECT_EQ(a.levels[i].level, b.levels[i].level);
    EXPECT_EQ(a.levels[i].frames_done, b.levels[i].frames_done);
    EXPECT_EQ(a.levels[i].frames_total, b.levels[i].frames_total);
    EXPECT_EQ(a.levels[i].vertices, b.levels[i].vertices);
  }
  ASSERT_EQ(a.tasks.size(), b.tasks.size());
  for (std::size_t i = 0; i < a.tasks.size(); ++i) {
    const TaskStatus &s = a.tasks[i], &t = b.tasks[i];
    EXPECT_EQ(s.id, t.id);
    EXPECT_EQ(s.kind, t.kind);
    EXPECT_EQ(s.level, t.level);
    EXPECT_EQ(s.first, t.first);
    EXPECT_EQ(s.last, t.last);
    EXPECT_EQ(s.state, t.state);
    EXPECT_EQ(s.frames_done, t.frames_done);
    EXPECT_EQ(s.worker, t.worker);
    EXPECT_EQ(s.attempts, t.attempts);
    EXPECT_EQ(s.reason, t.reason);
    EXPECT_EQ(s.horizontal, t.horizontal);
    EXPECT_EQ(s.stitch, t.stitch);
  }
}

TEST(ProtocolReplies, SmallRepliesRoundTrip) {
  EXPECT_EQ(round_trip(Submitted{17}).job, 17);
  const Accepted a = round_trip(Accepted{4, "refinement of job 4 queued"});
  EXPECT_EQ(a.job, 4);
  EXPECT_EQ(a.message, "refinement of job 4 queued");
  EXPECT_EQ(round_trip(ErrorReply{"no job 17"}).message, "no job 17");
  const FetchReply f{9, std::string("\x89HDF\0\0\r\n\xff", 9)};
  const Parts parts = encode(f);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[1], f.blob);
  const FetchReply g = round_trip(f);
  EXPECT_EQ(g.job, 9);
  EXPECT_EQ(g.blob, f.blob);
  EXPECT_TRUE(round_trip(FetchReply{9, ""}).blob.empty());
}

TEST(ProtocolReplies, StatusReplyRoundTripsEveryFieldOfJobsLevelsAndTasks) {
  const StatusReply m = sample_status();
  const StatusReply b = round_trip(m);
  ASSERT_EQ(b.jobs.size(), 2u);
  expect_same(b.jobs[0], m.jobs[0]);
  expect_same(b.jobs[1], m.jobs[1]);
  EXPECT_TRUE(round_trip(StatusReply{}).jobs.empty());
}

TEST(ProtocolReplies, WorkersReplyRoundTripsEveryField) {
  const WorkersReply m = sample_workers();
  const WorkersReply b = round_trip(m);
  ASSERT_EQ(b.workers.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const WorkerStatus &s = m.workers[i], &t = b.workers[i];
    EXPECT_EQ(s.id, t.id);
    EXPECT_EQ(s.name, t.name);
    EXPECT_EQ(s.host, t.host);
    EXPECT_EQ(s.version, t.version);
    EXPECT_EQ(s.cores, t.cores);
    EXPECT_EQ(s.state, t.state);
    EXPECT_EQ(s.task, t.task);
    EXPECT_TRUE(same_bits(s.seen_seconds_ago, t.seen_seconds_ago));
    EXPECT_EQ(s.tasks_done, t.tasks_done);
    EXPECT_EQ(s.slurm_job, t.slurm_job);
  }
  ASSERT_EQ(b.slurm.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const SlurmWorkerStatus &s = m.slurm[i], &t = b.slurm[i];
    EXPECT_EQ(s.slurm_job, t.slurm_job);
    EXPECT_EQ(s.state, t.state);
    EXPECT_EQ(s.worker, t.worker);
    EXPECT_EQ(s.draining, t.draining);
    EXPECT_EQ(s.replacement, t.replacement);
    EXPECT_TRUE(same_bits(s.submitted_seconds_ago, t.submitted_seconds_ago));
    EXPECT_EQ(s.reason, t.reason);
  }
  EXPECT_EQ(b.slurm_keep, 3);
}

TEST(ProtocolReplies, SlurmAcceptedRoundTripsEveryField) {
  const SlurmAccepted m{"4711", {"4711_0", "4711_1"}, "2 workers submitted"};
  const SlurmAccepted b = round_trip(m);
  EXPECT_EQ(b.slurm_job, "4711");
  EXPECT_EQ(b.tasks, m.tasks);
  EXPECT_EQ(b.message, m.message);
}

TEST(ProtocolReplies, JsonTextIsPrettyWithStructFieldNamesInOrderAndStateNames) {
  StatusReply m;
  JobStatus j;
  j.id = 1;
  j.name = "cube-trampoline";
  j.state = JobState::running;
  j.frames = 40;
  j.elapsed_seconds = 2.5;
  j.levels = {{0, 12, 41, 128}};
  j.tasks = {{3, TaskKind::level, 1, 0, 40, TaskState::running, 5, "w1", 1, ""}};
  m.jobs = {j};
  const std::string expected = R"({
  "jobs": [
    {
      "id": 1,
      "name": "cube-trampoline",
      "state": "running",
      "reason": "",
      "priority": 0,
      "frames": 40,
      "subsets": 1,
      "stitch": 0,
      "seams": [],
      "preview_only": false,
      "elapsed_seconds": 2.5,
      "eta_seconds": -1.0,
      "levels": [
        {
          "level": 0,
          "frames_done": 12,
          "frames_total": 41,
          "vertices": 128
        }
      ],
      "tasks": [
        {
          "id": 3,
          "kind": "level",
          "level": 1,
          "first": 0,
          "last": 40,
          "state": "running",
          "frames_done": 5,
          "worker": "w1",
          "attempts": 1,
          "reason": "",
          "horizontal": false,
          "stitch": false
        }
      ]
    }
  ]
})";
  EXPECT_EQ(to_json_text(m), expected);
  EXPECT_EQ(to_json_text(StatusReply{}), "{\n  \"jobs\": []\n}");
  const WorkersReply w{{{2, "w2", "node-2", "0.4.0", 4, "idle", 0, 1.5, 3, ""}}, {}, 0};
  EXPECT_EQ(to_json_text(w), R"({
  "workers": [
    {
      "id": 2,
      "name": "w2",
      "host": "node-2",
      "version": "0.4.0",
      "cores": 4,
      "state": "idle",
      "task": 0,
      "seen_seconds_ago": 1.5,
      "tasks_done": 3,
      "slurm_job": ""
    }
  ],
  "slurm": [],
  "slurm_keep": 0
})");
}

TEST(ProtocolReplies, MessagesOfOtherFamiliesAreRefused) {
  EXPECT_EQ(error_of(encode(Refused{"x"})), "refused: not a scheduler reply (it is a scheduler command)");
  EXPECT_EQ(error_of(encode(TaskFailed{})), "task_failed: not a scheduler reply (it is a worker report)");
  EXPECT_EQ(error_of(encode(WorkersRequest{})), "workers: not a scheduler reply (it is a client request)");
}

TEST(ProtocolReplies, EveryRequiredFieldIsCheckedByName) {
  EXPECT_EQ(check_every_field_required(encode(Submitted{1}), "", ""), 1);
  EXPECT_EQ(check_every_field_required(encode(Accepted{1, "m"}), "", ""), 2);
  EXPECT_EQ(check_every_field_required(encode(ErrorReply{"m"}), "", ""), 1);
  EXPECT_EQ(check_every_field_required(encode(FetchReply{1, "abc"}), "", ""), 2);
  const Parts status = encode(sample_status());
  EXPECT_EQ(check_every_field_required(status, "", ""), 1);
  EXPECT_EQ(check_every_field_required(status, "/jobs/1", "jobs[1]."), 14);
  EXPECT_EQ(check_every_field_required(status, "/jobs/0/levels/1", "jobs[0].levels[1]."), 4);
  EXPECT_EQ(check_every_field_required(status, "/jobs/0/tasks/2", "jobs[0].tasks[2]."), 12);
  const Parts workers = encode(sample_workers());
  EXPECT_EQ(check_every_field_required(workers, "", ""), 3);
  EXPECT_EQ(check_every_field_required(workers, "/workers/1", "workers[1]."), 10);
  EXPECT_EQ(check_every_field_required(workers, "/slurm/1", "slurm[1]."), 7);
  EXPECT_EQ(check_every_field_required(encode(SlurmAccepted{"1", {"1_0"}, "m"}), "", ""), 3);
}

TEST(ProtocolReplies, EveryFieldOfTheWrongTypeIsRefusedByName) {
  EXPECT_EQ(check_every_field_typed(encode(Submitted{1}), "", ""), 1);
  EXPECT_EQ(check_every_field_typed(encode(Accepted{1, "m"}), "", ""), 2);
  EXPECT_EQ(check_every_field_typed(encode(ErrorReply{"m"}), "", ""), 1);
  EXPECT_EQ(check_every_field_typed(encode(FetchReply{1, "abc"}), "", ""), 2);
  const Parts status = encode(sample_status());
  EXPECT_EQ(check_every_field_typed(status, "", ""), 1);
  EXPECT_EQ(check_every_field_typed(status, "/jobs/0", "jobs[0]."), 14);
  EXPECT_EQ(check_every_field_typed(status, "/jobs/0/levels/0", "jobs[0].levels[0]."), 4);
  EXPECT_EQ(check_every_field_typed(status, "/jobs/0/tasks/1", "jobs[0].tasks[1]."), 12);
  const Parts workers = encode(sample_workers());
  EXPECT_EQ(check_every_field_typed(workers, "", ""), 3);
  EXPECT_EQ(check_every_field_typed(workers, "/workers/0", "workers[0]."), 10);
  EXPECT_EQ(check_every_field_typed(workers, "/slurm/0", "slurm[0]."), 7);
  EXPECT_EQ(check_every_field_typed(encode(SlurmAccepted{"1", {"1_0"}, "m"}), "", ""), 3);
}

TEST(ProtocolReplies, UnknownStateAndKindNamesAreRefusedWithTheAllowedOnes) {
  const Parts status = encode(sample_status());
  Json h = header(status);
  h["jobs"][0]["state"] = "paused";
  EXPECT_EQ(error_of(with_header(status, h)), "status_reply: field 'jobs[0].state': unknown job state 'paused' "
                                              "(allowed: queued, running, done, failed, cancelled)");
  h = header(status);
  h["jobs"][0]["tasks"][1]["state"] = "Running";
  EXPECT_TRUE(has(error_of(with_header(status, h)),
                  "status_reply: field 'jobs[0].tasks[1].state': unknown task state 'Running' (allowed: waiting,"));
  h = header(status);
  h["jobs"][1]["tasks"] = Json::array({header(status)["jobs"][0]["tasks"][0]});
  h["jobs"][1]["tasks"][0]["kind"] = "";
  EXPECT_EQ(error_of(with_header(status, h)),
            "status_reply: field 'jobs[1].tasks[0].kind': unknown task kind '' (allowed: hierarchy, level)");
  h = header(status);
  h["jobs"][0]["levels"][0]["frames_done"] = -1;
  EXPECT_TRUE(has(error_of(with_header(status, h)), "status_reply: field 'jobs[0].levels[0].frames_done': -1 is"));
  EXPECT_TRUE(has(error_of(with_field(status, "jobs", Json::array({1}))),
                  "status_reply: field 'jobs[0]': expected an object, got number 1"));
}

TEST(ProtocolReplies, WrongPartCountsAndSizesAreRefused) {
  Parts fetch = encode(FetchReply{3, "job file bytes"});
  fetch.push_back("");
  EXPECT_EQ(error_of(fetch), "fetch_reply: 3 parts, expected 2");
  fetch.resize(1);
  EXPECT_EQ(error_of(fetch), "fetch_reply: 1 part, expected 2");
  fetch = encode(FetchReply{3, "job file bytes"});
  fetch[1].pop_back();
  EXPECT_EQ(error_of(fetch), "fetch_reply: part 1: 13 bytes, expected 14 (field 'bytes')");
  fetch[1] += "xy";
  EXPECT_EQ(error_of(fetch), "fetch_reply: part 1: 15 bytes, expected 14 (field 'bytes')");
  EXPECT_TRUE(has(error_of(with_field(encode(FetchReply{3, "abc"}), "bytes", -3)),
                  "fetch_reply: field 'bytes': -3 is negative"));
  EXPECT_TRUE(has(error_of(with_field(encode(FetchReply{3, "abc"}), "bytes", int64_t{1} << 31)),
                  "fetch_reply: field 'bytes': 2147483648 bytes is over the message limit"));
  for (Parts p : {encode(Submitted{1}), encode(Accepted{}), encode(sample_status()), encode(sample_workers()),
                  encode(ErrorReply{})}) {
    const std::string type = header(p)["type"];
    p.push_back("");
    EXPECT_EQ(error_of(p), type + ": 2 parts, expected 1");
  }
}

}  // namespace
}  // namespace pd::protocol
