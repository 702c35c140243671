// The SQLite RAII layer (store/sqlite_db.h).
#include "store/sqlite_db.h"

#include <sqlite3.h>

#include <algorithm>
#include <climits>
#include <deque>
#include <nlohmann/json.hpp>

#include "protocol/wire.h"

namespace pd::sqlite {

namespace {

const char* type_name(int type) {
  switch (type) {
    case SQLITE_INTEGER: return "integer";
    case SQLITE_FLOAT: return "real";
    case SQLITE_TEXT: return "text";
    case SQLITE_BLOB: return "blob";
    case SQLITE_NULL: return "null";
  }
  return "unknown";
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Db

Db::Db(const std::string& path) : path_(path) {
  const int rc = sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
  if (rc != SQLITE_OK) {
    // sqlite3_open_v2 gives a handle even on failure (except out of memory), for the message.
    const std::string message = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
    sqlite3_close(db_);
    db_ = nullptr;
    throw StoreError(path_ + ": open: " + message);
  }
  // Constraint failures etc. are then reported with their extended code in sqlite3_errmsg.
  sqlite3_extended_result_codes(db_, 1);
}

Db::~Db() {
  // Statements are finalized by their own destructors before the Db goes; sqlite3_close_v2 would
  // otherwise defer the close until they are.
  sqlite3_close_v2(db_);
}

void Db::exec(std::string_view sql, const std::string& what) {
  const std::string text(sql);
  char* message = nullptr;
  const int rc = sqlite3_exec(db_, text.c_str(), nullptr, nullptr, &message);
  if (rc != SQLITE_OK) {
    const std::string m = message ? message : sqlite3_errstr(rc);
    sqlite3_free(message);
    fail_with((what.empty() ? label_ : what) + ": " + m);
  }
}

void Db::busy_timeout(int milliseconds) {
  if (sqlite3_busy_timeout(db_, milliseconds) != SQLITE_OK) fail("busy_timeout");
}

int64_t Db::last_insert_id() const { return sqlite3_last_insert_rowid(db_); }

int Db::changes() const { return sqlite3_changes(db_); }

void Db::fail(const std::string& what) const {
  fail_with((what.empty() ? label_ : what) + ": " + sqlite3_errmsg(db_));
}

void Db::fail_with(const std::string& message) const { throw StoreError(path_ + ": " + message); }

// ---------------------------------------------------------------------------------------------------
// Statement

Statement::Statement(Db& db, std::string_view sql, const std::string& what) : db_(db), what_(what) {
  if (sqlite3_prepare_v2(db_.handle(), sql.data(), static_cast<int>(sql.size()), &stmt_, nullptr) != SQLITE_OK)
    db_.fail(what_);
  if (!stmt_) db_.fail_with((what_.empty() ? db_.label() : what_) + ": empty statement");
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

void Statement::check_bind(int rc, int index) {
  if (rc != SQLITE_OK) db_.fail((what_.empty() ? db_.label() : what_) + ": parameter " + std::to_string(index));
}

Statement& Statement::bind(int index, int64_t value) {
  check_bind(sqlite3_bind_int64(stmt_, index, value), index);
  return *this;
}

Statement& Statement::bind(int index, int value) { return bind(index, static_cast<int64_t>(value)); }

Statement& Statement::bind(int index, double value) {
  check_bind(sqlite3_bind_double(stmt_, index, value), index);
  return *this;
}

Statement& Statement::bind(int index, const std::string& value) {
  // SQLITE_TRANSIENT: SQLite copies the text, so the argument may go before the step.
  check_bind(sqlite3_bind_text64(stmt_, index, value.data(), value.size(), SQLITE_TRANSIENT, SQLITE_UTF8), index);
  return *this;
}

Statement& Statement::bind(int index, const char* value) { return bind(index, std::string(value)); }

Statement& Statement::bind(int index, const Blob& value) {
  // A zero-length blob still binds as a BLOB (not NULL): the pointer must be non-null.
  static const char kEmpty = 0;
  check_bind(sqlite3_bind_blob64(stmt_, index, value.bytes.empty() ? &kEmpty : value.bytes.data(), value.bytes.size(),
                                 SQLITE_TRANSIENT),
             index);
  return *this;
}

Statement& Statement::bind(int index, std::nullptr_t) {
  check_bind(sqlite3_bind_null(stmt_, index), index);
  return *this;
}

Statement& Statement::bind(int index, std::optional<double> value) {
  return value ? bind(index, *value) : bind(index, nullptr);
}

Statement& Statement::bind(int index, std::optional<int64_t> value) {
  return value ? bind(index, *value) : bind(index, nullptr);
}

bool Statement::step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  db_.fail(what_);
}

void Statement::run() {
  if (step()) db_.fail_with((what_.empty() ? db_.label() : what_) + ": statement returned a row");
}

void Statement::reset() {
  // sqlite3_reset repeats the last step's error, which step() has already thrown.
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

int Statement::columns() const { return sqlite3_column_count(stmt_); }

bool Statement::is_null(int column) const { return sqlite3_column_type(stmt_, column) == SQLITE_NULL; }

void Statement::check_type(int column, int expected) const {
  const int type = sqlite3_column_type(stmt_, column);
  if (type == expected || (expected == SQLITE_FLOAT && type == SQLITE_INTEGER)) return;
  const char* name = sqlite3_column_name(stmt_, column);
  db_.fail_with((what_.empty() ? db_.label() : what_) + ": column '" + (name ? name : "?") + "' holds " +
                type_name(type) + ", expected " + type_name(expected));
}

int64_t Statement::column_int64(int column) const {
  check_type(column, SQLITE_INTEGER);
  return sqlite3_column_int64(stmt_, column);
}

int Statement::column_int(int column) const {
  const int64_t v = column_int64(column);
  if (v < INT_MIN || v > INT_MAX) {
    const char* name = sqlite3_column_name(stmt_, column);
    db_.fail_with((what_.empty() ? db_.label() : what_) + ": column '" + (name ? name : "?") + "': " +
                  std::to_string(v) + " does not fit an int");
  }
  return static_cast<int>(v);
}

double Statement::column_double(int column) const {
  check_type(column, SQLITE_FLOAT);
  return sqlite3_column_double(stmt_, column);
}

std::string Statement::column_text(int column) const {
  check_type(column, SQLITE_TEXT);
  const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(stmt_, column));
  const int bytes = sqlite3_column_bytes(stmt_, column);  // after column_text, as SQLite requires
  return text ? std::string(text, static_cast<size_t>(bytes)) : std::string();
}

std::string Statement::column_blob(int column) const {
  check_type(column, SQLITE_BLOB);
  const auto* bytes = static_cast<const char*>(sqlite3_column_blob(stmt_, column));
  const int n = sqlite3_column_bytes(stmt_, column);  // after column_blob, as SQLite requires
  return bytes ? std::string(bytes, static_cast<size_t>(n)) : std::string();
}

std::optional<double> Statement::column_optional_double(int column) const {
  if (is_null(column)) return std::nullopt;
  return column_double(column);
}

std::optional<int64_t> Statement::column_optional_int64(int column) const {
  if (is_null(column)) return std::nullopt;
  return column_int64(column);
}

// ---------------------------------------------------------------------------------------------------
// Transaction

Transaction::Transaction(Db& db, Mode mode, std::string label) : db_(db), previous_label_(db.label()) {
  db_.set_label(std::move(label));
  try {
    db_.exec(mode == Mode::immediate ? "BEGIN IMMEDIATE" : "BEGIN");
  } catch (...) {
    db_.set_label(previous_label_);
    throw;
  }
  open_ = true;
}

Transaction::~Transaction() {
  // A failed statement may already have rolled the transaction back (SQLite does so on some errors);
  // then there is nothing to undo, and ROLLBACK's "no transaction is active" is not worth reporting.
  if (open_ && !sqlite3_get_autocommit(db_.handle())) sqlite3_exec(db_.handle(), "ROLLBACK", nullptr, nullptr, nullptr);
  db_.set_label(previous_label_);
}

void Transaction::commit() {
  if (!open_) db_.fail_with(db_.label() + ": commit: the transaction is not open");
  if (sqlite3_get_autocommit(db_.handle()))
    db_.fail_with(db_.label() + ": commit: SQLite has already rolled the transaction back");
  db_.exec("COMMIT");
  open_ = false;
}

}  // namespace pd::sqlite

namespace pd::task_store_detail {

using protocol::JobState;
using protocol::TaskKind;
using protocol::TaskState;
using sqlite::Db;
using sqlite::Statement;

// Schema version 3 (1 had no frame data, no hierarchy blobs; 2 no stitches: kUpgrade2To3). States are their protocol names; ids of "none" are NULL; times are seconds since
// the Unix epoch.
const char* const kSchema = R"sql(
CREATE TABLE jobs(
  id INTEGER PRIMARY KEY,
  name TEXT NOT NULL,
  scene_name TEXT NOT NULL,
  scene_text TEXT NOT NULL,
  scene_files TEXT NOT NULL,          -- JSON array of {"path": ..., "content": ...}
  frames INTEGER NOT NULL,            -- N: frames t = 0..N
  levels INTEGER NOT NULL,
  subsets INTEGER NOT NULL,
  priority INTEGER NOT NULL,
  preview_only INTEGER NOT NULL,      -- 0 or 1
  preview_chunk INTEGER NOT NULL,
  hessian TEXT NOT NULL,
  state TEXT NOT NULL,
  reason TEXT NOT NULL DEFAULT '',
  hierarchy_hash TEXT NOT NULL DEFAULT '',
  submitted REAL NOT NULL,
  finished REAL NOT NULL DEFAULT 0,   -- 0 while the job has not ended
  stitch INTEGER NOT NULL DEFAULT 0,  -- W, frames per seam stitch; 0: none
  seams TEXT NOT NULL DEFAULT '[]');  -- JSON array: where each seam was placed and why
CREATE TABLE workers(
  id INTEGER PRIMARY KEY,
  name TEXT NOT NULL,
  host TEXT NOT NULL,
  version TEXT NOT NULL,
  cores INTEGER NOT NULL,
  state TEXT NOT NULL,                -- idle, busy, lost
  last_seen REAL NOT NULL,
  tasks_done INTEGER NOT NULL DEFAULT 0);
CREATE TABLE tasks(
  id INTEGER PRIMARY KEY,
  job_id INTEGER NOT NULL REFERENCES jobs(id),
  kind TEXT NOT NULL,
  level INTEGER NOT NULL,
  first INTEGER NOT NULL,
  last INTEGER NOT NULL,
  state TEXT NOT NULL,
  reason TEXT NOT NULL DEFAULT '',
  worker_id INTEGER REFERENCES workers(id),
  attempts INTEGER NOT NULL DEFAULT 0,
  stitch INTEGER NOT NULL DEFAULT 0,  -- 1: a seam's stitch task
  guides INTEGER NOT NULL DEFAULT 0); -- its frames first + 1 .. first + guides are guide frames
CREATE INDEX tasks_by_job ON tasks(job_id, state);
CREATE INDEX tasks_by_state ON tasks(state, job_id);
CREATE TABLE task_after(
  task_id INTEGER NOT NULL REFERENCES tasks(id),
  after_task_id INTEGER NOT NULL REFERENCES tasks(id),
  PRIMARY KEY(task_id, after_task_id)) WITHOUT ROWID;
CREATE INDEX task_after_by_after ON task_after(after_task_id);
CREATE TABLE task_frames(
  task_id INTEGER NOT NULL REFERENCES tasks(id),
  level INTEGER NOT NULL,
  frame INTEGER NOT NULL,
  guide INTEGER NOT NULL DEFAULT 0,   -- 1: a guide frame (guide_frames), 0: a frame (frames)
  PRIMARY KEY(task_id, level, frame)) WITHOUT ROWID;
CREATE TABLE frames(
  job_id INTEGER NOT NULL REFERENCES jobs(id),
  level INTEGER NOT NULL,
  frame INTEGER NOT NULL,
  kappa REAL,                         -- J/m^4; NULL when the scene has no contact
  positions BLOB NOT NULL,            -- 3 n float64, x0 y0 z0 x1 ..., little-endian (metres)
  stat_names TEXT NOT NULL,           -- JSON array of the frame's statistic names, in report order
  stat_values BLOB NOT NULL,          -- one float64 per name
  center_of_mass BLOB NOT NULL,       -- 3 float64 per object, or empty
  PRIMARY KEY(job_id, level, frame));
CREATE TABLE guide_frames(
  job_id INTEGER NOT NULL REFERENCES jobs(id),
  level INTEGER NOT NULL,
  frame INTEGER NOT NULL,
  positions BLOB NOT NULL,            -- as frames.positions
  PRIMARY KEY(job_id, level, frame));
CREATE TABLE hierarchies(
  job_id INTEGER PRIMARY KEY REFERENCES jobs(id),
  hash TEXT NOT NULL,
  blob BLOB NOT NULL);                -- the hierarchy file as the hierarchy task built it
CREATE TABLE attempts(
  id INTEGER PRIMARY KEY,
  task_id INTEGER NOT NULL REFERENCES tasks(id),
  worker_id INTEGER NOT NULL REFERENCES workers(id),
  started REAL NOT NULL,
  ended REAL,                         -- NULL while the attempt is open
  outcome TEXT,
  message TEXT NOT NULL DEFAULT '');
CREATE INDEX attempts_by_task ON attempts(task_id, ended);
CREATE TABLE events(
  id INTEGER PRIMARY KEY,
  time REAL NOT NULL,
  job_id INTEGER REFERENCES jobs(id),
  task_id INTEGER REFERENCES tasks(id),
  worker_id INTEGER REFERENCES workers(id),
  kind TEXT NOT NULL,
  message TEXT NOT NULL);
CREATE INDEX events_by_job ON events(job_id);
)sql";

const char* const kUpgrade2To3 = R"sql(
ALTER TABLE jobs ADD COLUMN stitch INTEGER NOT NULL DEFAULT 0;
ALTER TABLE jobs ADD COLUMN seams TEXT NOT NULL DEFAULT '[]';
ALTER TABLE tasks ADD COLUMN stitch INTEGER NOT NULL DEFAULT 0;
ALTER TABLE tasks ADD COLUMN guides INTEGER NOT NULL DEFAULT 0;
ALTER TABLE task_frames ADD COLUMN guide INTEGER NOT NULL DEFAULT 0;
CREATE TABLE guide_frames(
  job_id INTEGER NOT NULL REFERENCES jobs(id),
  level INTEGER NOT NULL,
  frame INTEGER NOT NULL,
  positions BLOB NOT NULL,
  PRIMARY KEY(job_id, level, frame));
)sql";

const char* const kJobColumns =
    "id, name, scene_name, scene_text, scene_files, frames, levels, subsets, priority, preview_only, "
    "preview_chunk, hessian, state, reason, hierarchy_hash, submitted, finished, stitch, seams";
// The current attempt of a task: its open one (a running task has at most one).
const char* const kTaskColumns =
    "t.id, t.job_id, t.kind, t.level, t.first, t.last, t.state, t.reason, t.worker_id, t.attempts, "
    "(SELECT MAX(a.id) FROM attempts a WHERE a.task_id = t.id AND a.ended IS NULL), t.stitch, t.guides";
const char* const kWorkerColumns = "id, name, host, version, cores, state, last_seen, tasks_done";

namespace {

// A stored state or kind name read back; a name this program does not know means a damaged store.
template <typename Parse>
auto parse_name(const Db& db, Parse&& parse) -> decltype(parse()) {
  try {
    return parse();
  } catch (const protocol::ProtocolError& e) {
    db.fail_with(e.what());
  }
}

std::vector<protocol::SceneFile> files_from_json(const Db& db, int64_t job, const std::string& text) {
  const std::string where = "job " + std::to_string(job) + ": scene_files: ";
  std::vector<protocol::SceneFile> files;
  try {
    const nlohmann::json list = nlohmann::json::parse(text);
    if (!list.is_array()) db.fail_with(where + "not a JSON array");
    for (const auto& f : list) files.push_back(protocol::wire::read_scene_file(protocol::wire::Fields(f, "scene_files", "")));
  } catch (const nlohmann::json::exception& e) {
    db.fail_with(where + e.what());
  } catch (const protocol::ProtocolError& e) {
    db.fail_with(where + e.what());
  }
  return files;
}

}  // namespace

std::string files_to_json(const Db& db, const std::vector<protocol::SceneFile>& files) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& f : files) list.emplace_back(protocol::wire::scene_file_json(f));
  try {
    return list.dump();  // throws for text that is not UTF-8 (the wire's JSON header cannot hold it either)
  } catch (const nlohmann::json::exception& e) {
    db.fail_with(std::string("add_job: scene files: ") + e.what());
  }
}

