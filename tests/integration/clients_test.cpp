// Two clients at once (issue test 7): two threads run real `pd` processes against one farm of two
// workers for a minute, submitting small jobs, cancelling their own and each other's (queued, running
// or already done) and listing the jobs. Checked: no command's output mentions a busy database, every
// command exits 0 or with a documented refusal, and once everything has ended each job's final state
// matches what the clients were told (an accepted cancel ends cancelled, a refused "already done"
// stays done, an uncancelled job is done with every frame stored) and the scheduler's log (one
// job_cancelled or one job_done, never both, nothing stored after a cancel).
//
// The threads only record (gtest assertions stay on the main thread); every command is bounded by
// kCommandBound, the waits by kEndBound.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "support/farm.h"
#include "support/process.h"

namespace pd {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using test::Args;
using test::Farm;
using test::FarmTest;
using Clock = std::chrono::steady_clock;

constexpr auto kClientTime = 60s;     // how long each client keeps issuing commands
constexpr auto kCommandBound = 20s;   // one pd command; measured 0.03-0.4 s on an idle farm
constexpr auto kEndBound = 60s;       // after the minute, until every job has ended
constexpr int kMaxUnfinished = 8;     // jobs not yet seen ended: past this a client stops submitting
constexpr unsigned kBaseSeed = 20240607;  // client k uses kBaseSeed + k; PD_CLIENTS_SEED replaces it

bool finished(const std::string& state) { return state == "done" || state == "cancelled" || state == "failed"; }

struct CancelTry {
  int client = 0;
  double start = 0.0, end = 0.0;  // s since the clients started
  int exit_code = -1;
  bool accepted = false;
  std::string reply;      // stdout when accepted, else the refusal on stderr
  std::string seen;       // the job's state in the latest listing before it ("" when never listed)
};

struct JobRecord {
  int64_t id = 0;
  int owner = 0;  // the client that submitted it
  int frames = 0;
  bool preview_only = false;
  int priority = 0;
  double submitted = 0.0;  // when its submit reply arrived, s
  std::vector<CancelTry> cancels;
};

// A job's state as one listing showed it, between the listing command's start and end (s).
struct Observation {
  int64_t job = 0;
  std::string state;
  double start = 0.0, end = 0.0;
};

// What both clients share: the jobs, what listings showed, and every command's verdict.
class Clients {
 public:
  explicit Clients(const Farm& farm) : farm_(farm), t0_(Clock::now()) {}

  void run_client(int k, unsigned seed, Clock::time_point deadline);

  std::mutex mutex;
  std::map<int64_t, JobRecord> jobs;
  std::vector<Observation> observations;
  std::vector<std::string> problems;  // commands whose output or exit code was not allowed
  int commands = 0, submits = 0, cancels = 0, statuses = 0;
  double slowest = 0.0;
  std::string slowest_command;

 private:
  double now() const { return std::chrono::duration<double>(Clock::now() - t0_).count(); }
  test::RunResult pd(Args args);
  void problem(const std::string& what, const test::RunResult& r);
  // The job id, 0 when it failed. priority: the job's, or none for one drawn from -1..2.
  int64_t submit(int k, std::mt19937& rng, std::optional<int> priority = std::nullopt);
  void cancel(int k, int64_t job);
  void status(int64_t job);
  int64_t pick_target(std::mt19937& rng);
  int unfinished();

