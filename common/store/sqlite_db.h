#pragma once
// A small RAII layer over the SQLite C API for the task store (store/task_store.h): a connection,
// prepared statements and a transaction guard. Every SQLite failure becomes StoreError whose what()
// names the database file, the operation and SQLite's message, e.g.
//   "farm.sqlite: claim_next: database is locked".
// The operation is the `what` given to the call, or else the label of the innermost open Transaction
// on the connection, or else "sqlite". Not thread-safe: use one Db from one thread at a time.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "store/task_store.h"  // StoreError (defined once, there)

struct sqlite3;
struct sqlite3_stmt;

namespace pd::sqlite {

class Db {
 public:
  // Opens (creating when missing) the database at `path`, read-write. Throws StoreError when the file
  // cannot be opened. SQLite reads the file lazily: a file that is not a database is only detected by
  // the first statement ("<path>: <what>: file is not a database").
  explicit Db(const std::string& path);
  ~Db();
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;

  const std::string& path() const { return path_; }
  sqlite3* handle() const { return db_; }

  // Runs one or more ';'-separated statements that return no values (schema, BEGIN, PRAGMA x = y).
  void exec(std::string_view sql, const std::string& what = {});
  // How long a statement waits for another connection's lock before failing with "database is locked".
  void busy_timeout(int milliseconds);

  int64_t last_insert_id() const;
  int changes() const;  // rows changed by the last INSERT, UPDATE or DELETE

  // The operation named in error messages when a call gives none (see Transaction).
  const std::string& label() const { return label_; }
  void set_label(std::string label) { label_ = std::move(label); }

  // Throws StoreError "<path>: <what or label>: <SQLite's last error message>".
  [[noreturn]] void fail(const std::string& what = {}) const;
  // Throws StoreError "<path>: <message>" (a store-level error such as "no job 17").
  [[noreturn]] void fail_with(const std::string& message) const;

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
  std::string label_ = "sqlite";
};

// Bytes bound as a BLOB (a TEXT binding would be checked as UTF-8 by readers).
struct Blob {
  std::string bytes;
};

// A prepared statement. Parameters are 1-based (as in SQL "?1"); columns 0-based. Reading a column
// of another type than it holds is an error, except that an integer column reads as a double.
class Statement {
 public:
  Statement(Db& db, std::string_view sql, const std::string& what = {});
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& bind(int index, int64_t value);
  Statement& bind(int index, int value);
  Statement& bind(int index, double value);
  Statement& bind(int index, const std::string& value);
  Statement& bind(int index, const char* value);
  Statement& bind(int index, std::nullptr_t);
  Statement& bind(int index, std::optional<double> value);  // nullopt binds NULL
  Statement& bind(int index, std::optional<int64_t> value);  // nullopt binds NULL
  Statement& bind(int index, const Blob& value);
  // Binds the arguments to parameters 1, 2, ... in order.
  template <typename... Args>
  Statement& bind_all(const Args&... args) {
    int index = 0;
    (bind(++index, args), ...);
    return *this;
  }

  // Runs to the next row: true when a row is available, false when the statement is done.
  bool step();
  // Steps a statement that must return no row (INSERT, UPDATE, ...).
  void run();
  // Back to before the first step, bindings cleared, so that the statement can run again.
  void reset();

  int columns() const;
  bool is_null(int column) const;
  int64_t column_int64(int column) const;
  int column_int(int column) const;  // throws when the value does not fit an int
  double column_double(int column) const;
  std::string column_text(int column) const;
  std::optional<double> column_optional_double(int column) const;  // NULL reads nullopt
  std::optional<int64_t> column_optional_int64(int column) const;  // NULL reads nullopt
  std::string column_blob(int column) const;  // the bytes of a BLOB column (empty for a zero-length one)

 private:
  void check_bind(int rc, int index);
  void check_type(int column, int expected) const;
  Db& db_;
  std::string what_;
  sqlite3_stmt* stmt_ = nullptr;
};

// BEGIN (deferred: the first write takes the write lock, a read-only transaction never waits) or
// BEGIN IMMEDIATE (takes the write lock now, waiting up to the busy timeout, so that a transaction
// that reads then writes can never be overtaken by another writer). commit() ends it; a guard
// destroyed before commit() rolls back. While open, the transaction's label names the operation in
// the connection's error messages.
class Transaction {
 public:
  enum class Mode { deferred, immediate };
  Transaction(Db& db, Mode mode, std::string label);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;

  void commit();

 private:
  Db& db_;
  std::string previous_label_;
  bool open_ = false;
};

}  // namespace pd::sqlite

// ---------------------------------------------------------------------------------------------------
// Parts of the task store kept here so that store/task_store.cpp stays short: its schema, its row
// readers and fail_task's dependency walk. Not for other users.
namespace pd::task_store_detail {

// The SQL that creates a new store's tables and indexes (schema version kTaskStoreSchemaVersion).
extern const char* const kSchema;
// Upgrades a version-2 store to version 3 (the stitch columns and guide_frames).
extern const char* const kUpgrade2To3;

// Row readers: a SELECT lists these columns (in this order) and the reader turns its current row into
// the header's row type. A stored name this program does not know, or damaged scene_files JSON, throws
// StoreError naming the row ("farm.sqlite: task 4: unknown task state 'x' ...").
extern const char* const kJobColumns;     // FROM jobs
extern const char* const kTaskColumns;    // FROM tasks t (with the task's open attempt)
extern const char* const kWorkerColumns;  // FROM workers
JobRow job_from(const sqlite::Db& db, const sqlite::Statement& st);
TaskRow task_from(const sqlite::Db& db, const sqlite::Statement& st);
WorkerRow worker_from(const sqlite::Statement& st);
protocol::JobState job_state_from(const sqlite::Db& db, const std::string& name, int64_t job);
// The jobs.scene_files text; StoreError for a file content that JSON cannot hold (not UTF-8).
std::string files_to_json(const sqlite::Db& db, const std::vector<protocol::SceneFile>& files);

// A task as fail_task's dependency walk sees it.
struct GraphTask {
  int64_t id = 0;
  protocol::TaskKind kind = protocol::TaskKind::level;
  int level = 0, first = 0, last = 0;
  protocol::TaskState state = protocol::TaskState::waiting;
  bool stitch = false;  // a seam's stitch task: also needs the guide frames of the later subset at `first`
};

// Whether t2 needs frames (or the hierarchy) that t1 produces; both of the same job.
bool depends_on(const GraphTask& t2, const GraphTask& t1);
// Indices of the tasks that need a frame of tasks[failed] directly or through other tasks that are
// not done; done tasks are neither included nor walked through (their frames are stored). In the
// order the walk reaches them.
std::vector<size_t> dependents(const std::vector<GraphTask>& tasks, size_t failed);
// The reason a dependent of `failed` is blocked with.
std::string block_reason(const GraphTask& failed, const std::string& reason);

}  // namespace pd::task_store_detail