JobRow job_from(const Db& db, const Statement& st) {
  JobRow r;
  r.id = st.column_int64(0);
  const std::string what = "job " + std::to_string(r.id);
  r.spec.name = st.column_text(1);
  r.spec.scene.name = st.column_text(2);
  r.spec.scene.text = st.column_text(3);
  r.spec.scene.files = files_from_json(db, r.id, st.column_text(4));
  r.spec.frames = st.column_int(5);
  r.spec.levels = st.column_int(6);
  r.spec.subsets = st.column_int(7);
  r.spec.priority = st.column_int(8);
  r.spec.preview_only = st.column_int(9) != 0;
  r.spec.preview_chunk = st.column_int(10);
  r.spec.hessian = st.column_text(11);
  r.state = parse_name(db, [&] { return protocol::parse_job_state(st.column_text(12), what); });
  r.reason = st.column_text(13);
  r.hierarchy_hash = st.column_text(14);
  r.submitted = st.column_double(15);
  r.finished = st.column_double(16);
  r.spec.stitch = st.column_int(17);
  try {
    r.seams = nlohmann::json::parse(st.column_text(18)).get<std::vector<std::string>>();
  } catch (const nlohmann::json::exception& e) {
    db.fail_with(what + ": seams: " + e.what());
  }
  return r;
}