  const Farm& farm_;
  const Clock::time_point t0_;
  std::map<int64_t, std::string> last_seen_;  // the latest listing's state of each job
};

// A pd command, bounded; its time counted and its output searched for a busy database.
test::RunResult Clients::pd(Args args) {
  const test::RunResult r = farm_.pd(std::move(args), kCommandBound);
  std::string text = r.out + r.err;
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  std::lock_guard<std::mutex> lock(mutex);
  ++commands;
  if (r.seconds > slowest) {
    slowest = r.seconds;
    slowest_command = r.command;
  }
  for (const char* word : {"sqlite_busy", "database is locked", "busy"})
    if (text.find(word) != std::string::npos)
      problems.push_back(std::string("mentions '") + word + "': " + r.describe());
  return r;
}

void Clients::problem(const std::string& what, const test::RunResult& r) {
  std::lock_guard<std::mutex> lock(mutex);
  problems.push_back(what + ": " + r.describe());
}

int Clients::unfinished() {
  int n = 0;
  for (const auto& [id, job] : jobs) {
    const auto seen = last_seen_.find(id);
    const bool cancelled =
        std::any_of(job.cancels.begin(), job.cancels.end(), [](const CancelTry& c) { return c.accepted; });
    n += !cancelled && (seen == last_seen_.end() || !finished(seen->second));
  }
  return n;
}

int64_t Clients::submit(int k, std::mt19937& rng, std::optional<int> priority) {
  JobRecord job;
  job.owner = k;
  // Mostly previews of 3..8 frames (0.1-0.7 s on a worker); one in four the scene's 3 levels over
  // 4 frames (1.1 s). --levels 2 is refused by this scene (its vertex_counts name 3 levels).
  job.preview_only = std::uniform_int_distribution<int>(0, 3)(rng) != 0;
  job.frames = job.preview_only ? std::uniform_int_distribution<int>(3, 8)(rng) : 4;
  job.priority = std::uniform_int_distribution<int>(-1, 2)(rng);
  if (priority) job.priority = *priority;
  Args args = {"submit", test::scene_path("cube-trampoline.json"), "--frames", std::to_string(job.frames),
               "--priority", std::to_string(job.priority), "--json"};
  if (job.preview_only) args.push_back("--preview-only");
  const test::RunResult r = pd(args);
  try {
    if (r.exit_code != 0) throw std::runtime_error("exit code");
    job.id = test::parse_json(r).at("job").get<int64_t>();
  } catch (const std::exception& e) {
    problem(std::string("submit: ") + e.what(), r);
    return 0;
  }
  job.submitted = now();
  std::lock_guard<std::mutex> lock(mutex);
  ++submits;
  if (!jobs.emplace(job.id, job).second) problems.push_back("a second submit was given job " + std::to_string(job.id));
  return job.id;
}

// A job to cancel, 0 when there is none: one the latest listing showed running, done or queued, or
// any (both clients' jobs alike).
int64_t Clients::pick_target(std::mt19937& rng) {
  std::lock_guard<std::mutex> lock(mutex);
  if (jobs.empty()) return 0;
  std::map<std::string, std::vector<int64_t>> by_state;
  for (const auto& [id, job] : jobs) {
    const auto seen = last_seen_.find(id);
    by_state[seen == last_seen_.end() ? "" : seen->second].push_back(id);
    by_state["any"].push_back(id);
  }
  const std::vector<std::string> wanted = {"running", "done", "queued", "any"};
  const std::string& kind = wanted[std::uniform_int_distribution<std::size_t>(0, wanted.size() - 1)(rng)];
  const std::vector<int64_t>& pool = by_state[kind].empty() ? by_state["any"] : by_state[kind];
  return pool[std::uniform_int_distribution<std::size_t>(0, pool.size() - 1)(rng)];
}

void Clients::cancel(int k, int64_t job) {
  CancelTry c;
  c.client = k;
  {
    std::lock_guard<std::mutex> lock(mutex);
    const auto seen = last_seen_.find(job);
    c.seen = seen == last_seen_.end() ? "" : seen->second;
  }
  c.start = now();
  const test::RunResult r = pd({"cancel", std::to_string(job), "--json"});
  c.end = now();
  c.exit_code = r.exit_code;
  const std::string prefix = "pd: error: job " + std::to_string(job) + " is already ";
  bool allowed = false;
  if (r.exit_code == 0) {
    c.accepted = true;
    c.reply = r.out;
    try {
      allowed = test::parse_json(r).at("job").get<int64_t>() == job;
    } catch (const std::exception&) {
    }
  } else if (r.exit_code == 2) {
    c.reply = r.err;
    for (const char* state : {"done\n", "cancelled\n", "failed\n"}) allowed = allowed || r.err == prefix + state;
  }
  if (!allowed) problem("cancel: neither accepted for this job nor refused as already finished", r);
  while (!c.reply.empty() && c.reply.back() == '\n') c.reply.pop_back();
  std::lock_guard<std::mutex> lock(mutex);
  ++cancels;
  jobs.at(job).cancels.push_back(c);
}

// `pd status [JOB] --json`: every job whose submit had returned before it must be listed, once.
void Clients::status(int64_t job) {
  std::set<int64_t> known;
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (const auto& [id, record] : jobs) known.insert(id);
  }
  if (job != 0) known = {job};
  const double start = now();
  Args args = {"status", "--json"};
  if (job != 0) args.insert(args.begin() + 1, std::to_string(job));
  const test::RunResult r = pd(args);
  const double end = now();
  std::map<int64_t, std::string> listed;
  try {
    if (r.exit_code != 0) throw std::runtime_error("exit code");
    const json reply = test::parse_json(r);  // named: a range-for over a temporary's member would dangle
    for (const json& j : reply.at("jobs"))
      if (!listed.emplace(j.at("id").get<int64_t>(), j.at("state").get<std::string>()).second)
        throw std::runtime_error("job " + j.at("id").dump() + " listed twice");
    for (const int64_t id : known)
      if (!listed.count(id)) throw std::runtime_error("job " + std::to_string(id) + " submitted before, not listed");
    if (job != 0 && listed.size() != 1)
      throw std::runtime_error("asked for one job, got " + std::to_string(listed.size()));
  } catch (const std::exception& e) {
    problem(std::string("status: ") + e.what(), r);
    return;
  }
  std::lock_guard<std::mutex> lock(mutex);
  ++statuses;
  for (const auto& [id, state] : listed) {
    last_seen_[id] = state;
    observations.push_back({id, state, start, end});
  }
}

