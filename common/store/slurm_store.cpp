#include "store/slurm_store.h"

#include "farm/slurm.h"
#include "store/sqlite_db.h"

namespace pd {

namespace {

constexpr const char* kSlurmSchema = R"sql(
CREATE TABLE IF NOT EXISTS slurm_workers(
  id TEXT PRIMARY KEY,
  array_job TEXT NOT NULL,
  state TEXT NOT NULL,
  reason TEXT NOT NULL DEFAULT '',
  worker TEXT NOT NULL DEFAULT '',
  draining INTEGER NOT NULL DEFAULT 0,
  replacement INTEGER NOT NULL DEFAULT 0,
  external INTEGER NOT NULL DEFAULT 0,
  submitted REAL NOT NULL,
  ended REAL);
CREATE TABLE IF NOT EXISTS slurm_pool(id INTEGER PRIMARY KEY CHECK (id = 1), keep INTEGER NOT NULL,
  request TEXT NOT NULL DEFAULT '');
INSERT OR IGNORE INTO slurm_pool(id, keep) VALUES (1, 0);
)sql";

constexpr const char* kColumns =
    "id, array_job, state, reason, worker, draining, replacement, external, submitted, ended";

SlurmWorkerRow row_from(const sqlite::Statement& st) {
  SlurmWorkerRow r;
  r.id = st.column_text(0);
  r.array_job = st.column_text(1);
  r.state = st.column_text(2);
  r.reason = st.column_text(3);
  r.worker = st.column_text(4);
  r.draining = st.column_int(5) != 0;
  r.replacement = st.column_int(6) != 0;
  r.external = st.column_int(7) != 0;
  r.submitted = st.column_double(8);
  r.ended = st.column_optional_double(9);
  return r;
}

std::vector<SlurmWorkerRow> all_rows(sqlite::Statement& st) {
  std::vector<SlurmWorkerRow> rows;
  while (st.step()) rows.push_back(row_from(st));
  return rows;
}

}  // namespace

struct SlurmStore::Impl {
  explicit Impl(const std::string& path) : db(path) {}
  sqlite::Db db;
};

SlurmStore::SlurmStore(const std::string& path) : impl_(std::make_unique<Impl>(path)) {
  impl_->db.busy_timeout(5000);
  sqlite::Transaction t(impl_->db, sqlite::Transaction::Mode::immediate, "slurm schema");
  impl_->db.exec(kSlurmSchema);
  t.commit();
}

SlurmStore::~SlurmStore() = default;

void SlurmStore::add_submitted(const std::string& array_job, const std::vector<std::string>& tasks, bool replacement,
                               double now) {
  sqlite::Transaction t(impl_->db, sqlite::Transaction::Mode::immediate, "slurm add_submitted");
  sqlite::Statement st(impl_->db,
                       "INSERT INTO slurm_workers(id, array_job, state, replacement, submitted) VALUES (?1, ?2, "
                       "'SUBMITTED', ?3, ?4)");
  for (const std::string& id : tasks) {
    st.bind_all(id, array_job, replacement ? 1 : 0, now).run();
    st.reset();
  }
  t.commit();
}

void SlurmStore::link_worker(const std::string& id, const std::string& worker, double now) {
  const std::string array_job = id.substr(0, id.find('_'));
  sqlite::Statement(impl_->db,
                    "INSERT INTO slurm_workers(id, array_job, state, external, submitted) VALUES (?1, ?2, 'RUNNING', 1, ?3) "
                    "ON CONFLICT(id) DO NOTHING",
                    "slurm link_worker")
      .bind_all(id, array_job, now)
      .run();
  sqlite::Statement(impl_->db,
                    "UPDATE slurm_workers SET worker = ?2, state = CASE WHEN state IN ('SUBMITTED', 'PENDING', "
                    "'CONFIGURING') THEN 'RUNNING' ELSE state END WHERE id = ?1",
                    "slurm link_worker")
      .bind_all(id, worker)
      .run();
}

void SlurmStore::set_state(const std::string& id, const std::string& state, const std::string& reason, double now) {
  sqlite::Statement st(impl_->db,
                       "UPDATE slurm_workers SET state = ?2, reason = ?3, ended = CASE WHEN ?4 THEN NULL ELSE "
                       "COALESCE(ended, ?5) END WHERE id = ?1",
                       "slurm set_state");
  st.bind_all(id, state, reason, farm::slurm_state_active(state) ? 1 : 0, now).run();
}

void SlurmStore::set_draining(const std::string& id, bool draining) {
  sqlite::Statement(impl_->db, "UPDATE slurm_workers SET draining = ?2 WHERE id = ?1", "slurm set_draining")
      .bind_all(id, draining ? 1 : 0)
      .run();
}

std::optional<SlurmWorkerRow> SlurmStore::find(const std::string& id) const {
  sqlite::Statement st(impl_->db, std::string("SELECT ") + kColumns + " FROM slurm_workers WHERE id = ?1",
                       "slurm find");
  st.bind(1, id);
  if (!st.step()) return std::nullopt;
  return row_from(st);
}

std::vector<SlurmWorkerRow> SlurmStore::rows() const {
  sqlite::Statement st(impl_->db,
                       std::string("SELECT ") + kColumns + " FROM slurm_workers ORDER BY submitted DESC, id DESC",
                       "slurm rows");
  return all_rows(st);
}

std::vector<SlurmWorkerRow> SlurmStore::active() const {
  sqlite::Statement st(impl_->db,
                       std::string("SELECT ") + kColumns +
                           " FROM slurm_workers WHERE ended IS NULL ORDER BY submitted, id",
                       "slurm active");
  return all_rows(st);
}

std::optional<SlurmWorkerRow> SlurmStore::by_worker(const std::string& name) const {
  if (name.empty()) return std::nullopt;
  sqlite::Statement st(impl_->db,
                       std::string("SELECT ") + kColumns + " FROM slurm_workers WHERE worker = ?1 ORDER BY "
                       "submitted DESC LIMIT 1",
                       "slurm by_worker");
  st.bind(1, name);
  if (!st.step()) return std::nullopt;
  return row_from(st);
}

void SlurmStore::forget_ended_before(double time) {
  sqlite::Statement(impl_->db, "DELETE FROM slurm_workers WHERE ended IS NOT NULL AND ended < ?1",
                    "slurm forget_ended_before")
      .bind(1, time)
      .run();
}

int SlurmStore::keep() const {
  sqlite::Statement st(impl_->db, "SELECT keep FROM slurm_pool WHERE id = 1", "slurm keep");
  return st.step() ? st.column_int(0) : 0;
}

void SlurmStore::set_keep(int keep) {
  sqlite::Statement(impl_->db, "UPDATE slurm_pool SET keep = ?1 WHERE id = 1", "slurm set_keep").bind(1, keep).run();
}

std::string SlurmStore::keep_request() const {
  sqlite::Statement st(impl_->db, "SELECT request FROM slurm_pool WHERE id = 1", "slurm keep_request");
  return st.step() ? st.column_text(0) : "";
}

void SlurmStore::set_keep_request(const std::string& json) {
  sqlite::Statement(impl_->db, "UPDATE slurm_pool SET request = ?1 WHERE id = 1", "slurm set_keep_request")
      .bind(1, json)
      .run();
}

}  // namespace pd
