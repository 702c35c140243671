#pragma once
// Inside the task store (store/task_store.h), shared by its source files: task_store.cpp (jobs,
// tasks, attempts, workers, events), task_store_failures.cpp (failed, refused and released attempts,
// moved seams, requeue, recovery, cancel) and task_store_frames.cpp (frames and guide frames). Not for
// other code: it names the store's SQL tables and its transaction helper.
#include <chrono>
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "store/sqlite_db.h"
#include "store/task_store.h"

namespace pd {
namespace task_store_internal {

using protocol::JobState;
using protocol::TaskState;
using protocol::to_string;
using sqlite::Db;
using sqlite::Statement;
using sqlite::Transaction;
using namespace task_store_detail;  // the schema, row readers and dependency walk (store/sqlite_db.h)
using Mode = Transaction::Mode;

inline double now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

inline std::string str(int64_t v) { return std::to_string(v); }

// Runs one statement that returns no row with the arguments bound to ?1, ?2, ...; returns the rows
// it changed.
template <typename... Args>
int run_sql(Db& db, const char* sql, const Args&... args) {
  Statement st(db, sql);
  st.bind_all(args...).run();
  return db.changes();
}

inline sqlite::Blob doubles_blob(const std::vector<double>& v) {
  sqlite::Blob b;
  b.bytes.resize(v.size() * sizeof(double));
  if (!v.empty()) std::memcpy(b.bytes.data(), v.data(), b.bytes.size());
  return b;
}

inline std::vector<double> blob_doubles(const Db& db, const std::string& bytes, const char* what) {
  if (bytes.size() % sizeof(double) != 0)
    db.fail_with(std::string("frame ") + what + ": " + std::to_string(bytes.size()) + " bytes, not whole float64s");
  std::vector<double> v(bytes.size() / sizeof(double));
  if (!v.empty()) std::memcpy(v.data(), bytes.data(), bytes.size());
  return v;
}

// What most methods need of a job, without reading its scene.
struct JobInfo {
  JobState state = JobState::queued;
  int frames = 0, levels = 0;
};

inline JobInfo job_info(Db& db, int64_t job) {
  Statement st(db, "SELECT state, frames, levels FROM jobs WHERE id = ?1");
  if (!st.bind_all(job).step()) db.fail_with("no job " + str(job));
  JobInfo info;
  info.state = job_state_from(db, st.column_text(0), job);
  info.frames = st.column_int(1);
  info.levels = st.column_int(2);
  return info;
}

// A frame of the job: level in [0, levels), frame t in [0, N].
inline void check_frame(const Db& db, const char* what, int64_t job, const JobInfo& info, const FrameKey& key) {
  if (key.level < 0 || key.level >= info.levels)
    db.fail_with(std::string(what) + ": job " + str(job) + ": level " + str(key.level) + " outside 0.." +
                 str(info.levels - 1));
  if (key.frame < 0 || key.frame > info.frames)
    db.fail_with(std::string(what) + ": job " + str(job) + ": frame " + str(key.frame) + " outside 0.." +
                 str(info.frames));
}

// The scheduler's rule (header comment): waiting -> ready once every task it waits after is done and
// every frame it needs is stored. Only the given job's tasks are looked at.
inline void promote(Db& db, int64_t job) {
  run_sql(db, R"sql(
    UPDATE tasks SET state = ?2 WHERE job_id = ?1 AND state = ?3
      AND NOT EXISTS (SELECT 1 FROM task_after a JOIN tasks d ON d.id = a.after_task_id
                      WHERE a.task_id = tasks.id AND d.state <> ?4)
      AND NOT EXISTS (SELECT 1 FROM task_frames f WHERE f.task_id = tasks.id AND f.guide = 0 AND NOT EXISTS
                      (SELECT 1 FROM frames s WHERE s.job_id = ?1 AND s.level = f.level AND s.frame = f.frame))
      AND NOT EXISTS (SELECT 1 FROM task_frames f WHERE f.task_id = tasks.id AND f.guide = 1 AND NOT EXISTS
                      (SELECT 1 FROM guide_frames g WHERE g.job_id = ?1 AND g.level = f.level AND g.frame = f.frame)))sql",
          job, to_string(TaskState::ready), to_string(TaskState::waiting), to_string(TaskState::done));
}

// The frames of `level` in [first, last] stored in `table` (frames or guide_frames, this file's names),
// sorted.
inline std::vector<int> frames_between(Db& db, const char* what, const char* table, int64_t job, int level, int first,
                                int last) {
  check_frame(db, what, job, job_info(db, job), FrameKey{level, 0});
  Statement st(db, std::string("SELECT frame FROM ") + table +
                       " WHERE job_id = ?1 AND level = ?2 AND frame BETWEEN ?3 AND ?4 ORDER BY frame");
  st.bind_all(job, level, first, last);
  std::vector<int> frames;
  while (st.step()) frames.push_back(st.column_int(0));
  return frames;
}

// ---- Tasks and attempts (task_store.cpp and task_store_failures.cpp) ----

inline bool job_ended(JobState s) { return s == JobState::done || s == JobState::failed || s == JobState::cancelled; }

// Failed attempts count against tasks and workers until the job is requeued (their outcome then
// becomes kRequeuedFailure).
inline constexpr char kFailure[] = "failed";
inline constexpr char kRequeuedFailure[] = "failed, requeued";
// An attempt whose vertical start was refused (continue_horizontally): not a failure of the worker.
inline constexpr char kVerticalRefused[] = "vertical start refused";

inline TaskRow read_task(Db& db, int64_t task) {
  Statement st(db, std::string("SELECT ") + kTaskColumns + " FROM tasks t WHERE t.id = ?1");
  if (!st.bind_all(task).step()) db.fail_with("no task " + str(task));
  return task_from(db, st);
}

// Closes the task's open attempt, if any.
inline void close_attempts(Db& db, int64_t task, const std::string& outcome, const std::string& message) {
  run_sql(db, "UPDATE attempts SET ended = ?2, outcome = ?3, message = ?4 WHERE task_id = ?1 AND ended IS NULL", task,
          now(), outcome, message);
}

// The worker that held a task is free again, unless the scheduler has meanwhile marked it lost.
inline void free_worker(Db& db, int64_t worker, bool credit) {
  if (worker == 0) return;
  run_sql(db, "UPDATE workers SET state = CASE WHEN state = 'busy' THEN 'idle' ELSE state END, "
          "tasks_done = tasks_done + ?2 WHERE id = ?1", worker, credit ? 1 : 0);
}

inline void set_task_state(Db& db, int64_t task, TaskState state, const std::string& reason, bool keep_worker) {
  run_sql(db, keep_worker ? "UPDATE tasks SET state = ?2, reason = ?3 WHERE id = ?1"
                          : "UPDATE tasks SET state = ?2, reason = ?3, worker_id = NULL WHERE id = ?1",
          task, to_string(state), reason);
}

// The tasks of a job in the given order (an ORDER BY list of this file, never a value).
inline std::vector<TaskRow> job_tasks(Db& db, int64_t job, const char* order) {
  Statement st(db, std::string("SELECT ") + kTaskColumns + " FROM tasks t WHERE t.job_id = ?1 ORDER BY " + order);
  st.bind_all(job);
  std::vector<TaskRow> rows;
  while (st.step()) rows.push_back(task_from(db, st));
  return rows;
}

// Inserts `tasks` (in their order, so ids follow it) with their dependencies, as waiting; the caller
// promotes them. Returns the new tasks' ids, in the order given. what: the method, for messages.
// (task_store.cpp)
std::vector<int64_t> insert_tasks(Db& db, const char* what, int64_t job, const JobInfo& info,
                                  const std::vector<NewTask>& tasks);

}  // namespace task_store_internal

struct TaskStore::Impl {
  using Db = sqlite::Db;
  using Mode = sqlite::Transaction::Mode;
  explicit Impl(const std::string& path) : db(path) {}

  // Runs body() as one transaction labelled with the method's name and returns its result; an
  // exception rolls it back. Writers take the write lock first (see the top of this file).
  template <typename Body>
  auto write(const char* label, Body&& body) { return run(Mode::immediate, label, body); }
  template <typename Body>
  auto read(const char* label, Body&& body) { return run(Mode::deferred, label, body); }

  template <typename Body>
  auto run(Mode mode, const char* label, Body& body) -> decltype(body()) {
    sqlite::Transaction tx(db, mode, label);
    if constexpr (std::is_void_v<decltype(body())>) {
      body();
      tx.commit();
    } else {
      auto result = body();
      tx.commit();
      return result;
    }
  }

  Db db;
};

}  // namespace pd