// One client: until `deadline`, a random command every 0-300 ms. A third of the submits is followed
// at once by a cancel of that job (queued still, or its hierarchy task just assigned).
void Clients::run_client(int k, unsigned seed, Clock::time_point deadline) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  while (Clock::now() < deadline) {
    const double x = u(rng);
    int backlog;
    {
      std::lock_guard<std::mutex> lock(mutex);
      backlog = unfinished();
    }
    if (x < 0.04 && backlog + 3 <= kMaxUnfinished) {
      // A cancel that finds its job queued, whatever the workers' speed: two jobs of the highest
      // priority for the two workers, then one of the lowest, cancelled at once. Claims go by
      // priority, so it waits at least until one of the two has run (0.1-1.1 s), while the cancel
      // takes one pd command (0.03-0.4 s). Random cancels alone found none in 3 of 4 runs once
      // the solves got faster.
      submit(k, rng, 2);
      submit(k, rng, 2);
      if (const int64_t job = submit(k, rng, -1)) cancel(k, job);
    } else if (x < 0.4 && backlog < kMaxUnfinished) {
      const int64_t job = submit(k, rng);
      if (job != 0 && u(rng) < 0.33) cancel(k, job);
    } else if (x < 0.75) {
      if (const int64_t job = pick_target(rng)) cancel(k, job);
    } else {
      status(u(rng) < 0.2 ? pick_target(rng) : 0);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(std::uniform_int_distribution<int>(0, 300)(rng)));
  }
}

// The scheduler log's events per job, in log order.
struct JobEvents {
  std::vector<std::pair<std::size_t, std::string>> events;  // (line index, event) but frame_stored
  int count(const std::string& kind) const {
    return static_cast<int>(
        std::count_if(events.begin(), events.end(), [&](const auto& e) { return e.second == kind; }));
  }
  std::size_t first(const std::string& kind) const {
    for (const auto& e : events)
      if (e.second == kind) return e.first;
    return SIZE_MAX;
  }
  int frames_after_cancel = 0;  // frame_stored lines after job_cancelled
};

std::map<int64_t, JobEvents> job_events(const std::string& log_path) {
  std::map<int64_t, JobEvents> out;
  std::map<int64_t, std::size_t> cancelled_at;
  std::ifstream in(log_path);
  std::string line;
  for (std::size_t i = 0; std::getline(in, line); ++i) {
    if (line.empty() || line[0] != '{') continue;
    json j;
    try {
      j = json::parse(line);
    } catch (const json::exception&) {
      continue;  // the last line, while the scheduler is still writing it
    }
    if (!j.contains("job")) continue;
    const int64_t job = j.at("job").get<int64_t>();
    const std::string kind = j.at("event").get<std::string>();
    if (kind == "job_cancelled") cancelled_at.emplace(job, i);
    if (kind == "frame_stored") {
      if (cancelled_at.count(job)) ++out[job].frames_after_cancel;
      continue;
    }
    out[job].events.emplace_back(i, kind);
  }
  return out;
}

// `pd status --json` every 0.5 s until every job has ended; the final listing (id -> job).
std::map<int64_t, json> wait_until_all_ended(const Farm& farm, std::chrono::milliseconds bound) {
  const auto deadline = Clock::now() + bound;
  for (;;) {
    const test::RunResult r = farm.pd({"status", "--json"});
    if (r.exit_code != 0) throw std::runtime_error("pd status failed: " + r.describe());
    std::map<int64_t, json> jobs;
    bool all = true;
    const json reply = test::parse_json(r);
    for (const json& j : reply.at("jobs")) {
      all = all && finished(j.at("state").get<std::string>());
      jobs[j.at("id").get<int64_t>()] = j;
    }
    if (all) return jobs;
    if (Clock::now() >= deadline) throw std::runtime_error("jobs still unfinished after the bound: " + r.out);
    std::this_thread::sleep_for(500ms);
  }
}

