#include "scheduler/slurm_pool.h"

#include <algorithm>
#include <cstdio>
#include <set>
#include <filesystem>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "farm/curve.h"
#include "farm/slurm.h"
#include "util/input_error.h"
#include "util/subprocess.h"

namespace pd::scheduler {

namespace {

std::string joined(const std::vector<std::string>& ids) {
  std::string s;
  for (const std::string& id : ids) s += (s.empty() ? "" : " ") + id;
  return s;
}

std::string seconds_text(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3f s", seconds);
  return text;
}

std::string absolute(const std::string& path) { return std::filesystem::absolute(path).lexically_normal().string(); }

}  // namespace

void complete_slurm_options(SlurmOptions& slurm, const std::string& farm_dir, const std::string& workers_endpoint,
                            const std::string& own_executable, bool curve) {
  if (slurm.script.empty()) {
    const std::pair<const char*, bool> given[] = {{"--slurm-worker", !slurm.worker_binary.empty()},
                                                  {"--slurm-connect", !slurm.connect.empty()},
                                                  {"--slurm-server-key", !slurm.server_key_file.empty()},
                                                  {"--slurm-worker-key", !slurm.worker_key_file.empty()},
                                                  {"--slurm-log-dir", !slurm.log_dir.empty()}};
    for (const auto& [option, is_given] : given)
      if (is_given) throw InputError(std::string(option) + ": needs --slurm-script (without it no Slurm worker starts)");
    return;
  }
  slurm.script = absolute(slurm.script);
  if (slurm.worker_binary.empty()) {
    std::error_code ec;
    const std::filesystem::path self = std::filesystem::canonical(own_executable, ec);
    slurm.worker_binary = (ec ? std::filesystem::path(own_executable) : self).parent_path() / "pd-worker";
  }
  slurm.worker_binary = absolute(slurm.worker_binary);
  if (access(slurm.worker_binary.c_str(), X_OK) != 0)
    throw InputError("--slurm-worker: '" + slurm.worker_binary + "' is not an executable file");
  slurm.log_dir = absolute(slurm.log_dir.empty() ? farm_dir + "/slurm" : slurm.log_dir);
  if (slurm.log_dir.find('%') != std::string::npos)
    throw InputError("--slurm-log-dir: '" + slurm.log_dir + "' holds '%', which sbatch reads as a pattern");
  if (slurm.job_name.empty() || slurm.job_name.size() > 64 ||
      slurm.job_name.find_first_of("%| \t\n") != std::string::npos)
    throw InputError("--slurm-job-name: expected 1 to 64 characters without '%', '|' or spaces");
  if (slurm.connect.empty()) {
    if (workers_endpoint.find("://*") != std::string::npos || workers_endpoint.find("0.0.0.0") != std::string::npos)
      throw InputError("--slurm-connect: needed when --workers-endpoint is a wildcard (" + workers_endpoint +
                       "): the address compute nodes reach this scheduler at");
  }
  if (curve) {
    if (slurm.server_key_file.empty() || slurm.worker_key_file.empty())
      throw InputError("--slurm-server-key and --slurm-worker-key: needed with --key, so that Slurm workers get in");
    farm::read_public_key(slurm.server_key_file);  // InputError naming the file when it is bad
    farm::read_key_pair(slurm.worker_key_file);
    slurm.server_key_file = absolute(slurm.server_key_file);
    slurm.worker_key_file = absolute(slurm.worker_key_file);
  } else if (!slurm.server_key_file.empty() || !slurm.worker_key_file.empty()) {
    throw InputError("--slurm-server-key/--slurm-worker-key: only with --key (this scheduler uses no CURVE)");
  }
}

SlurmPool::SlurmPool(const SlurmOptions& options, const std::string& store_path, EventSink event)
    : options_(options), store_(store_path), event_(std::move(event)) {
  if (enabled()) std::filesystem::create_directories(options_.log_dir);
}

std::string SlurmPool::submit(const protocol::AddSlurmWorkers& m, bool replacement, double now) {
  farm::SbatchCall call;
  call.script = options_.script;
  call.job_name = options_.job_name;
  call.log_dir = options_.log_dir;
  call.request = m;
  call.worker_command = {options_.worker_binary, "--connect", options_.connect, "--scheduler-timeout",
                         std::to_string(options_.scheduler_timeout_s)};
  if (!options_.worker_key_file.empty())
    call.worker_command.insert(call.worker_command.end(),
                               {"--server-key", options_.server_key_file, "--key", options_.worker_key_file});
  const std::vector<std::string> argv = farm::sbatch_argv(call);
  const CommandResult r = slurm_command(argv);
  if (!r.failure.empty()) throw InputError(r.failure);
  const std::string job = farm::parse_sbatch_job_id(r.out);
  const std::vector<std::string> tasks = farm::array_task_ids(job, m.count);
  store_.add_submitted(job, tasks, replacement, now);
  event_("slurm_submitted", "job array " + job + ": " + std::to_string(m.count) + " worker(s)" +
                                (replacement ? " (replacement for the keep target)" : "") + ", sbatch took " +
                                seconds_text(r.seconds));
  poll_soon();
  return job;
}

CommandResult SlurmPool::slurm_command(const std::vector<std::string>& argv) {
  CommandResult r = run_command(argv, kSlurmCommandTimeout);
  if (!r.failure.empty()) event_("slurm_error", r.failure + " (" + seconds_text(r.seconds) + ")");
  return r;
}

protocol::SlurmAccepted SlurmPool::add(const protocol::AddSlurmWorkers& m, double now) {
  if (!enabled())
    throw InputError("this scheduler was started without --slurm-script: it cannot start Slurm workers");
  farm::check_slurm_request(m);
  protocol::SlurmAccepted a;
  a.slurm_job = submit(m, false, now);
  a.tasks = farm::array_task_ids(a.slurm_job, m.count);
  if (m.keep >= 0) {
    store_.set_keep(m.keep);
    const nlohmann::json settings = {
        {"partition", m.partition}, {"time_limit", m.time_limit}, {"cpus", m.cpus}, {"memory", m.memory}};
    store_.set_keep_request(settings.dump());
    quick_deaths_ = 0;
    event_("slurm_keep", "keep target " + std::to_string(m.keep));
  }
  a.message = std::to_string(m.count) + " Slurm worker(s) submitted as job array " + a.slurm_job +
              (m.keep >= 0 ? ", keep target " + std::to_string(m.keep) : "");
  return a;
}

// Only Slurm jobs this scheduler submitted (rows not `external`) are ever cancelled: a worker's hello
// only claims a Slurm job id, and any peer of the workers socket can claim any id (a hello naming
// 987654321_7 followed by this request made a scheduler started without Slurm run scancel on it).
protocol::SlurmAccepted SlurmPool::remove(const protocol::RemoveSlurmWorkers& m, const Busy& busy, double now) {
  if (!enabled())
    throw InputError("this scheduler was started without --slurm-script: it has no Slurm workers to remove");
  if (!farm::valid_slurm_job_id(m.slurm_job))
    throw InputError("--slurm: expected a Slurm job id (123) or array task id (123_4), got '" +
                     m.slurm_job.substr(0, 40) + "'");
  const bool whole_array = m.slurm_job.find('_') == std::string::npos;
  std::vector<std::string> cancel_now, later;
  int claimed = 0;  // matching rows known only from a worker's hello
  for (const SlurmWorkerRow& r : store_.active()) {
    if (r.id != m.slurm_job && !(whole_array && r.array_job == m.slurm_job)) continue;
    if (r.external) {
      ++claimed;
      continue;
    }
    if (r.draining && !m.now) continue;  // already being drained
    store_.set_draining(r.id, true);
    (m.now || r.worker.empty() || !busy(r.worker) ? cancel_now : later).push_back(r.id);
  }
  if (cancel_now.empty() && later.empty() && claimed > 0)
    throw InputError("Slurm job " + m.slurm_job +
                     " was not submitted by this scheduler (a worker only named it when it connected): it "
                     "cancels only the Slurm workers it started; cancel that job with scancel yourself");
  if (cancel_now.empty() && later.empty())
    throw InputError("no queued or running Slurm worker " + m.slurm_job + " (pd workers lists them)");
  if (!cancel_now.empty()) scancel(cancel_now, "pd workers remove");
  const int removed = static_cast<int>(cancel_now.size() + later.size());
  const int keep = std::max(0, store_.keep() - removed);
  if (keep != store_.keep()) store_.set_keep(keep);
  protocol::SlurmAccepted a;
  a.slurm_job = m.slurm_job;
  a.tasks = cancel_now;
  a.tasks.insert(a.tasks.end(), later.begin(), later.end());
  a.message = std::to_string(cancel_now.size()) + " cancelled" +
              (later.empty() ? "" : ", " + std::to_string(later.size()) + " draining (cancelled when their task ends)") +
              ", keep target " + std::to_string(keep);
  for (const std::string& id : cancel_now) store_.set_state(id, "CANCELLING", "pd workers remove", now);
  event_("slurm_remove", m.slurm_job + ": " + a.message);
  return a;
}

void SlurmPool::scancel(const std::vector<std::string>& ids, const std::string& why) {
  if (ids.empty()) return;
  std::vector<std::string> argv = {"scancel"};
  argv.insert(argv.end(), ids.begin(), ids.end());
  const CommandResult r = slurm_command(argv);
  if (r.failure.empty())
    event_("slurm_cancelled", joined(ids) + ": " + why + " (scancel took " + seconds_text(r.seconds) + ")");
  poll_soon();
}

void SlurmPool::worker_joined(const std::string& id, const std::string& name, double now) {
  store_.link_worker(id, name, now);
  const std::optional<SlurmWorkerRow> row = store_.find(id);
  if (row && row->replacement) quick_deaths_ = 0;  // a replacement that became a worker: Slurm works
}

void SlurmPool::worker_lost(const std::string& name, double now) {
  const std::optional<SlurmWorkerRow> row = store_.by_worker(name);
  if (!row || row->ended) return;
  if (row->external) store_.set_state(row->id, "ENDED", "its worker was lost (not submitted here: not polled)", now);
  else poll_soon();  // show how its Slurm job ended (scancel, time limit)
}

bool SlurmPool::draining(const std::string& name) const {
  const std::optional<SlurmWorkerRow> row = store_.by_worker(name);
  return row && row->draining && !row->ended;
}

void SlurmPool::cancel_drained(const std::string& name, double now) {
  const std::optional<SlurmWorkerRow> row = store_.by_worker(name);
  if (row && row->draining && !row->ended) {
    store_.set_state(row->id, "CANCELLING", "drained", now);
    scancel({row->id}, "drained: its task ended");
  }
}

void SlurmPool::tick(double now, const std::function<bool()>& work_remains, const Busy& busy) {
  if (now < next_poll_) return;
  next_poll_ = now + options_.poll_seconds;
  if (enabled()) poll(now);
  // Draining workers that are idle (their task ended between polls, or they never got one).
  std::vector<std::string> idle;
  for (const SlurmWorkerRow& r : store_.active())
    if (r.draining && (r.worker.empty() || !busy(r.worker))) idle.push_back(r.id);
  for (const std::string& id : idle) store_.set_state(id, "CANCELLING", "drained", now);
  scancel(idle, "drained");
  if (enabled() && store_.keep() > 0) keep_target(now, work_remains());
  store_.forget_ended_before(now - kForgetEndedSeconds);
}

// squeue lists this farm's jobs (by job name) in every state Slurm still remembers; an active row
// it no longer lists has ended without our seeing how (it left Slurm's memory): GONE.
void SlurmPool::poll(double now) {
  const CommandResult r = slurm_command(farm::squeue_argv(options_.job_name));
  if (!r.failure.empty()) return;  // states stay as they were; the next poll tries again
  std::set<std::string> listed;
  for (const farm::SlurmJobState& j : farm::parse_squeue(r.out)) {
    listed.insert(j.id);
    const std::optional<SlurmWorkerRow> row = store_.find(j.id);
    if (!row || (row->state == j.state && row->reason == j.reason)) continue;
    if (row->state == "CANCELLING" && farm::slurm_state_active(j.state)) continue;  // scancel not through yet
    store_.set_state(j.id, j.state, j.reason, now);
    event_("slurm_state", j.id + ": " + row->state + " -> " + j.state + (j.reason == "None" ? "" : " (" + j.reason + ")"));
    if (row->replacement && row->worker.empty() && !farm::slurm_state_active(j.state) &&
        now - row->submitted < kQuickDeathSeconds)
      ++quick_deaths_;
  }
  for (const SlurmWorkerRow& row : store_.active()) {
    if (row.external || listed.count(row.id) || now - row.submitted < 2.0 * options_.poll_seconds) continue;
    store_.set_state(row.id, "GONE", "no longer listed by squeue", now);
    event_("slurm_state", row.id + ": " + row.state + " -> GONE (no longer listed by squeue)");
  }
}

void SlurmPool::keep_target(double now, bool work_remains) {
  const int keep = store_.keep();
  if (keep <= 0 || !work_remains) return;
  if (quick_deaths_ >= kMaxQuickDeaths) {
    store_.set_keep(0);
    event_("slurm_keep_suspended", std::to_string(quick_deaths_) + " replacements in a row ended within " +
                                       std::to_string(static_cast<int>(kQuickDeathSeconds)) +
                                       " s without becoming workers: keep target set to 0 (see their logs in " +
                                       options_.log_dir + ")");
    quick_deaths_ = 0;
    return;
  }
  int active = 0;
  for (const SlurmWorkerRow& r : store_.active())
    if (!r.draining && !r.external) ++active;
  if (active >= keep) return;
  protocol::AddSlurmWorkers m;
  m.count = keep - active;
  try {
    // The settings of the request that set the target (stored by add(); written by this program).
    const nlohmann::json settings = nlohmann::json::parse(store_.keep_request());
    m.partition = settings.at("partition").get<std::string>();
    m.time_limit = settings.at("time_limit").get<std::string>();
    m.cpus = settings.at("cpus").get<int>();
    m.memory = settings.at("memory").get<std::string>();
  } catch (const nlohmann::json::exception& e) {
    event_("slurm_error", std::string("keep target: stored sbatch settings unreadable, using the script's: ") + e.what());
  }
  try {
    submit(m, true, now);
  } catch (const InputError&) {
    // logged by submit; tried again at the next poll
  }
}

void SlurmPool::fill(protocol::WorkersReply& reply, double now) const {
  for (const SlurmWorkerRow& r : store_.rows()) {
    protocol::SlurmWorkerStatus s;
    s.slurm_job = r.id;
    s.state = r.state;
    s.worker = r.worker;
    s.draining = r.draining;
    s.replacement = r.replacement;
    s.submitted_seconds_ago = std::max(0.0, now - r.submitted);
    s.reason = r.reason;
    reply.slurm.push_back(s);
  }
  reply.slurm_keep = store_.keep();
}

}  // namespace pd::scheduler