TaskRow task_from(const Db& db, const Statement& st) {
  TaskRow r;
  r.id = st.column_int64(0);
  const std::string what = "task " + std::to_string(r.id);
  r.job = st.column_int64(1);
  r.kind = parse_name(db, [&] { return protocol::parse_task_kind(st.column_text(2), what); });
  r.level = st.column_int(3);
  r.first = st.column_int(4);
  r.last = st.column_int(5);
  r.state = parse_name(db, [&] { return protocol::parse_task_state(st.column_text(6), what); });
  r.reason = st.column_text(7);
  r.worker = st.column_optional_int64(8).value_or(0);
  r.attempts = st.column_int(9);
  if (r.state == TaskState::running) r.attempt = st.column_optional_int64(10).value_or(0);
  r.stitch = st.column_int(11) != 0;
  r.guides = st.column_int(12);
  return r;
}

WorkerRow worker_from(const Statement& st) {
  WorkerRow r;
  r.id = st.column_int64(0);
  r.name = st.column_text(1);
  r.host = st.column_text(2);
  r.version = st.column_text(3);
  r.cores = st.column_int(4);
  r.state = st.column_text(5);
  r.last_seen = st.column_double(6);
  r.tasks_done = st.column_int(7);
  return r;
}

JobState job_state_from(const Db& db, const std::string& name, int64_t job) {
  return parse_name(db, [&] { return protocol::parse_job_state(name, "job " + std::to_string(job)); });
}