unsigned base_seed() {
  const char* env = std::getenv("PD_CLIENTS_SEED");
  return env != nullptr && *env != '\0' ? static_cast<unsigned>(std::stoul(env)) : kBaseSeed;
}

// What the clients did, as the report prints it.
struct Tally {
  int accepted_queued = 0, accepted_running = 0;  // accepted cancels, by whether a task had been assigned
  int refused_done = 0, refused_cancelled = 0, refused_other = 0;
  int cross_client = 0;  // cancels of the other client's job
  int done = 0, cancelled = 0;
  int checks = 0;  // jobs and observations compared
};

bool refused_as(const CancelTry& c, const std::string& state) {
  const std::string tail = " is already " + state;
  return !c.accepted && c.reply.size() > tail.size() &&
         c.reply.compare(c.reply.size() - tail.size(), tail.size(), tail) == 0;
}

// "job 12 (preview, 5 frames, priority 1) submitted by client 0 at 3.2 s; cancel by client 1 at
// 3.3-3.4 s (listed running): exit 0 ...": what its clients did and were told, for failure messages.
std::string history(const JobRecord& job) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "job %lld (%s, %d frames, priority %d) submitted by client %d at %.3f s",
                static_cast<long long>(job.id), job.preview_only ? "preview" : "3 levels", job.frames, job.priority,
                job.owner, job.submitted);
  std::string s = buf;
  for (const CancelTry& c : job.cancels) {
    std::snprintf(buf, sizeof buf, "; cancel by client %d at %.3f-%.3f s (last listed %s): exit %d, ", c.client,
                  c.start, c.end, c.seen.empty() ? "never" : c.seen.c_str(), c.exit_code);
    s += buf + c.reply;
  }
  return s + ": ";
}

// One job: its final listing and its log events against what its clients were told.
void check_job(const JobRecord& job, const json& final, const JobEvents& ev, Tally& tally) {
  const std::string where = history(job);
  const std::string state = final.at("state").get<std::string>();
  int accepted = 0, refused_done = 0, refused_cancelled = 0;
  for (const CancelTry& c : job.cancels) {
    accepted += c.accepted;
    refused_done += refused_as(c, "done");
    refused_cancelled += refused_as(c, "cancelled");
    tally.cross_client += c.client != job.owner;
  }
  tally.refused_done += refused_done;
  tally.refused_cancelled += refused_cancelled;
  tally.refused_other += static_cast<int>(job.cancels.size()) - accepted - refused_done - refused_cancelled;
  EXPECT_EQ(ev.count("job_submitted"), 1) << where;
  EXPECT_EQ(ev.count("job_failed"), 0) << where << final.dump();
  EXPECT_FALSE(ev.count("job_done") > 0 && ev.count("job_cancelled") > 0)
      << where << "both done and cancelled in the log";
  EXPECT_LE(accepted, 1) << where << "more than one cancel accepted";
  if (accepted > 0) {
    ++tally.cancelled;
    EXPECT_EQ(refused_done, 0) << where << "a cancel accepted and another refused as already done";
    EXPECT_EQ(state, "cancelled") << where << "its cancel was accepted";
    EXPECT_EQ(ev.count("job_cancelled"), 1) << where;
    EXPECT_EQ(ev.count("job_done"), 0) << where;
    const std::size_t at = ev.first("job_cancelled");
    const bool assigned_before = ev.first("task_assigned") < at;
    (assigned_before ? tally.accepted_running : tally.accepted_queued) += 1;
    EXPECT_EQ(ev.frames_after_cancel, 0) << where << "frames stored after its job_cancelled line";
    for (const auto& [line, kind] : ev.events)
      EXPECT_FALSE(line > at && (kind == "task_done" || kind == "hierarchy_stored"))
          << where << kind << " at log line " << line + 1 << " after job_cancelled at line " << at + 1;
  } else {
    ++tally.done;
    EXPECT_EQ(refused_cancelled, 0) << where << "refused as already cancelled, but no cancel was accepted";
    EXPECT_EQ(state, "done") << where << "never cancelled: " << final.dump();
    EXPECT_EQ(ev.count("job_done"), 1) << where;
    EXPECT_EQ(ev.count("job_cancelled"), 0) << where;
    EXPECT_EQ(final.at("levels").size(), job.preview_only ? 1u : 3u) << where << final.dump();
    for (const json& l : final.at("levels")) {
      EXPECT_EQ(l.at("frames_total"), job.frames + 1) << where << l.dump();
      EXPECT_EQ(l.at("frames_done"), l.at("frames_total")) << where << l.dump();
    }
  }
  ++tally.checks;
}

