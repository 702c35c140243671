// The farm's SQLite task store (store/task_store.h). Every public method is one transaction; methods
// that write begin it IMMEDIATE (taking the write lock first), so that a read-then-write is never
// overtaken by another connection and never fails on a stale snapshot (SQLITE_BUSY_SNAPSHOT, which
// the busy timeout does not retry).
#include "store/task_store.h"

#include <chrono>
#include <cstring>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "store/sqlite_db.h"
#include "store/task_store_internal.h"

namespace pd {
namespace {

using protocol::TaskKind;
// The helpers and names task_store_frames.cpp and task_store_failures.cpp share (Db, Statement, the
// schema's row readers, job_info, promote, read_task, close_attempts, ...): store/task_store_internal.h.
using namespace task_store_internal;

// An id of "none" (0) is stored as NULL.
std::optional<int64_t> id_or_null(int64_t id) { return id == 0 ? std::nullopt : std::optional<int64_t>(id); }

// One UPDATE of row `id` (bound to ?1, the arguments to ?2, ...) as a transaction of its own; StoreError
// "no <noun> <id>" when the row does not exist.
template <typename... Args>
void update_row(Db& db, const char* label, const char* noun, const char* sql, int64_t id, const Args&... args) {
  Transaction tx(db, Mode::immediate, label);
  if (run_sql(db, sql, id, args...) == 0) db.fail_with(std::string("no ") + noun + " " + std::to_string(id));
  tx.commit();
}

void require_row(Db& db, const char* sql, const char* noun, int64_t id) {
  Statement st(db, sql);
  if (!st.bind_all(id).step()) db.fail_with(std::string("no ") + noun + " " + str(id));
}
void require_worker(Db& db, int64_t worker) {
  require_row(db, "SELECT 1 FROM workers WHERE id = ?1", "worker", worker);
}

void check_new_job(const Db& db, const NewJob& job) {
  auto at_least = [&](const char* field, int value, int min) {
    if (value < min)
      db.fail_with(std::string("add_job: ") + field + " " + str(value) + ", expected at least " + str(min));
  };
  at_least("frames", job.frames, 1);
  at_least("levels", job.levels, 1);
  at_least("subsets", job.subsets, 1);
  at_least("preview_chunk", job.preview_chunk, 0);
}

void check_new_task(const Db& db, const std::string& where, const NewTask& t, int64_t job, const JobInfo& info) {
  if (t.level < 0 || t.level >= info.levels)
    db.fail_with(where + "level " + str(t.level) + " outside 0.." + str(info.levels - 1));
  const bool frames_ok = t.kind == TaskKind::level ? 0 <= t.first && t.first < t.last && t.last <= info.frames
                                                   : 0 <= t.first && t.first <= t.last && t.last <= info.frames;
  if (!frames_ok)
    db.fail_with(where + "frames (" + str(t.first) + ", " + str(t.last) + "] not within (0, " + str(info.frames) +
                 "] with first < last");
  if (t.kind == TaskKind::hierarchy && t.after_hierarchy)
    db.fail_with(where + "a hierarchy task cannot wait for itself");
  for (const FrameKey& k : t.needs) check_frame(db, (where + "needs").c_str(), job, info, k);
  for (const FrameKey& k : t.guide_needs) check_frame(db, (where + "guide_needs").c_str(), job, info, k);
  if (t.guides < 0 || (t.kind == TaskKind::level && t.first + t.guides >= t.last))
    db.fail_with(where + "guides " + str(t.guides) + ": a task (" + str(t.first) + ", " + str(t.last) +
                 "] keeps at least its last frame");
  if (t.stitch && (t.kind != TaskKind::level || t.level < 1 || t.first < 1 || t.guides != 0))
    db.fail_with(where + "a stitch task is a level task of a refinement level after frame 0, with no guides");
}

}  // namespace

namespace task_store_internal {

// Inserts `tasks` (in their order, so ids follow it) with their dependencies, as waiting; the caller
// promotes them.
// Returns the new tasks' ids, in the order given.
std::vector<int64_t> insert_tasks(Db& db, const char* what, int64_t job, const JobInfo& info,
                                  const std::vector<NewTask>& tasks) {
  if (tasks.empty()) db.fail_with(std::string(what) + ": job " + str(job) + ": no tasks given");
  Statement existing(db, "SELECT id FROM tasks WHERE job_id = ?1 AND kind = ?2 ORDER BY id");
  int64_t hierarchy = existing.bind_all(job, to_string(TaskKind::hierarchy)).step() ? existing.column_int64(0) : 0;
  Statement insert(db, "INSERT INTO tasks(job_id, kind, level, first, last, state, stitch, guides) "
                       "VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)");
  std::vector<int64_t> ids;
  for (size_t i = 0; i < tasks.size(); ++i) {
    const NewTask& t = tasks[i];
    const std::string where = std::string(what) + ": task " + str(static_cast<int64_t>(i) + 1) + " of " +
                              str(static_cast<int64_t>(tasks.size())) + ": ";
    check_new_task(db, where, t, job, info);
    if (t.kind == TaskKind::hierarchy && hierarchy != 0)
      db.fail_with(where + "job " + str(job) + " already has a hierarchy task (" + str(hierarchy) + ")");
    insert.bind_all(job, to_string(t.kind), t.level, t.first, t.last, to_string(TaskState::waiting), t.stitch ? 1 : 0,
                    t.guides).run();
    insert.reset();
    ids.push_back(db.last_insert_id());
    if (t.kind == TaskKind::hierarchy) hierarchy = ids.back();
  }
  Statement after(db, "INSERT INTO task_after(task_id, after_task_id) VALUES(?1, ?2)");
  Statement needs(db, "INSERT OR IGNORE INTO task_frames(task_id, level, frame, guide) VALUES(?1, ?2, ?3, ?4)");
  for (size_t i = 0; i < tasks.size(); ++i) {
    if (tasks[i].after_hierarchy) {
      if (hierarchy == 0)
        db.fail_with(std::string(what) + ": task " + str(static_cast<int64_t>(i) + 1) +
                     " waits for the hierarchy, but job " + str(job) + " has no hierarchy task");
      after.bind_all(ids[i], hierarchy).run();
      after.reset();
    }
    for (const FrameKey& k : tasks[i].needs) {
      needs.bind_all(ids[i], k.level, k.frame, 0).run();
      needs.reset();
    }
    for (const FrameKey& k : tasks[i].guide_needs) {
      needs.bind_all(ids[i], k.level, k.frame, 1).run();
      needs.reset();
    }
  }
  return ids;
}

}  // namespace task_store_internal

TaskStore::TaskStore(const std::string& path) : impl_(std::make_unique<Impl>(path)) {
  Db& db = impl_->db;
  db.set_label("open");
  db.busy_timeout(5000);
  db.exec("PRAGMA foreign_keys = ON");
  // The schema is checked and created under the write lock (two processes opening a new file at once
  // must not both create it), and before journal_mode changes the file.
  impl_->write("open", [&] {
    Statement version(db, "PRAGMA user_version");
    version.step();
    const int v = version.column_int(0);
    Statement tables(db, "SELECT COUNT(*) FROM sqlite_master");
    tables.step();
    const int64_t n = tables.column_int64(0);
    if (v == 0 && n == 0) {
      db.exec(kSchema);
      // PRAGMA takes no parameters; the value is this program's constant.
      db.exec("PRAGMA user_version = " + std::to_string(kTaskStoreSchemaVersion));
    } else if (v == 2) {
      db.exec(kUpgrade2To3);
      db.exec("PRAGMA user_version = " + std::to_string(kTaskStoreSchemaVersion));
    } else if (v == 0) {
      db.fail_with("not a task store (no schema version, " + str(n) + " schema objects)");
    } else if (v != kTaskStoreSchemaVersion) {
      db.fail_with("schema version " + str(v) + ", this program reads " + str(kTaskStoreSchemaVersion));
    }
  });
  {
    Statement wal(db, "PRAGMA journal_mode = WAL");
    const std::string mode = wal.step() ? wal.column_text(0) : "";
    if (mode != "wal") db.fail_with("open: journal_mode is '" + mode + "', expected 'wal'");
  }
  db.exec("PRAGMA synchronous = NORMAL");
  db.set_label("sqlite");
}

TaskStore::~TaskStore() = default;

const std::string& TaskStore::path() const { return impl_->db.path(); }

int64_t TaskStore::add_job(const NewJob& job, const std::vector<NewTask>& tasks) {
  Db& db = impl_->db;
  return impl_->write("add_job", [&] {
    check_new_job(db, job);
    Statement st(db, "INSERT INTO jobs(name, scene_name, scene_text, scene_files, frames, levels, subsets, priority, "
                     "preview_only, preview_chunk, hessian, state, submitted, stitch) "
                     "VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14)");
    st.bind_all(job.name, job.scene.name, job.scene.text, files_to_json(db, job.scene.files), job.frames, job.levels,
                job.subsets, job.priority, job.preview_only ? 1 : 0, job.preview_chunk, job.hessian,
                to_string(JobState::queued), now(), job.stitch)
        .run();
    const int64_t id = db.last_insert_id();
    insert_tasks(db, "add_job", id, JobInfo{JobState::queued, job.frames, job.levels}, tasks);
    promote(db, id);
    return id;
  });
}

void TaskStore::add_tasks(int64_t job, const std::vector<NewTask>& tasks) {
  Db& db = impl_->db;
  impl_->write("add_tasks", [&] {
    const JobInfo info = job_info(db, job);
    if (info.state == JobState::failed || info.state == JobState::cancelled)
      db.fail_with("add_tasks: job " + str(job) + " is " + to_string(info.state));
    insert_tasks(db, "add_tasks", job, info, tasks);
    if (info.state == JobState::done)
      run_sql(db, "UPDATE jobs SET state = ?2, finished = 0 WHERE id = ?1", job, to_string(JobState::running));
    promote(db, job);
  });
}

JobRow TaskStore::job(int64_t id) const {
  std::optional<JobRow> row = find_job(id);
  if (!row) impl_->db.fail_with("no job " + str(id));
  return *row;
}

std::optional<JobRow> TaskStore::find_job(int64_t id) const {
  Db& db = impl_->db;
  return impl_->read("job", [&] {
    Statement st(db, std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?1");
    return st.bind_all(id).step() ? std::optional<JobRow>(job_from(db, st)) : std::nullopt;
  });
}

std::vector<JobRow> TaskStore::jobs() const {
  Db& db = impl_->db;
  return impl_->read("jobs", [&] {
    Statement st(db, std::string("SELECT ") + kJobColumns + " FROM jobs ORDER BY id");
    std::vector<JobRow> rows;
    while (st.step()) rows.push_back(job_from(db, st));
    return rows;
  });
}

void TaskStore::set_job_state(int64_t job, JobState state, const std::string& reason) {
  update_row(impl_->db, "set_job_state", "job", "UPDATE jobs SET state = ?2, reason = ?3, finished = ?4 WHERE id = ?1",
             job, to_string(state), reason, job_ended(state) ? now() : 0.0);
}

void TaskStore::store_hierarchy(int64_t job, const std::string& hash, const std::string& blob) {
  Db& db = impl_->db;
  impl_->write("store_hierarchy", [&] {
    if (run_sql(db, "UPDATE jobs SET hierarchy_hash = ?2 WHERE id = ?1", job, hash) == 0) db.fail_with("no job " + str(job));
    run_sql(db, "INSERT INTO hierarchies(job_id, hash, blob) VALUES(?1, ?2, ?3) "
            "ON CONFLICT(job_id) DO UPDATE SET hash = excluded.hash, blob = excluded.blob", job, hash, sqlite::Blob{blob});
  });
}

std::string TaskStore::hierarchy_blob(int64_t job) const {
  Db& db = impl_->db;
  return impl_->read("hierarchy_blob", [&] {
    Statement st(db, "SELECT blob FROM hierarchies WHERE job_id = ?1");
    if (!st.bind_all(job).step()) db.fail_with("job " + str(job) + " has no stored hierarchy");
    return st.column_blob(0);
  });
}

void TaskStore::set_preview_only(int64_t job, bool preview_only) {
  update_row(impl_->db, "set_preview_only", "job", "UPDATE jobs SET preview_only = ?2 WHERE id = ?1", job,
             preview_only ? 1 : 0);
}

void TaskStore::set_seams(int64_t job, const std::vector<std::string>& reasons) {
  Db& db = impl_->db;
  std::string text;
  try {
    text = nlohmann::json(reasons).dump();
  } catch (const nlohmann::json::exception& e) {
    db.fail_with(std::string("set_seams: ") + e.what());
  }
  update_row(db, "set_seams", "job", "UPDATE jobs SET seams = ?2 WHERE id = ?1", job, text);
}

void TaskStore::set_subsets(int64_t job, int subsets, int stitch) {
  update_row(impl_->db, "set_subsets", "job", "UPDATE jobs SET subsets = ?2, stitch = ?3 WHERE id = ?1", job, subsets,
             stitch);
}

TaskRow TaskStore::task(int64_t id) const {
  return impl_->read("task", [&] { return read_task(impl_->db, id); });
}

std::vector<TaskRow> TaskStore::tasks(int64_t job) const {
  Db& db = impl_->db;
  return impl_->read("tasks", [&] {
    job_info(db, job);
    return job_tasks(db, job, "t.level, t.first, t.id");
  });
}

void TaskStore::finish_task(int64_t task) {
  Db& db = impl_->db;
  impl_->write("finish_task", [&] {
    const TaskRow t = read_task(db, task);
    if (t.state != TaskState::running && t.state != TaskState::ready)
      db.fail_with("task " + str(task) + " is " + to_string(t.state) + ", not running or ready");
    close_attempts(db, task, "done", "");
    set_task_state(db, task, TaskState::done, "", true);  // done keeps the worker that finished it
    free_worker(db, t.worker, true);
    promote(db, t.job);
    Statement left(db, "SELECT COUNT(*) FROM tasks WHERE job_id = ?1 AND state <> ?2");
    left.bind_all(t.job, to_string(TaskState::done)).step();
    if (left.column_int64(0) == 0)
      run_sql(db, "UPDATE jobs SET state = ?2, finished = ?3 WHERE id = ?1 AND state IN (?4, ?5)", t.job,
              to_string(JobState::done), now(), to_string(JobState::queued), to_string(JobState::running));
  });
}

std::optional<Claim> TaskStore::claim_next(int64_t worker) {
  Db& db = impl_->db;
  return impl_->write("claim_next", [&]() -> std::optional<Claim> {
    require_worker(db, worker);
    // Not a task this worker failed, nor one of a job it is blocklisted for.
    Statement pick(db, "SELECT t.id, t.job_id FROM tasks t JOIN jobs j ON j.id = t.job_id "
                       "WHERE t.state = ?1 AND j.state IN (?2, ?3) "
                       "AND NOT EXISTS (SELECT 1 FROM attempts a WHERE a.task_id = t.id AND a.worker_id = ?4 "
                       "                AND a.outcome = ?5) "
                       "AND (SELECT COUNT(*) FROM attempts a JOIN tasks u ON u.id = a.task_id "
                       "     WHERE u.job_id = t.job_id AND a.worker_id = ?4 AND a.outcome = ?5) < ?6 "
                       "ORDER BY j.priority DESC, j.id, t.level, t.first, t.id LIMIT 1");
    pick.bind_all(to_string(TaskState::ready), to_string(JobState::queued), to_string(JobState::running), worker,
                  kFailure, kBlocklistFailures);
    if (!pick.step()) return std::nullopt;
    const int64_t task = pick.column_int64(0), job = pick.column_int64(1);
    run_sql(db, "INSERT INTO attempts(task_id, worker_id, started) VALUES(?1, ?2, ?3)", task, worker, now());
    const int64_t attempt = db.last_insert_id();
    run_sql(db, "UPDATE tasks SET state = ?2, worker_id = ?3, attempts = attempts + 1, reason = '' WHERE id = ?1",
            task, to_string(TaskState::running), worker);
    run_sql(db, "UPDATE jobs SET state = ?2 WHERE id = ?1", job, to_string(JobState::running));
    run_sql(db, "UPDATE workers SET state = 'busy' WHERE id = ?1", worker);
    return Claim{read_task(db, task), attempt};
  });
}

bool TaskStore::has_ready_task() const {
  Db& db = impl_->db;
  return impl_->read("has_ready_task", [&] {
    Statement st(db, "SELECT 1 FROM tasks t JOIN jobs j ON j.id = t.job_id WHERE t.state = ?1 AND j.state IN (?2, ?3) "
                     "LIMIT 1");
    return st.bind_all(to_string(TaskState::ready), to_string(JobState::queued), to_string(JobState::running)).step();
  });
}

void TaskStore::end_attempt(int64_t attempt, const std::string& outcome, const std::string& message) {
  Db& db = impl_->db;
  impl_->write("end_attempt", [&] {
    if (outcome.empty()) db.fail_with("end_attempt: attempt " + str(attempt) + ": empty outcome");
    Statement st(db, "SELECT outcome FROM attempts WHERE id = ?1");
    if (!st.bind_all(attempt).step()) db.fail_with("no attempt " + str(attempt));
    if (!st.is_null(0)) db.fail_with("attempt " + str(attempt) + " has already ended (" + st.column_text(0) + ")");
    run_sql(db, "UPDATE attempts SET ended = ?2, outcome = ?3, message = ?4 WHERE id = ?1", attempt, now(), outcome,
            message);
  });
}

int64_t TaskStore::add_worker(const std::string& name, const std::string& host, const std::string& version,
                              int cores) {
  Db& db = impl_->db;
  return impl_->write("add_worker", [&] {
    if (cores < 1) db.fail_with("add_worker: cores " + str(cores) + ", expected at least 1");
    Statement known(db, "SELECT id FROM workers WHERE name = ?1 ORDER BY id LIMIT 1");
    if (known.bind_all(name).step()) {
      const int64_t id = known.column_int64(0);
      run_sql(db, "UPDATE workers SET host = ?2, version = ?3, cores = ?4, state = 'idle', last_seen = ?5 WHERE id = ?1",
              id, host, version, cores, now());
      return id;
    }
    run_sql(db, "INSERT INTO workers(name, host, version, cores, state, last_seen) VALUES(?1, ?2, ?3, ?4, 'idle', ?5)",
            name, host, version, cores, now());
    return db.last_insert_id();
  });
}

void TaskStore::set_worker_state(int64_t worker, const std::string& state) {
  if (state != "idle" && state != "busy" && state != "lost")
    impl_->db.fail_with("set_worker_state: unknown worker state '" + state + "' (allowed: idle, busy, lost)");
  update_row(impl_->db, "set_worker_state", "worker", "UPDATE workers SET state = ?2 WHERE id = ?1", worker, state);
}

void TaskStore::touch_worker(int64_t worker) {
  update_row(impl_->db, "touch_worker", "worker", "UPDATE workers SET last_seen = ?2 WHERE id = ?1", worker, now());
}

WorkerRow TaskStore::worker(int64_t id) const {
  Db& db = impl_->db;
  return impl_->read("worker", [&] {
    Statement st(db, std::string("SELECT ") + kWorkerColumns + " FROM workers WHERE id = ?1");
    if (!st.bind_all(id).step()) db.fail_with("no worker " + str(id));
    return worker_from(st);
  });
}

std::vector<WorkerRow> TaskStore::workers() const {
  Db& db = impl_->db;
  return impl_->read("workers", [&] {
    Statement st(db, std::string("SELECT ") + kWorkerColumns + " FROM workers ORDER BY id");
    std::vector<WorkerRow> rows;
    while (st.step()) rows.push_back(worker_from(st));
    return rows;
  });
}

void TaskStore::log_event(int64_t job, int64_t task, int64_t worker, const std::string& kind,
                          const std::string& message) {
  Db& db = impl_->db;
  impl_->write("log_event", [&] {
    if (kind.empty()) db.fail_with("log_event: empty kind");
    if (job != 0) job_info(db, job);
    if (task != 0) read_task(db, task);
    if (worker != 0) require_worker(db, worker);
    run_sql(db, "INSERT INTO events(time, job_id, task_id, worker_id, kind, message) VALUES(?1, ?2, ?3, ?4, ?5, ?6)",
            now(), id_or_null(job), id_or_null(task), id_or_null(worker), kind, message);
  });
}

std::vector<EventRow> TaskStore::events(int64_t job) const {
  Db& db = impl_->db;
  return impl_->read("events", [&] {
    if (job != 0) job_info(db, job);
    Statement st(db, "SELECT id, time, job_id, task_id, worker_id, kind, message FROM events "
                     "WHERE ?1 = 0 OR job_id = ?1 ORDER BY id");
    st.bind_all(job);
    std::vector<EventRow> rows;
    while (st.step()) {
      EventRow e;
      e.id = st.column_int64(0);
      e.time = st.column_double(1);
      e.job = st.column_optional_int64(2).value_or(0);
      e.task = st.column_optional_int64(3).value_or(0);
      e.worker = st.column_optional_int64(4).value_or(0);
      e.kind = st.column_text(5);
      e.message = st.column_text(6);
      rows.push_back(e);
    }
    return rows;
  });
}

}  // namespace pd