// A level task (a, b] produces the frames a + 1..b of its level (and frame 0 when a = 0). A level-l
// task (a, b] reads level l - 1's frames max(a - 1, 0)..b - 1 (frame t needs frames t - 1 and t - 2
// below, PD eq. 5; a vertical start at a reads frame a below), and continues horizontally from the
// task of its own level that ends where it starts. Every level task needs the hierarchy.
bool depends_on(const GraphTask& t2, const GraphTask& t1) {
  if (t2.kind != TaskKind::level || t2.id == t1.id) return false;
  if (t1.kind == TaskKind::hierarchy) return true;
  if (t2.level == t1.level) return t2.first == t1.last || (t2.stitch && !t1.stitch && t2.first == t1.first);
  if (t2.level != t1.level + 1) return false;
  const int produced_from = t1.first == 0 ? 0 : t1.first + 1;
  const int read_from = std::max(t2.first - 1, 0), read_to = t2.last - 1;
  return read_from <= t1.last && produced_from <= read_to;
}

std::vector<size_t> dependents(const std::vector<GraphTask>& tasks, size_t failed) {
  std::vector<size_t> found;
  std::vector<bool> reached(tasks.size(), false);
  reached.at(failed) = true;
  std::deque<size_t> frontier{failed};
  while (!frontier.empty()) {
    const GraphTask& from = tasks[frontier.front()];
    frontier.pop_front();
    for (size_t i = 0; i < tasks.size(); ++i) {
      if (reached[i] || tasks[i].state == TaskState::done || !depends_on(tasks[i], from)) continue;
      reached[i] = true;
      frontier.push_back(i);
      found.push_back(i);
    }
  }
  return found;
}

std::string block_reason(const GraphTask& failed, const std::string& reason) {
  const auto s = [](int64_t v) { return std::to_string(v); };
  if (failed.kind == TaskKind::hierarchy)
    return "needs the hierarchy of task " + s(failed.id) + ", which failed: " + reason;
  return "needs frames of task " + s(failed.id) + " (level " + s(failed.level) + ", frames (" + s(failed.first) + ", " +
         s(failed.last) + "]), which failed: " + reason;
}

}  // namespace pd::task_store_detail