// Ended is ended: a listing that showed a job done or cancelled showed its final state, and one that
// started after an accepted cancel's reply shows it cancelled.
void check_observations(const Clients& c, const std::map<int64_t, json>& final, Tally& tally) {
  int bad = 0;
  for (const Observation& o : c.observations) {
    const std::string end_state = final.at(o.job).at("state").get<std::string>();
    bool after_cancel = false;
    for (const CancelTry& t : c.jobs.at(o.job).cancels) after_cancel = after_cancel || (t.accepted && t.end < o.start);
    const bool ok = (!finished(o.state) || o.state == end_state) && (!after_cancel || o.state == "cancelled");
    if (!ok && ++bad <= 5)
      ADD_FAILURE() << "job " << o.job << " listed " << o.state << " at " << o.start << "-" << o.end
                    << " s, ends " << end_state << (after_cancel ? ", after its cancel was accepted" : "");
    ++tally.checks;
  }
  EXPECT_EQ(bad, 0) << "listings inconsistent with the final states";
}

// After the minute: cancelling a done job again is refused as already done, a cancelled one as
// already cancelled (up to 3 of each), and nothing changes.
void check_late_cancels(const Farm& farm, const std::map<int64_t, json>& final) {
  std::map<std::string, int> tried;
  for (const auto& [id, j] : final) {
    const std::string state = j.at("state").get<std::string>();
    if (tried[state]++ >= 3) continue;
    const test::RunResult r = farm.pd({"cancel", std::to_string(id), "--json"}, kCommandBound);
    EXPECT_EQ(r.exit_code, 2) << r.describe();
    EXPECT_EQ(r.err, "pd: error: job " + std::to_string(id) + " is already " + state + "\n") << r.describe();
    EXPECT_EQ(test::job_status(farm, id).at("state"), state) << "job " << id << " after a refused cancel";
  }
  EXPECT_GE(tried["done"], 1) << "no job ended done";
  EXPECT_GE(tried["cancelled"], 1) << "no job ended cancelled";
}

