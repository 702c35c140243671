#include <gtest/gtest.h>

#include <set>

#include "protocol/protocol.h"
#include "support/protocol_cases.h"

namespace pd::protocol {
namespace {

using namespace test;  // error_of: the helpers shared by the protocol tests

// The names are what the task store holds and the wire carries: written out here, not derived.
TEST(ProtocolStates, EveryJobStateRoundTripsThroughItsName) {
  const std::vector<std::pair<JobState, std::string>> names = {{JobState::queued, "queued"},
                                                               {JobState::running, "running"},
                                                               {JobState::done, "done"},
                                                               {JobState::failed, "failed"},
                                                               {JobState::cancelled, "cancelled"}};
  for (const auto& [state, name] : names) {
    EXPECT_EQ(to_string(state), name);
    EXPECT_EQ(parse_job_state(name, "job 1"), state);
  }
  EXPECT_EQ(static_cast<int>(JobState::cancelled) + 1, static_cast<int>(names.size()));  // none left out
}

TEST(ProtocolStates, EveryTaskStateRoundTripsThroughItsName) {
  const std::vector<std::pair<TaskState, std::string>> names = {
      {TaskState::waiting, "waiting"}, {TaskState::ready, "ready"},   {TaskState::running, "running"},
      {TaskState::done, "done"},       {TaskState::failed, "failed"}, {TaskState::blocked, "blocked"},
      {TaskState::cancelled, "cancelled"}};
  for (const auto& [state, name] : names) {
    EXPECT_EQ(to_string(state), name);
    EXPECT_EQ(parse_task_state(name, "task 1"), state);
  }
  EXPECT_EQ(static_cast<int>(TaskState::cancelled) + 1, static_cast<int>(names.size()));
}

TEST(ProtocolStates, EveryTaskKindRoundTripsThroughItsName) {
  EXPECT_EQ(to_string(TaskKind::hierarchy), "hierarchy");
  EXPECT_EQ(to_string(TaskKind::level), "level");
  EXPECT_EQ(parse_task_kind("hierarchy", "task 1"), TaskKind::hierarchy);
  EXPECT_EQ(parse_task_kind("level", "task 1"), TaskKind::level);
}

TEST(ProtocolStates, NamesAreDistinctWithinEachEnum) {
  std::set<std::string> task_names;
  for (int s = 0; s <= static_cast<int>(TaskState::cancelled); ++s)
    task_names.insert(to_string(static_cast<TaskState>(s)));
  EXPECT_EQ(task_names.size(), 7u);
  std::set<std::string> job_names;
  for (int s = 0; s <= static_cast<int>(JobState::cancelled); ++s)
    job_names.insert(to_string(static_cast<JobState>(s)));
  EXPECT_EQ(job_names.size(), 5u);
}

TEST(ProtocolStates, UnknownNamesAreRefusedListingTheAllowedOnes) {
  EXPECT_EQ(error_of([] { parse_job_state("finished", "farm.sqlite: job 3"); }),
            "farm.sqlite: job 3: unknown job state 'finished' (allowed: queued, running, done, failed, cancelled)");
  EXPECT_EQ(error_of([] { parse_task_state("Running", "task 9"); }),
            "task 9: unknown task state 'Running' (allowed: waiting, ready, running, done, failed, blocked, "
            "cancelled)");
  EXPECT_EQ(error_of([] { parse_task_kind("", "assign: field 'kind'"); }),
            "assign: field 'kind': unknown task kind '' (allowed: hierarchy, level)");
  EXPECT_EQ(error_of([] { parse_task_state("waiting ", "t"); }).rfind("t: unknown task state 'waiting '", 0), 0u);
  EXPECT_EQ(error_of([] { parse_job_state("ready", "j"); }).rfind("j: unknown job state 'ready'", 0), 0u);
}

}  // namespace
}  // namespace pd::protocol
