// The task store's failures and recovery (store/task_store.h): a task failing for good and blocking
// what depends on it, attempts failed, released or refused their vertical start (the subset then
// continues horizontally or its seam moves), requeue, recovery after a scheduler restart, cancel.
// The rest of the store is in task_store.cpp; every method is one transaction, as there.
#include <string>
#include <vector>

#include "store/task_store_internal.h"

namespace pd {
namespace {

using protocol::TaskKind;
using namespace task_store_internal;

// The running attempt `attempt` of `task` found no safe upsampling for its vertical start
// (continue_horizontally, move_seam): checked to be that, closed as "vertical start refused" (a
// failure of neither task nor worker), the worker freed. Returns the task as it was.
TaskRow close_refused_start(Db& db, const char* what, int64_t task, int64_t attempt, const std::string& message) {
  const TaskRow t = read_task(db, task);
  if (t.state != TaskState::running || t.attempt != attempt)
    db.fail_with(std::string(what) + ": attempt " + str(attempt) + " is not task " + str(task) + "'s running attempt");
  if (t.kind != TaskKind::level || t.level < 1 || t.first < 1)
    db.fail_with(std::string(what) + ": task " + str(task) + " (level " + str(t.level) + ", first " + str(t.first) +
                 ") does not start vertically");
  run_sql(db, "UPDATE attempts SET ended = ?2, outcome = ?3, message = ?4 WHERE id = ?1", attempt, now(),
          kVerticalRefused, message);
  free_worker(db, t.worker, false);
  return t;
}

// A subset whose vertical start went away (continue_horizontally, move_seam) has no seam at its first
// frame to stitch: its guides become 0, and the stitch task of its seam, which waits for the first of
// those guide frames (it cannot have run without it; the scheduler never moves a seam whose guide
// frames are stored), is removed.
void remove_stitch_of(Db& db, const TaskRow& subset) {
  run_sql(db, "UPDATE tasks SET guides = 0 WHERE id = ?1", subset.id);
  Statement find(db, "SELECT id, state FROM tasks WHERE job_id = ?1 AND level = ?2 AND first = ?3 AND stitch = 1");
  find.bind_all(subset.job, subset.level, subset.first);
  std::vector<int64_t> stitches;
  while (find.step()) {
    if (find.column_text(1) != to_string(TaskState::waiting))
      db.fail_with("task " + str(subset.id) + ": its seam's stitch task " + str(find.column_int64(0)) + " is " +
                   find.column_text(1) + ", not waiting");
    stitches.push_back(find.column_int64(0));
  }
  for (const int64_t id : stitches) {
    run_sql(db, "DELETE FROM task_frames WHERE task_id = ?1", id);
    run_sql(db, "DELETE FROM task_after WHERE task_id = ?1", id);
    run_sql(db, "DELETE FROM events WHERE task_id = ?1", id);
    run_sql(db, "DELETE FROM tasks WHERE id = ?1", id);
  }
}

// Blocks every task of the job that is not done and needs, directly or through others, a frame of
// the failed task. Their open attempts close as "blocked" and their workers are freed (the scheduler
// tells those workers to stop).
void block_dependents(Db& db, const TaskRow& failed, const std::string& reason) {
  const std::vector<TaskRow> rows = job_tasks(db, failed.job, "t.id");
  std::vector<GraphTask> graph;
  size_t root = 0;
  for (const TaskRow& r : rows) {
    if (r.id == failed.id) root = graph.size();
    graph.push_back(GraphTask{r.id, r.kind, r.level, r.first, r.last, r.state, r.stitch});
  }
  const std::string why = block_reason(graph[root], reason);
  for (size_t i : dependents(graph, root)) {
    const TaskState state = rows[i].state;
    if (state != TaskState::waiting && state != TaskState::ready && state != TaskState::running) continue;
    close_attempts(db, rows[i].id, "blocked", why);
    set_task_state(db, rows[i].id, TaskState::blocked, why, false);
    free_worker(db, rows[i].worker, false);
  }
}

// The task fails for good (TaskStore::fail_task), inside the caller's transaction.
void fail_for_good(Db& db, const TaskRow& t, const std::string& reason) {
  if (t.state != TaskState::running && t.state != TaskState::ready)
    db.fail_with("task " + str(t.id) + " is " + to_string(t.state) + ", not running or ready");
  close_attempts(db, t.id, kFailure, reason);
  set_task_state(db, t.id, TaskState::failed, reason, false);
  free_worker(db, t.worker, false);
  block_dependents(db, t, reason);
  // The first failure gives the job's reason; a later one (of an independent task) leaves it.
  run_sql(db, "UPDATE jobs SET state = ?2, reason = ?3, finished = ?4 WHERE id = ?1 AND state IN (?5, ?6)", t.job,
          to_string(JobState::failed), "task " + str(t.id) + " failed: " + reason, now(),
          to_string(JobState::queued), to_string(JobState::running));
}

}  // namespace

void TaskStore::fail_task(int64_t task, const std::string& reason) {
  Db& db = impl_->db;
  impl_->write("fail_task", [&] { fail_for_good(db, read_task(db, task), reason); });
}

void TaskStore::release_task(int64_t task, const std::string& outcome) {
  Db& db = impl_->db;
  impl_->write("release_task", [&] {
    if (outcome.empty()) db.fail_with("release_task: task " + str(task) + ": empty outcome");
    const TaskRow t = read_task(db, task);
    if (t.state != TaskState::running)
      db.fail_with("task " + str(task) + " is " + to_string(t.state) + ", not running");
    close_attempts(db, task, outcome, "");
    set_task_state(db, task, TaskState::ready, "", false);
    free_worker(db, t.worker, false);
  });
}

FailOutcome TaskStore::fail_attempt(int64_t task, int64_t attempt, const std::string& message) {
  Db& db = impl_->db;
  const FailOutcome out = impl_->write("fail_attempt", [&] {
    const TaskRow t = read_task(db, task);
    if (t.state != TaskState::running || t.attempt != attempt)
      db.fail_with("fail_attempt: attempt " + str(attempt) + " is not task " + str(task) + "'s running attempt");
    run_sql(db, "UPDATE attempts SET ended = ?2, outcome = ?3, message = ?4 WHERE id = ?1", attempt, now(), kFailure,
            message);
    FailOutcome o;
    Statement workers(db, "SELECT COUNT(DISTINCT worker_id) FROM attempts WHERE task_id = ?1 AND outcome = ?2");
    workers.bind_all(task, kFailure).step();
    o.workers_failed = workers.column_int(0);
    Statement mine(db, "SELECT COUNT(*) FROM attempts a JOIN tasks u ON u.id = a.task_id "
                       "WHERE u.job_id = ?1 AND a.worker_id = ?2 AND a.outcome = ?3");
    mine.bind_all(t.job, t.worker, kFailure).step();
    o.worker_blocklisted = mine.column_int(0) == kBlocklistFailures;
    o.task_failed = o.workers_failed >= kMaxTaskWorkers;
    if (o.task_failed) {
      fail_for_good(db, t, message + " (failed on " + str(o.workers_failed) + " workers)");
    } else {
      set_task_state(db, task, TaskState::ready, message, false);
      free_worker(db, t.worker, false);
    }
    return o;
  });
  return out;
}

void TaskStore::continue_horizontally(int64_t task, int64_t attempt, const std::string& message) {
  Db& db = impl_->db;
  impl_->write("continue_horizontally", [&] {
    const TaskRow t = close_refused_start(db, "continue_horizontally", task, attempt, message);
    remove_stitch_of(db, t);
    for (const int frame : {t.first - 1, t.first})
      run_sql(db, "INSERT OR IGNORE INTO task_frames(task_id, level, frame) VALUES(?1, ?2, ?3)", task, t.level,
              frame);
    set_task_state(db, task, TaskState::waiting, "continues horizontally: " + message, false);
    promote(db, t.job);
  });
}

int64_t TaskStore::move_seam(int64_t task, int64_t attempt, int new_first, const std::vector<FrameKey>& needs,
                             const std::optional<NewTask>& stitch, const std::string& message) {
  Db& db = impl_->db;
  int64_t bridge = 0;
  impl_->write("move_seam", [&] {
    const TaskRow t = read_task(db, task);
    if (t.state == TaskState::running && t.attempt == attempt && (new_first <= t.first || new_first >= t.last))
      db.fail_with("move_seam: task " + str(task) + " (" + str(t.first) + ", " + str(t.last) + "]: the new seam " +
                   str(new_first) + " is not inside it");
    close_refused_start(db, "move_seam", task, attempt, message);
    remove_stitch_of(db, t);
    if (stitch) {
      if (!stitch->stitch || stitch->level != t.level || stitch->first != new_first || stitch->last >= t.last)
        db.fail_with("move_seam: task " + str(task) + ": the stitch given is not one for level " + str(t.level) +
                     " at the new seam " + str(new_first));
      insert_tasks(db, "move_seam", t.job, job_info(db, t.job), {*stitch});
      run_sql(db, "UPDATE tasks SET guides = ?2 WHERE id = ?1", task, stitch->last - stitch->first);
    }
    run_sql(db, "UPDATE tasks SET first = ?2 WHERE id = ?1", task, new_first);
    run_sql(db, "DELETE FROM task_frames WHERE task_id = ?1", task);
    for (const FrameKey& k : needs)
      run_sql(db, "INSERT OR IGNORE INTO task_frames(task_id, level, frame) VALUES(?1, ?2, ?3)", task, k.level,
              k.frame);
    set_task_state(db, task, TaskState::waiting,
                   "seam moved from " + str(t.first) + " to " + str(new_first) + ": " + message, false);
    NewTask b;
    b.kind = TaskKind::level;
    b.level = t.level;
    b.first = t.first;
    b.last = new_first;
    Statement after(db, "SELECT COUNT(*) FROM task_after WHERE task_id = ?1");
    b.after_hierarchy = after.bind_all(task).step() && after.column_int(0) > 0;  // as the task it bridges for
    b.needs = {FrameKey{t.level, t.first - 1}, FrameKey{t.level, t.first}};
    bridge = insert_tasks(db, "move_seam", t.job, job_info(db, t.job), {b}).front();
    promote(db, t.job);
  });
  return bridge;
}

int TaskStore::refused_starts(int64_t task) const {
  Db& db = impl_->db;
  return impl_->read("refused_starts", [&] {
    Statement st(db, "SELECT COUNT(*) FROM attempts WHERE task_id = ?1 AND outcome = ?2");
    st.bind_all(task, kVerticalRefused).step();
    return st.column_int(0);
  });
}

bool TaskStore::continues_horizontally(int64_t task) const {
  Db& db = impl_->db;
  return impl_->read("continues_horizontally", [&] {
    const TaskRow t = read_task(db, task);
    if (t.kind != TaskKind::level || t.level < 1 || t.first < 1) return false;
    Statement own(db, "SELECT COUNT(*) FROM task_frames WHERE task_id = ?1 AND level = ?2 AND frame = ?3");
    own.bind_all(task, t.level, t.first).step();
    return own.column_int(0) > 0;
  });
}

bool TaskStore::may_run(int64_t task, int64_t worker) const {
  Db& db = impl_->db;
  return impl_->read("may_run", [&] {
    const TaskRow t = read_task(db, task);
    Statement own(db, "SELECT COUNT(*) FROM attempts WHERE task_id = ?1 AND worker_id = ?2 AND outcome = ?3");
    own.bind_all(task, worker, kFailure).step();
    if (own.column_int(0) > 0) return false;
    Statement job(db, "SELECT COUNT(*) FROM attempts a JOIN tasks u ON u.id = a.task_id "
                      "WHERE u.job_id = ?1 AND a.worker_id = ?2 AND a.outcome = ?3");
    job.bind_all(t.job, worker, kFailure).step();
    return job.column_int(0) < kBlocklistFailures;
  });
}

int TaskStore::requeue_job(int64_t job) {
  Db& db = impl_->db;
  return impl_->write("requeue_job", [&] {
    const JobInfo info = job_info(db, job);
    if (info.state != JobState::failed)
      db.fail_with("job " + str(job) + " is " + to_string(info.state) + ", only a failed job can be requeued");
    run_sql(db, "UPDATE attempts SET outcome = ?2 WHERE outcome = ?3 AND task_id IN "
            "(SELECT id FROM tasks WHERE job_id = ?1)", job, kRequeuedFailure, kFailure);
    const int n = run_sql(db, "UPDATE tasks SET state = ?2, reason = '', worker_id = NULL "
                          "WHERE job_id = ?1 AND state IN (?3, ?4)", job, to_string(TaskState::waiting),
                          to_string(TaskState::failed), to_string(TaskState::blocked));
    run_sql(db, "UPDATE jobs SET state = ?2, reason = '', finished = 0 WHERE id = ?1", job, to_string(JobState::running));
    promote(db, job);
    return n;
  });
}

std::vector<TaskRow> TaskStore::recover_after_restart() {
  Db& db = impl_->db;
  return impl_->write("recover_after_restart", [&] {
    std::vector<TaskRow> released;
    Statement st(db, std::string("SELECT ") + kTaskColumns + " FROM tasks t WHERE t.state = ?1 ORDER BY t.id");
    st.bind_all(to_string(TaskState::running));
    while (st.step()) released.push_back(task_from(db, st));
    run_sql(db, "UPDATE attempts SET ended = ?1, outcome = 'scheduler restarted' WHERE ended IS NULL", now());
    run_sql(db, "UPDATE tasks SET state = ?1, worker_id = NULL WHERE state = ?2", to_string(TaskState::ready),
            to_string(TaskState::running));
    run_sql(db, "UPDATE workers SET state = 'lost'");
    return released;
  });
}

void TaskStore::cancel_job(int64_t job) {
  Db& db = impl_->db;
  impl_->write("cancel_job", [&] {
    const JobInfo info = job_info(db, job);
    if (job_ended(info.state)) db.fail_with("job " + str(job) + " is already " + to_string(info.state));
    for (const TaskRow& t : job_tasks(db, job, "t.id")) {
      if (t.state != TaskState::running) continue;
      close_attempts(db, t.id, "cancelled", "job cancelled");
      free_worker(db, t.worker, false);
    }
    run_sql(db, "UPDATE tasks SET state = ?2, worker_id = NULL WHERE job_id = ?1 AND state IN (?3, ?4, ?5)", job,
            to_string(TaskState::cancelled), to_string(TaskState::waiting), to_string(TaskState::ready),
            to_string(TaskState::running));
    run_sql(db, "UPDATE jobs SET state = ?2, finished = ?3 WHERE id = ?1", job, to_string(JobState::cancelled), now());
  });
}

}  // namespace pd
