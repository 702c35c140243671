#pragma once
// The scheduler's Slurm workers (farm/slurm.h), in the farm's SQLite file beside the task store's
// tables, so that a restarted scheduler still knows which Slurm jobs it started, which are still
// queued or running, and its keep target:
//   slurm_workers(id, array_job, state, reason, worker, draining, replacement, external, submitted, ended)
//   slurm_pool(id = 1, keep, request)
// Created when missing (CREATE TABLE IF NOT EXISTS): a task store of schema version 2 gains them
// without a version change, and a program without Slurm support ignores them. Open it after the
// TaskStore of the same file (which creates and checks the file). Times are Unix seconds.
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace pd {

struct SlurmWorkerRow {
  std::string id;         // "<array job>_<task>"
  std::string array_job;  // "<array job>"
  std::string state;      // Slurm's state, "SUBMITTED" before the first poll, "GONE" once unlisted
  std::string reason;
  std::string worker;     // the pd-worker name it became ("" until its hello)
  bool draining = false;
  bool replacement = false;
  bool external = false;  // not submitted by this scheduler (sbatch by hand): known from its hello only
  double submitted = 0.0;
  std::optional<double> ended;  // set when the state became an end (farm/slurm.h slurm_state_active)
};

class SlurmStore {
 public:
  explicit SlurmStore(const std::string& path);  // StoreError when it cannot be opened
  ~SlurmStore();
  SlurmStore(const SlurmStore&) = delete;
  SlurmStore& operator=(const SlurmStore&) = delete;

  // The array tasks of one sbatch call, state SUBMITTED.
  void add_submitted(const std::string& array_job, const std::vector<std::string>& tasks, bool replacement,
                     double now);
  // A worker said hello as Slurm job `id`: its name is recorded (a job submitted by hand, not by this
  // scheduler, gets a row of its own, RUNNING and external) and its state becomes RUNNING when it was
  // pending.
  void link_worker(const std::string& id, const std::string& worker, double now);
  // A new state from squeue (or GONE); `ended` is set the first time the state is an end.
  void set_state(const std::string& id, const std::string& state, const std::string& reason, double now);
  void set_draining(const std::string& id, bool draining);

  std::optional<SlurmWorkerRow> find(const std::string& id) const;
  std::vector<SlurmWorkerRow> rows() const;    // newest first (by submission, then id)
  std::vector<SlurmWorkerRow> active() const;  // not ended, oldest first
  // The row whose worker is `name`, if any.
  std::optional<SlurmWorkerRow> by_worker(const std::string& name) const;
  // Rows ended before `time` are deleted (pd workers shows recent ends only).
  void forget_ended_before(double time);

  int keep() const;
  void set_keep(int keep);
  // The sbatch settings replacements are submitted with (the last AddSlurmWorkers that set a keep
  // target, as JSON text; "" when none).
  std::string keep_request() const;
  void set_keep_request(const std::string& json);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pd
