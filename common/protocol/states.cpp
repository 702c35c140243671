// Names of the job, task and kind enums (protocol/protocol.h): the wire and the task store use them.
#include <array>
#include <utility>

#include "protocol/protocol.h"

namespace pd::protocol {

namespace {

template <typename E, std::size_t N>
std::string name_of(const std::array<std::pair<E, const char*>, N>& table, E value) {
  for (const auto& [e, name] : table)
    if (e == value) return name;
  return "unknown";
}

template <typename E, std::size_t N>
E value_of(const std::array<std::pair<E, const char*>, N>& table, const std::string& name, const std::string& what,
           const char* kind) {
  for (const auto& [e, n] : table)
    if (name == n) return e;
  std::string allowed;
  for (const auto& entry : table) allowed += std::string(allowed.empty() ? "" : ", ") + entry.second;
  throw ProtocolError(what + ": unknown " + kind + " '" + name + "' (allowed: " + allowed + ")");
}

constexpr std::array<std::pair<JobState, const char*>, 5> kJobStates{{{JobState::queued, "queued"},
                                                                       {JobState::running, "running"},
                                                                       {JobState::done, "done"},
                                                                       {JobState::failed, "failed"},
                                                                       {JobState::cancelled, "cancelled"}}};
constexpr std::array<std::pair<TaskState, const char*>, 7> kTaskStates{{{TaskState::waiting, "waiting"},
                                                                         {TaskState::ready, "ready"},
                                                                         {TaskState::running, "running"},
                                                                         {TaskState::done, "done"},
                                                                         {TaskState::failed, "failed"},
                                                                         {TaskState::blocked, "blocked"},
                                                                         {TaskState::cancelled, "cancelled"}}};
constexpr std::array<std::pair<TaskKind, const char*>, 2> kTaskKinds{
    {{TaskKind::hierarchy, "hierarchy"}, {TaskKind::level, "level"}}};
constexpr std::array<std::pair<FailureKind, const char*>, 2> kFailureKinds{
    {{FailureKind::error, "error"}, {FailureKind::vertical_start_refused, "vertical_start_refused"}}};

}  // namespace

std::string to_string(JobState s) { return name_of(kJobStates, s); }
std::string to_string(TaskState s) { return name_of(kTaskStates, s); }
std::string to_string(TaskKind k) { return name_of(kTaskKinds, k); }
std::string to_string(FailureKind k) { return name_of(kFailureKinds, k); }

JobState parse_job_state(const std::string& name, const std::string& what) {
  return value_of(kJobStates, name, what, "job state");
}
TaskState parse_task_state(const std::string& name, const std::string& what) {
  return value_of(kTaskStates, name, what, "task state");
}
TaskKind parse_task_kind(const std::string& name, const std::string& what) {
  return value_of(kTaskKinds, name, what, "task kind");
}
FailureKind parse_failure_kind(const std::string& name, const std::string& what) {
  return value_of(kFailureKinds, name, what, "failure kind");
}

}  // namespace pd::protocol