TEST_F(FarmTest, TwoClientsSubmittingAndCancellingForAMinuteSeeNoBusyErrorAndEveryJobEndsAsItsHistorySays) {
  Farm& farm = start_farm(2, "farm_clients");
  Clients clients(farm);
  const unsigned seed = base_seed();
  std::printf("seeds %u and %u (PD_CLIENTS_SEED=%u repeats them)\n", seed, seed + 1, seed);
  const auto deadline = Clock::now() + kClientTime;
  std::vector<std::thread> threads;
  for (int k = 0; k < 2; ++k)
    threads.emplace_back([&, k] {
      try {
        clients.run_client(k, seed + static_cast<unsigned>(k), deadline);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(clients.mutex);
        clients.problems.push_back("client " + std::to_string(k) + " stopped: " + e.what());
      }
    });
  for (std::thread& t : threads) t.join();
  std::string shown;
  for (std::size_t i = 0; i < std::min<std::size_t>(clients.problems.size(), 10); ++i)
    shown += clients.problems[i] + "\n";
  EXPECT_TRUE(clients.problems.empty()) << clients.problems.size() << " commands not allowed, the first:\n" << shown;
  ASSERT_GE(clients.jobs.size(), 10u) << "too few jobs submitted to mean anything";

  const auto t_end = Clock::now();
  const std::map<int64_t, json> final = wait_until_all_ended(farm, kEndBound);
  const double ending = std::chrono::duration<double>(Clock::now() - t_end).count();
  // Every submitted job listed once (the map would hide a repeat: count the raw listing too).
  const json listing = test::parse_json(farm.pd({"status", "--json"}, kCommandBound)).at("jobs");
  EXPECT_EQ(listing.size(), clients.jobs.size()) << "listed jobs against submitted jobs";
  std::set<int64_t> listed_ids;
  for (const json& j : listing) listed_ids.insert(j.at("id").get<int64_t>());
  EXPECT_EQ(listed_ids.size(), listing.size()) << "a job listed twice";
  for (const auto& [id, job] : clients.jobs) EXPECT_TRUE(final.count(id)) << "job " << id << " not listed";
  ASSERT_FALSE(HasFailure());

  check_late_cancels(farm, final);
  const std::map<int64_t, JobEvents> events = job_events(farm.scheduler_log());
  Tally tally;
  for (const auto& [id, job] : clients.jobs)
    check_job(job, final.at(id), events.count(id) ? events.at(id) : JobEvents{}, tally);
  check_observations(clients, final, tally);
  EXPECT_EQ(tally.checks, static_cast<int>(clients.jobs.size() + clients.observations.size()));
  const std::string log = test::read_file_text(farm.scheduler_log());
  EXPECT_EQ(log.find("database is locked"), std::string::npos) << "in " << farm.scheduler_log();
  EXPECT_EQ(log.find("SQLITE_BUSY"), std::string::npos) << "in " << farm.scheduler_log();
  // The minute must have exercised what it claims to.
  EXPECT_GE(tally.accepted_queued, 1) << "no cancel accepted while the job was queued";
  EXPECT_GE(tally.accepted_running, 1) << "no cancel accepted while the job was running";
  EXPECT_GE(tally.refused_done, 1) << "no cancel refused as already done";
  EXPECT_GE(tally.cross_client, 1) << "no client cancelled the other's job";

  std::printf("%zu jobs submitted (%d ended done, %d cancelled); %d cancels: %d accepted (%d queued, %d running), "
              "refused %d already done, %d already cancelled, %d other; %d of them on the other client's job\n",
              clients.jobs.size(), tally.done, tally.cancelled, clients.cancels,
              tally.accepted_queued + tally.accepted_running, tally.accepted_queued, tally.accepted_running,
              tally.refused_done, tally.refused_cancelled, tally.refused_other, tally.cross_client);
  std::printf("%d commands (%d submit, %d cancel, %d status), slowest %.3f s: %s; all ended %.1f s after the "
              "minute; %d checks\n",
              clients.commands, clients.submits, clients.cancels, clients.statuses, clients.slowest,
              clients.slowest_command.c_str(), ending, tally.checks);
  RecordProperty("jobs", static_cast<int>(clients.jobs.size()));
  RecordProperty("commands", clients.commands);
  RecordProperty("slowest_command_s", std::to_string(clients.slowest));
}

// Issue 47 item 2 (farm/job_limits.h): requests whose fields are each within pd's ranges but whose
// task graph is absurd are refused before anything is made, naming the figures, and the scheduler
// keeps answering; a job at the limit's size (19 001 tasks inserted in one transaction) is taken
// without its one worker being dropped as silent.
TEST_F(FarmTest, AbsurdJobSizesAreRefusedNamingTheFiguresAndTheSchedulerKeepsAnswering) {
  Farm& farm = start_farm(1, "absurd_sizes");
  const std::string scene = test::scene_path("cube-trampoline.json");
  const struct {
    Args args;
    std::string expected;
  } cases[] = {
      {{"--frames", "10000000", "--subsets", "10000000", "--levels", "20"}, "would need 380199982 tasks; the limit is 20000"},
      {{"--frames", "10000000", "--preview-chunk", "1", "--levels", "1"}, "would need 10000001 tasks; the limit is 20000"},
  };
  for (const auto& c : cases) {
    Args args = {"submit", scene};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const test::RunResult r = farm.pd(args);
    EXPECT_EQ(r.exit_code, 2) << r.describe();
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.describe();
    std::printf("refused in %.2f s: %s", r.seconds, r.err.c_str());
  }
  EXPECT_EQ(test::parse_json(farm.pd({"status", "--json"})).at("jobs").size(), 0u);

  const auto submitted = Clock::now();
  const int64_t job = test::submit(farm, {scene, "--frames", "19000", "--preview-chunk", "1", "--levels", "1"});
  const double seconds = std::chrono::duration<double>(Clock::now() - submitted).count();
  std::printf("a 19 001-task job submitted in %.2f s (the reply, its transaction included)\n", seconds);
  RecordProperty("submit_19001_tasks_seconds", std::to_string(seconds));
  EXPECT_EQ(farm.pd({"cancel", std::to_string(job)}).exit_code, 0);
  farm.wait_for_idle_workers(1, 30s);
  EXPECT_EQ(test::read_file_text(farm.scheduler_log()).find("\"worker_lost\""), std::string::npos)
      << "the worker was dropped while the job was inserted";
}

}  // namespace
}  // namespace pd
