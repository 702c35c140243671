#include "farm/slurm.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "util/input_error.h"

namespace pd::farm {
namespace {

std::string error_of(const protocol::AddSlurmWorkers& m) {
  try {
    check_slurm_request(m);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

protocol::AddSlurmWorkers request(int count) {
  protocol::AddSlurmWorkers m;
  m.count = count;
  return m;
}

TEST(SlurmRequest, AcceptsEveryTimeFormatSlurmDocuments) {
  for (const char* t : {"30", "30:15", "2:00:00", "1-12", "1-12:30", "1-12:30:05", ""}) {
    protocol::AddSlurmWorkers m = request(2);
    m.time_limit = t;
    EXPECT_EQ(error_of(m), "") << t;
  }
}

TEST(SlurmRequest, RefusesEachBadFieldByItsOptionName) {
  EXPECT_EQ(error_of(request(0)), "--slurm: expected 1 to 1000 workers, got 0");
  EXPECT_EQ(error_of(request(1001)), "--slurm: expected 1 to 1000 workers, got 1001");
  protocol::AddSlurmWorkers m = request(1);
  m.time_limit = "1h";
  EXPECT_EQ(error_of(m), "--time: expected minutes, M:S, H:M:S, D-H, D-H:M or D-H:M:S (Slurm's formats), got '1h'");
  m = request(1);
  m.partition = "gpu;rm -rf";
  EXPECT_EQ(error_of(m), "--partition: expected 1 to 64 letters, digits, '_', '.' or '-'");
  m = request(1);
  m.memory = "4 GB";
  EXPECT_EQ(error_of(m), "--mem: expected a number of megabytes or a number with K, M, G or T (e.g. 4G), got '4 GB'");
  m = request(1);
  m.cpus = 5000;
  EXPECT_EQ(error_of(m), "--cpus: expected 1 to 4096, got 5000");
  m = request(1);
  m.keep = -2;
  EXPECT_EQ(error_of(m), "--keep: expected 0 to 1000, got -2");
}

TEST(SlurmSbatch, ArgvHasTheArrayTheLogPatternTheSiteOptionsThenScriptAndWorkerCommand) {
  SbatchCall call;
  call.script = "/opt/pd/pd-worker.sbatch";
  call.job_name = "pd-worker";
  call.log_dir = "/farm/slurm";
  call.worker_command = {"/opt/pd/bin/pd-worker", "--connect", "tcp://head:7400"};
  call.request = request(3);
  call.request.partition = "short";
  call.request.time_limit = "1:00:00";
  call.request.cpus = 2;
  call.request.memory = "4G";
  const std::vector<std::string> expected = {
      "sbatch", "--parsable", "--array=0-2", "--job-name=pd-worker", "--output=/farm/slurm/pd-worker-%A_%a.log",
      "--chdir=/farm/slurm", "--partition=short", "--time=1:00:00", "--cpus-per-task=2", "--mem=4G", "/opt/pd/pd-worker.sbatch",
      "/opt/pd/bin/pd-worker", "--connect", "tcp://head:7400"};
  EXPECT_EQ(sbatch_argv(call), expected);
  call.request = request(1);  // the script's own defaults: no site option at all
  EXPECT_EQ(sbatch_argv(call).size(), 6u + 1u + 3u);
  call.log_dir = "/farm/50%";
  EXPECT_THROW(sbatch_argv(call), InputError);
}

TEST(SlurmSbatch, JobIdIsReadFromParsableOutputWithOrWithoutCluster) {
  EXPECT_EQ(parse_sbatch_job_id("4711\n"), "4711");
  EXPECT_EQ(parse_sbatch_job_id("4711;cluster-a\n"), "4711");
  EXPECT_THROW(parse_sbatch_job_id("sbatch: error: Batch job submission failed\n"), InputError);
  EXPECT_THROW(parse_sbatch_job_id(""), InputError);
  EXPECT_THROW(parse_sbatch_job_id("4711_2\n"), InputError);  // sbatch names the array job, not a task
  EXPECT_EQ(array_task_ids("9", 3), (std::vector<std::string>{"9_0", "9_1", "9_2"}));
}

TEST(SlurmSqueue, LinesAreParsedAndFoldedPendingArraysUnfolded) {
  const std::string out =
      "4711_0|RUNNING|None\n"
      " 4711_[2-4,7%2]|PENDING|Resources \n"
      "garbage line\n"
      "4712|CANCELLED|None\n";
  const std::vector<SlurmJobState> jobs = parse_squeue(out);
  ASSERT_EQ(jobs.size(), 6u);
  EXPECT_EQ(jobs[0].id, "4711_0");
  EXPECT_EQ(jobs[0].state, "RUNNING");
  EXPECT_EQ(jobs[1].id, "4711_2");
  EXPECT_EQ(jobs[1].reason, "Resources");
  EXPECT_EQ(jobs[3].id, "4711_4");
  EXPECT_EQ(jobs[4].id, "4711_7");
  EXPECT_EQ(jobs[5].id, "4712");
  EXPECT_EQ(jobs[5].state, "CANCELLED");
  EXPECT_EQ(squeue_argv("pd-worker").back(), "--format=%i|%T|%r");
}

TEST(SlurmStates, ActiveStatesRunOrMayRunAndEveryEndIsNot) {
  for (const char* s : {"PENDING", "RUNNING", "CONFIGURING", "SUSPENDED", "REQUEUED", "SUBMITTED"})
    EXPECT_TRUE(slurm_state_active(s)) << s;
  for (const char* s : {"COMPLETING", "COMPLETED", "CANCELLED", "TIMEOUT", "FAILED", "NODE_FAIL", "PREEMPTED",
                        "OUT_OF_MEMORY", "GONE", "CANCELLING"})
    EXPECT_FALSE(slurm_state_active(s)) << s;
  EXPECT_TRUE(valid_slurm_job_id("123"));
  EXPECT_TRUE(valid_slurm_job_id("123_4"));
  for (const char* s : {"", "123_", "_4", "12a", "123_4_5", "-1", "123 "}) EXPECT_FALSE(valid_slurm_job_id(s)) << s;
}

}  // namespace
}  // namespace pd::farm
