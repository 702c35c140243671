#include "store/task_store.h"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include "support/test_paths.h"
#include <poll.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

namespace pd {
namespace {

namespace fs = std::filesystem;
using protocol::JobState;
using protocol::TaskKind;
using protocol::TaskState;

template <typename F>
std::string store_error_of(F&& f) {
  try {
    f();
  } catch (const StoreError& e) {
    return e.what();
  }
  return "(no StoreError thrown)";
}

// First column of the first row of `sql` (one optional bound id) read over a raw sqlite3 connection
// of its own, as text; "NULL" for NULL, "(no row)" for none.
std::string raw_value(const std::string& path, const char* sql, int64_t id = 0) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, sql, -1, &st, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  if (id != 0) sqlite3_bind_int64(st, 1, id);
  std::string value = "(no row)";
  if (sqlite3_step(st) == SQLITE_ROW) {
    const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
    value = text ? text : "NULL";
  }
  sqlite3_finalize(st);
  sqlite3_close(db);
  return value;
}

FrameData with_kappa(std::optional<double> kappa) {
  FrameData d;
  d.kappa = kappa;
  return d;
}

NewJob make_job(int frames, int levels, int priority = 0) {
  NewJob j;
  j.name = "flag";
  j.scene = {"scenes/flag.json", "{\"name\": \"flag\", \"caf\xc3\xa9\": 1}",
             {{"meshes/flag.obj", "v 0 0 0\nv 1 0 0\n"}}};
  j.frames = frames;
  j.levels = levels;
  j.priority = priority;
  j.preview_chunk = 3;
  j.hessian = "lagged";
  return j;
}

NewTask hierarchy_task() {
  NewTask t;
  t.kind = TaskKind::hierarchy;
  return t;
}

NewTask level_task(int level, int first, int last, std::vector<FrameKey> needs = {}, bool after_hierarchy = false) {
  NewTask t;
  t.level = level;
  t.first = first;
  t.last = last;
  t.needs = std::move(needs);
  t.after_hierarchy = after_hierarchy;
  return t;
}

// The states of the job's tasks in their order (level, then first), space-separated.
std::string states_of(const TaskStore& s, int64_t job) {
  std::string out;
  for (const TaskRow& t : s.tasks(job)) out += (out.empty() ? "" : " ") + to_string(t.state);
  return out;
}

std::vector<int64_t> ids_in_state(const TaskStore& s, int64_t job, TaskState state) {
  std::vector<int64_t> ids;
  for (const TaskRow& t : s.tasks(job))
    if (t.state == state) ids.push_back(t.id);
  return ids;
}

// Every field of a row, for comparing rows (doubles with all their digits).
template <typename... T>
std::string join(const T&... v) {
  std::ostringstream o;
  o.precision(17);
  ((o << v << '|'), ...);
  return o.str();
}
std::string describe(const TaskRow& t) {
  return join(t.id, t.job, to_string(t.kind), t.level, t.first, t.last, to_string(t.state), t.reason, t.worker,
              t.attempts, t.attempt);
}
std::string describe(const JobRow& j) {
  std::string files;
  for (const auto& f : j.spec.scene.files) files += join(f.path, f.content);
  return join(j.id, j.spec.name, j.spec.scene.name, j.spec.scene.text, files, j.spec.frames, j.spec.levels,
              j.spec.subsets, j.spec.priority, j.spec.preview_only, j.spec.preview_chunk, j.spec.hessian,
              to_string(j.state), j.reason, j.hierarchy_hash, j.submitted, j.finished);
}
std::string describe(const WorkerRow& w) {
  return join(w.id, w.name, w.host, w.version, w.cores, w.state, w.last_seen, w.tasks_done);
}
std::string describe(const EventRow& e) { return join(e.id, e.time, e.job, e.task, e.worker, e.kind, e.message); }

template <typename Row>
std::vector<std::string> describe_all(const std::vector<Row>& rows) {
  std::vector<std::string> out;
  for (const Row& r : rows) out.push_back(describe(r));
  return out;
}

double now_seconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

class TaskStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::scratch_dir("task_store");
    path_ = (dir_ / "farm.sqlite").string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
  std::string path_;
};

TEST_F(TaskStoreTest, NewStoreHasSchemaVersionAndAnotherVersionIsRefused) {
  { TaskStore s(path_); }
  EXPECT_EQ(raw_value(path_, "PRAGMA user_version"), std::to_string(kTaskStoreSchemaVersion));
  { TaskStore again(path_); }  // the same version opens
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "PRAGMA user_version = 99", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  EXPECT_EQ(store_error_of([&] { TaskStore s(path_); }), path_ + ": schema version 99, this program reads " + std::to_string(kTaskStoreSchemaVersion));
}

TEST_F(TaskStoreTest, FileThatIsNotADatabaseIsRefusedAndLeftAlone) {
  const std::string text(5000, 'x');
  std::ofstream(path_) << text;
  const std::string message = store_error_of([&] { TaskStore s(path_); });
  EXPECT_EQ(message.rfind(path_ + ": ", 0), 0u) << message;
  EXPECT_NE(message.find("file is not a database"), std::string::npos) << message;
  std::ifstream in(path_);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), text);
}

TEST_F(TaskStoreTest, SqliteFileOfAnotherProgramIsRefused) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE photos(id)", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  EXPECT_EQ(store_error_of([&] { TaskStore s(path_); }),
            path_ + ": not a task store (no schema version, 1 schema objects)");
}

TEST_F(TaskStoreTest, JournalModeIsWal) {
  TaskStore s(path_);
  EXPECT_EQ(raw_value(path_, "PRAGMA journal_mode"), "wal");  // a second connection, while the store is open
  EXPECT_EQ(s.path(), path_);
}

// Job of N = 6, two levels: the hierarchy, a level-0 chain of two subsets, level 1 in two subsets.
TEST_F(TaskStoreTest, TasksBecomeReadyAsTheHierarchyAndTheirFramesAreStored) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(6, 2), {hierarchy_task(), level_task(0, 0, 3, {}, true),
                                                  level_task(0, 3, 6, {{0, 2}, {0, 3}}, true),
                                                  level_task(1, 0, 3, {{0, 0}}, true),
                                                  level_task(1, 3, 6, {{0, 2}, {0, 3}}, true)});
  const std::vector<TaskRow> tasks = s.tasks(job);
  ASSERT_EQ(tasks.size(), 5u);
  const int64_t h = tasks[0].id, a0 = tasks[1].id, b0 = tasks[2].id, a1 = tasks[3].id, b1 = tasks[4].id;
  EXPECT_EQ(tasks[0].kind, TaskKind::hierarchy);
  EXPECT_EQ(s.job(job).state, JobState::queued);
  EXPECT_EQ(ids_in_state(s, job, TaskState::ready), (std::vector<int64_t>{h}));

  s.record_frame(job, {0, 0}, FrameData{});  // a1's frame, but a1 also waits for the hierarchy
  EXPECT_EQ(ids_in_state(s, job, TaskState::ready), (std::vector<int64_t>{h}));

  const int64_t w = s.add_worker("w", "host", "1.0", 4);
  ASSERT_EQ(s.claim_next(w)->task.id, h);
  s.finish_task(h);
  EXPECT_EQ(ids_in_state(s, job, TaskState::ready), (std::vector<int64_t>{a0, a1}));

  s.record_frame(job, {0, 1}, FrameData{});
  s.record_frame(job, {0, 2}, FrameData{});
  EXPECT_EQ(ids_in_state(s, job, TaskState::ready), (std::vector<int64_t>{a0, a1}));
  s.record_frame(job, {1, 3}, FrameData{});  // level 1's frame 3 is not what b0 and b1 need
  EXPECT_EQ(ids_in_state(s, job, TaskState::ready), (std::vector<int64_t>{a0, a1}));
  s.record_frame(job, {0, 3}, FrameData{});
  EXPECT_EQ(ids_in_state(s, job, TaskState::ready), (std::vector<int64_t>{a0, b0, a1, b1}));
}

TEST_F(TaskStoreTest, ClaimOrderIsPriorityThenJobThenLevelThenFirstFrame) {
  TaskStore s(path_);
  const std::vector<NewTask> tasks{level_task(1, 0, 2), level_task(0, 2, 4), level_task(0, 0, 2), level_task(1, 2, 4)};
  const int64_t low = s.add_job(make_job(4, 2, 0), tasks);
  const int64_t high = s.add_job(make_job(4, 2, 5), tasks);
  const int64_t high_later = s.add_job(make_job(4, 2, 5), tasks);
  const int64_t w = s.add_worker("w", "host", "1.0", 1);
  std::vector<std::string> order;
  while (auto c = s.claim_next(w)) {
    EXPECT_EQ(c->task.state, TaskState::running);
    EXPECT_EQ(c->task.worker, w);
    EXPECT_EQ(c->task.attempt, c->attempt);
    EXPECT_EQ(s.job(c->task.job).state, JobState::running);
    order.push_back(std::to_string(c->task.job) + ":" + std::to_string(c->task.level) + "," +
                    std::to_string(c->task.first));
  }
  std::vector<std::string> expected;
  for (int64_t job : {high, high_later, low})
    for (const char* lf : {"0,0", "0,2", "1,0", "1,2"}) expected.push_back(std::to_string(job) + ":" + lf);
  EXPECT_EQ(order, expected);
}

TEST_F(TaskStoreTest, ClaimNextReturnsNulloptWhenNothingIsReady) {
  TaskStore s(path_);
  const int64_t w = s.add_worker("w", "host", "1.0", 1);
  EXPECT_FALSE(s.has_ready_task());
  EXPECT_FALSE(s.claim_next(w).has_value());  // empty store
  const int64_t job = s.add_job(make_job(4, 1), {level_task(0, 0, 4, {{0, 0}})});
  EXPECT_FALSE(s.has_ready_task());
  EXPECT_FALSE(s.claim_next(w).has_value());  // its task waits for frame 0
  EXPECT_EQ(s.worker(w).state, "idle");
  EXPECT_EQ(s.job(job).state, JobState::queued);
  s.record_frame(job, {0, 0}, FrameData{});
  EXPECT_TRUE(s.has_ready_task());
  EXPECT_TRUE(s.claim_next(w).has_value());
  EXPECT_FALSE(s.has_ready_task());
  EXPECT_EQ(s.worker(w).state, "busy");
}

TEST_F(TaskStoreTest, TwoConnectionsClaimingAlternatelyNeverShareATask) {
  TaskStore a(path_), b(path_);
  std::vector<NewTask> tasks;
  for (int i = 0; i < 30; ++i) tasks.push_back(level_task(i % 3, 0, 2));
  const int64_t job = a.add_job(make_job(2, 3), tasks);
  const int64_t wa = a.add_worker("a", "host", "1.0", 1), wb = b.add_worker("b", "host", "1.0", 1);
  std::map<int64_t, int> claimed;
  for (bool more = true; more;) {
    auto ca = a.claim_next(wa);
    auto cb = b.claim_next(wb);
    if (ca) ++claimed[ca->task.id];
    if (cb) ++claimed[cb->task.id];
    more = ca || cb;
  }
  ASSERT_EQ(claimed.size(), 30u);
  for (const TaskRow& t : a.tasks(job)) EXPECT_EQ(claimed[t.id], 1) << "task " << t.id;
}

// Reads exactly n bytes from fd within the deadline; false on timeout or end of file.
bool read_full(int fd, char* out, size_t n, std::chrono::steady_clock::time_point deadline) {
  size_t got = 0;
  while (got < n) {
    using std::chrono::milliseconds;
    const auto left = std::chrono::duration_cast<milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd p{fd, POLLIN, 0};
    if (left.count() <= 0 || poll(&p, 1, static_cast<int>(left.count())) <= 0) return false;
    const ssize_t r = read(fd, out + got, n - got);
    if (r <= 0) return false;
    got += static_cast<size_t>(r);
  }
  return true;
}

TEST_F(TaskStoreTest, ClaimsFromAnotherProcessNeverTakeATaskTwice) {
  constexpr int kTasks = 100;
  int64_t job = 0, w_parent = 0, w_child = 0;
  {
    // Closed before fork(): a SQLite connection must not cross a fork.
    TaskStore s(path_);
    std::vector<NewTask> tasks;
    for (int i = 0; i < kTasks; ++i) tasks.push_back(level_task(0, 0, 1));
    job = s.add_job(make_job(1, 1), tasks);
    w_parent = s.add_worker("parent", "host", "1.0", 1);
    w_child = s.add_worker("child", "host", "1.0", 1);
  }
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // Child: report readiness ('R'), then each claimed id; _exit so that no test code runs twice.
    close(fds[0]);
    int status = 0;
    try {
      TaskStore s(path_);
      status = write(fds[1], "R", 1) == 1 ? 0 : 2;
      while (status == 0) {
        auto c = s.claim_next(w_child);
        if (!c) break;
        if (write(fds[1], &c->task.id, sizeof(int64_t)) != sizeof(int64_t)) status = 2;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
    } catch (const std::exception& e) {
      std::fprintf(stderr, "child: %s\n", e.what());
      status = 1;
    }
    close(fds[1]);
    _exit(status);
  }
  close(fds[1]);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  char ready = 0;
  const bool started = read_full(fds[0], &ready, 1, deadline) && ready == 'R';
  std::map<int64_t, std::vector<int64_t>> claimed_by;  // task -> the workers that claimed it
  size_t parent_claims = 0, child_claims = 0;
  if (started) {
    TaskStore s(path_);
    while (auto c = s.claim_next(w_parent)) {
      claimed_by[c->task.id].push_back(w_parent);
      ++parent_claims;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }
  for (int64_t id = 0; started && read_full(fds[0], reinterpret_cast<char*>(&id), sizeof id, deadline);) {
    claimed_by[id].push_back(w_child);
    ++child_claims;
  }
  close(fds[0]);
  int status = -1;
  while (waitpid(child, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(child, SIGKILL);
      waitpid(child, &status, 0);
      FAIL() << "the child did not finish in time";
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_TRUE(started) << "the child did not open the store";
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "child status " << status;
  EXPECT_GT(child_claims, 0u);  // both competed (each sleeps 2 ms between claims)
  EXPECT_GT(parent_claims, 0u);
  TaskStore s(path_);
  ASSERT_EQ(claimed_by.size(), static_cast<size_t>(kTasks));
  for (const TaskRow& t : s.tasks(job)) {
    ASSERT_EQ(claimed_by[t.id].size(), 1u) << "task " << t.id;
    EXPECT_EQ(t.attempts, 1);
    EXPECT_EQ(t.worker, claimed_by[t.id][0]) << "task " << t.id;
  }
}

TEST_F(TaskStoreTest, FinishingTheLastTaskMakesTheJobDone) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(4, 1), {level_task(0, 0, 2), level_task(0, 2, 4, {{0, 2}})});
  const int64_t w = s.add_worker("w", "host", "1.0", 2);
  auto first = s.claim_next(w);
  ASSERT_TRUE(first);
  EXPECT_EQ(s.worker(w).state, "busy");
  s.finish_task(first->task.id);
  EXPECT_EQ(raw_value(path_, "SELECT outcome FROM attempts WHERE id = ?1", first->attempt), "done");
  EXPECT_EQ(s.worker(w).state, "idle");
  EXPECT_EQ(s.job(job).state, JobState::running);
  EXPECT_FALSE(s.claim_next(w).has_value());  // the second waits for frame 2
  s.record_frame(job, {0, 2}, with_kappa(1e8));
  auto second = s.claim_next(w);
  ASSERT_TRUE(second);
  const double before = now_seconds();
  s.finish_task(second->task.id);
  const JobRow j = s.job(job);
  EXPECT_EQ(j.state, JobState::done);
  EXPECT_GE(j.finished, before - 1.0);
  EXPECT_GE(j.finished, j.submitted);
  EXPECT_EQ(s.worker(w).tasks_done, 2);
  const TaskRow t = s.task(second->task.id);
  EXPECT_EQ(t.state, TaskState::done);
  EXPECT_EQ(t.worker, w);  // the worker that finished it
  EXPECT_EQ(t.attempt, 0);
  EXPECT_EQ(store_error_of([&] { s.finish_task(t.id); }),
            path_ + ": task " + std::to_string(t.id) + " is done, not running or ready");
}

// Level 0, 1, 2 each in two subsets (0, 3] and (3, 6]. The failed level-0 task (3, 6] produces frames
// 4..6: level 1's (3, 6] reads 2..5 of them, level 1's (0, 3] reads only 0..2; level 2's (3, 6] needs
// level 1's (3, 6] and so is blocked through it.
TEST_F(TaskStoreTest, FailTaskBlocksExactlyItsDependentsAndFailsTheJob) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(6, 3), {level_task(0, 0, 3), level_task(0, 3, 6), level_task(1, 0, 3),
                                                  level_task(1, 3, 6), level_task(2, 0, 3), level_task(2, 3, 6)});
  const std::vector<TaskRow> t = s.tasks(job);
  std::vector<int64_t> workers;
  for (int i = 0; i < 4; ++i) workers.push_back(s.add_worker("w" + std::to_string(i), "host", "1.0", 1));
  std::vector<Claim> claims;
  for (int i = 0; i < 4; ++i) claims.push_back(*s.claim_next(workers[i]));  // a0, b0, a1, b1 by level then first
  ASSERT_EQ(claims[1].task.id, t[1].id);
  ASSERT_EQ(claims[3].task.id, t[3].id);

  s.fail_task(t[1].id, "solver diverged");
  const std::string why =
      "needs frames of task " + std::to_string(t[1].id) + " (level 0, frames (3, 6]), which failed: solver diverged";
  // a1 reads level-0 frames 0..2 only and stays running; a2 does not depend on b0 and stays ready.
  EXPECT_EQ(states_of(s, job), "running failed running blocked ready blocked");
  const std::vector<TaskRow> after = s.tasks(job);
  EXPECT_EQ(after[1].reason, "solver diverged");
  EXPECT_EQ(after[3].reason, why);
  EXPECT_EQ(after[5].reason, why);
  EXPECT_EQ(raw_value(path_, "SELECT outcome FROM attempts WHERE id = ?1", claims[1].attempt), "failed");
  EXPECT_EQ(raw_value(path_, "SELECT message FROM attempts WHERE id = ?1", claims[1].attempt), "solver diverged");
  EXPECT_EQ(raw_value(path_, "SELECT outcome FROM attempts WHERE id = ?1", claims[3].attempt), "blocked");
  EXPECT_EQ(s.worker(workers[1]).state, "idle");
  EXPECT_EQ(s.worker(workers[3]).state, "idle");
  EXPECT_EQ(s.worker(workers[0]).state, "busy");
  const JobRow j = s.job(job);
  EXPECT_EQ(j.state, JobState::failed);
  EXPECT_EQ(j.reason, "task " + std::to_string(t[1].id) + " failed: solver diverged");
  EXPECT_GT(j.finished, 0.0);
  EXPECT_FALSE(s.claim_next(workers[1]).has_value());  // a2 is ready, but its job has failed
}

// Subsets that do not line up across levels: level 1's (0, 5] reads level-0 frames 0..4, all from
// (0, 4], so it does not depend on the failed (4, 8] although their ranges overlap; (5, 8] does.
TEST_F(TaskStoreTest, FailTaskFollowsTheFramesReadNotTheRangesOverlap) {
  TaskStore s(path_);
  const int64_t job =
      s.add_job(make_job(8, 2), {level_task(0, 0, 4), level_task(0, 4, 8), level_task(1, 0, 5), level_task(1, 5, 8)});
  const std::vector<TaskRow> t = s.tasks(job);
  const int64_t w = s.add_worker("w", "host", "1.0", 1);
  ASSERT_EQ(s.claim_next(w)->task.id, t[0].id);
  s.finish_task(t[0].id);
  ASSERT_EQ(s.claim_next(w)->task.id, t[1].id);
  s.fail_task(t[1].id, "out of memory");
  EXPECT_EQ(states_of(s, job), "done failed ready blocked");
}

TEST_F(TaskStoreTest, FailedHierarchyBlocksEveryLevelTask) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(4, 2), {hierarchy_task(), level_task(0, 0, 4, {}, true),
                                                  level_task(1, 0, 4, {{0, 0}}, true)});
  const int64_t w = s.add_worker("w", "host", "1.0", 1);
  const int64_t h = s.claim_next(w)->task.id;
  s.fail_task(h, "no safe hierarchy");
  for (const TaskRow& t : s.tasks(job)) {
    if (t.id == h) continue;
    EXPECT_EQ(t.state, TaskState::blocked);
    EXPECT_EQ(t.reason, "needs the hierarchy of task " + std::to_string(h) + ", which failed: no safe hierarchy");
  }
  EXPECT_EQ(s.job(job).reason, "task " + std::to_string(h) + " failed: no safe hierarchy");
}

TEST_F(TaskStoreTest, ReleasedTaskIsReadyAgainAndGetsANewAttempt) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(4, 1), {level_task(0, 0, 4)});
  const int64_t w1 = s.add_worker("w1", "host", "1.0", 1), w2 = s.add_worker("w2", "host", "1.0", 1);
  const Claim first = *s.claim_next(w1);
  s.release_task(first.task.id, "lost");
  TaskRow t = s.task(first.task.id);
  EXPECT_EQ(t.state, TaskState::ready);
  EXPECT_EQ(t.worker, 0);
  EXPECT_EQ(t.attempt, 0);
  EXPECT_EQ(s.worker(w1).state, "idle");
  EXPECT_EQ(raw_value(path_, "SELECT outcome FROM attempts WHERE id = ?1", first.attempt), "lost");
  EXPECT_EQ(store_error_of([&] { s.release_task(t.id, "lost"); }),
            path_ + ": task " + std::to_string(t.id) + " is ready, not running");
  const Claim second = *s.claim_next(w2);
  EXPECT_EQ(second.task.id, first.task.id);
  EXPECT_NE(second.attempt, first.attempt);
  EXPECT_EQ(second.task.attempts, 2);
  EXPECT_EQ(second.task.worker, w2);
  EXPECT_EQ(s.job(job).state, JobState::running);
}

TEST_F(TaskStoreTest, EndAttemptClosesItOnceAndKeepsTheTaskRunning) {
  TaskStore s(path_);
  s.add_job(make_job(4, 1), {level_task(0, 0, 4)});
  const int64_t w = s.add_worker("w", "host", "1.0", 1);
  const Claim c = *s.claim_next(w);
  s.end_attempt(c.attempt, "refused", "late report");
  EXPECT_EQ(raw_value(path_, "SELECT message FROM attempts WHERE id = ?1", c.attempt), "late report");
  EXPECT_EQ(s.task(c.task.id).state, TaskState::running);
  EXPECT_EQ(s.task(c.task.id).attempt, 0);
  EXPECT_EQ(store_error_of([&] { s.end_attempt(c.attempt, "lost"); }),
            path_ + ": attempt " + std::to_string(c.attempt) + " has already ended (refused)");
}

TEST_F(TaskStoreTest, CancelJobCancelsUnfinishedTasksAndRefusesAnEndedJob) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(6, 2), {level_task(0, 0, 2), level_task(0, 2, 4), level_task(0, 4, 6),
                                                  level_task(1, 0, 6, {{0, 5}})});
  const int64_t w = s.add_worker("w", "host", "1.0", 1);
  s.finish_task(s.claim_next(w)->task.id);
  const Claim running = *s.claim_next(w);
  s.cancel_job(job);
  EXPECT_EQ(states_of(s, job), "done cancelled cancelled cancelled");
  EXPECT_EQ(raw_value(path_, "SELECT outcome FROM attempts WHERE id = ?1", running.attempt), "cancelled");
  EXPECT_EQ(s.worker(w).state, "idle");
  EXPECT_EQ(s.job(job).state, JobState::cancelled);
  EXPECT_GT(s.job(job).finished, 0.0);
  EXPECT_EQ(store_error_of([&] { s.cancel_job(job); }),
            path_ + ": job " + std::to_string(job) + " is already cancelled");
  const int64_t done = s.add_job(make_job(2, 1), {level_task(0, 0, 2)});
  s.finish_task(s.claim_next(w)->task.id);
  EXPECT_EQ(store_error_of([&] { s.cancel_job(done); }), path_ + ": job " + std::to_string(done) + " is already done");
}

TEST_F(TaskStoreTest, RecordFrameRoundTripsKappaAndUpdatesIt) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(10, 2), {level_task(0, 0, 10)});
  EXPECT_FALSE(s.frame_stored(job, {0, 4}));
  EXPECT_EQ(s.frame_kappa(job, {0, 4}), std::nullopt);
  const double kappa = 1.0 / 3.0 * 1e9;
  s.record_frame(job, {0, 4}, with_kappa(kappa));
  EXPECT_TRUE(s.frame_stored(job, {0, 4}));
  EXPECT_EQ(s.frame_kappa(job, {0, 4}), std::optional<double>(kappa));  // bit for bit
  s.record_frame(job, {0, 4}, with_kappa(2.5e9));
  EXPECT_EQ(s.frame_kappa(job, {0, 4}), std::optional<double>(2.5e9));
  s.record_frame(job, {0, 4}, FrameData{});  // the scene has no contact after all: NULL
  EXPECT_TRUE(s.frame_stored(job, {0, 4}));
  EXPECT_EQ(s.frame_kappa(job, {0, 4}), std::nullopt);
  EXPECT_EQ(s.frames_stored(job), (std::vector<int>{1, 0}));  // recorded three times, stored once
  const std::string id = std::to_string(job);
  EXPECT_EQ(store_error_of([&] { s.record_frame(job, {2, 0}, FrameData{}); }),
            path_ + ": record_frame: job " + id + ": level 2 outside 0..1");
  EXPECT_EQ(store_error_of([&] { s.record_frame(job, {1, 11}, FrameData{}); }),
            path_ + ": record_frame: job " + id + ": frame 11 outside 0..10");
}

TEST_F(TaskStoreTest, FramesStoredCountsPerLevelAndStoredFramesListsSorted) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(8, 3), {level_task(0, 0, 8)});
  const int64_t other = s.add_job(make_job(8, 3), {level_task(0, 0, 8)});
  for (int t : {5, 0, 3, 8}) s.record_frame(job, {0, t}, FrameData{});
  s.record_frame(job, {2, 1}, FrameData{});
  s.record_frame(other, {1, 1}, FrameData{});
  EXPECT_EQ(s.frames_stored(job), (std::vector<int>{4, 0, 1}));
  EXPECT_EQ(s.frames_stored(other), (std::vector<int>{0, 1, 0}));
  EXPECT_EQ(s.stored_frames(job, 0, 0, 8), (std::vector<int>{0, 3, 5, 8}));
  EXPECT_EQ(s.stored_frames(job, 0, 1, 5), (std::vector<int>{3, 5}));
  EXPECT_EQ(s.stored_frames(job, 1, 0, 8), std::vector<int>{});
}

TEST_F(TaskStoreTest, AddTasksRefinesADoneJob) {
  TaskStore s(path_);
  NewJob preview = make_job(4, 2);
  preview.preview_only = true;
  const int64_t job = s.add_job(preview, {hierarchy_task(), level_task(0, 0, 4, {}, true)});
  const int64_t w = s.add_worker("w", "host", "1.0", 1);
  s.finish_task(s.claim_next(w)->task.id);
  s.finish_task(s.claim_next(w)->task.id);
  for (int t = 0; t <= 4; ++t) s.record_frame(job, {0, t}, FrameData{});
  ASSERT_EQ(s.job(job).state, JobState::done);
  s.set_preview_only(job, false);
  s.add_tasks(job, {level_task(1, 0, 2, {{0, 0}}, true), level_task(1, 2, 4, {{0, 2}, {1, 2}}, true)});
  const JobRow j = s.job(job);
  EXPECT_EQ(j.state, JobState::running);
  EXPECT_EQ(j.finished, 0.0);
  EXPECT_FALSE(j.spec.preview_only);
  const std::vector<TaskRow> t = s.tasks(job);
  ASSERT_EQ(t.size(), 4u);
  EXPECT_EQ(t[2].state, TaskState::ready);  // hierarchy done, level-0 frame 0 stored
  EXPECT_EQ(t[3].state, TaskState::waiting);  // level-1 frame 2 not yet
  EXPECT_EQ(store_error_of([&] { s.add_tasks(job, {hierarchy_task()}); }),
            path_ + ": add_tasks: task 1 of 1: job " + std::to_string(job) + " already has a hierarchy task (" +
                std::to_string(t[0].id) + ")");
}

TEST_F(TaskStoreTest, BadJobOrTaskIsRefusedNamingTheFieldAndAddsNothing) {
  TaskStore s(path_);
  NewJob bad = make_job(4, 2);
  bad.frames = 0;
  EXPECT_EQ(store_error_of([&] { s.add_job(bad, {level_task(0, 0, 1)}); }),
            path_ + ": add_job: frames 0, expected at least 1");
  EXPECT_EQ(store_error_of([&] { s.add_job(make_job(4, 2), {level_task(0, 0, 2), level_task(2, 0, 2)}); }),
            path_ + ": add_job: task 2 of 2: level 2 outside 0..1");
  EXPECT_EQ(store_error_of([&] { s.add_job(make_job(4, 2), {level_task(0, 3, 5)}); }),
            path_ + ": add_job: task 1 of 1: frames (3, 5] not within (0, 4] with first < last");
  EXPECT_EQ(store_error_of([&] { s.add_job(make_job(4, 2), {level_task(0, 0, 2, {{0, 9}})}); }),
            path_ + ": add_job: task 1 of 1: needs: job 1: frame 9 outside 0..4");
  EXPECT_EQ(store_error_of([&] { s.add_job(make_job(4, 2), {level_task(0, 0, 2, {}, true)}); }),
            path_ + ": add_job: task 1 waits for the hierarchy, but job 1 has no hierarchy task");
  EXPECT_EQ(store_error_of([&] { s.add_job(make_job(4, 2), {}); }), path_ + ": add_job: job 1: no tasks given");
  EXPECT_TRUE(s.jobs().empty());  // every refused add_job was rolled back
  EXPECT_EQ(raw_value(path_, "SELECT COUNT(*) FROM tasks"), "0");
}

TEST_F(TaskStoreTest, WorkersAndEvents) {
  TaskStore s(path_);
  const double before = now_seconds();
  const int64_t a = s.add_worker("node", "host-a", "1.0", 8);
  const int64_t b = s.add_worker("other", "host-a", "1.0", 8);
  EXPECT_NE(a, b);
  const WorkerRow wa = s.worker(a);
  EXPECT_EQ(join(wa.id, wa.name, wa.host, wa.version, wa.cores, wa.state, wa.tasks_done),
            join(a, "node", "host-a", "1.0", 8, "idle", 0));
  EXPECT_GE(wa.last_seen, before - 1.0);
  s.set_worker_state(a, "lost");
  s.touch_worker(b);
  EXPECT_GE(s.worker(b).last_seen, wa.last_seen);
  const std::vector<WorkerRow> all = s.workers();
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(join(all[0].id, all[0].state, all[1].id, all[1].state), join(a, "lost", b, "idle"));
  // A reconnect under the same name is the same worker (failures and blocklists follow it).
  EXPECT_EQ(s.add_worker("node", "host-b", "1.1", 4), a);
  EXPECT_EQ(join(s.worker(a).host, s.worker(a).version, s.worker(a).cores, s.worker(a).state),
            join("host-b", "1.1", 4, "idle"));
  EXPECT_EQ(s.workers().size(), 2u);
  EXPECT_EQ(store_error_of([&] { s.set_worker_state(b, "asleep"); }),
            path_ + ": set_worker_state: unknown worker state 'asleep' (allowed: idle, busy, lost)");

  const int64_t job = s.add_job(make_job(2, 1), {level_task(0, 0, 2)});
  const int64_t other = s.add_job(make_job(2, 1), {level_task(0, 0, 2)});
  const int64_t task = s.tasks(job)[0].id;
  s.log_event(0, 0, a, "worker_lost", "no heartbeat for 3 s");
  s.log_event(job, task, b, "assigned", "attempt 1");
  s.log_event(other, 0, 0, "submitted", "");
  const std::vector<EventRow> events = s.events(0);
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(join(events[0].job, events[0].task, events[0].worker, events[0].kind, events[0].message),
            join(0, 0, a, "worker_lost", "no heartbeat for 3 s"));
  EXPECT_GE(events[0].time, before - 1.0);
  EXPECT_LE(events[0].time, now_seconds() + 1.0);
  const std::vector<EventRow> of_job = s.events(job);
  ASSERT_EQ(of_job.size(), 1u);
  EXPECT_EQ(describe(of_job[0]), describe(events[1]));
  EXPECT_EQ(join(of_job[0].job, of_job[0].task, of_job[0].worker, of_job[0].kind, of_job[0].message),
            join(job, task, b, "assigned", "attempt 1"));
  EXPECT_EQ(s.events(other).size(), 1u);
  EXPECT_EQ(store_error_of([&] { s.log_event(job, 0, 0, "", "x"); }), path_ + ": log_event: empty kind");
}

TEST_F(TaskStoreTest, StateSurvivesClosingAndReopening) {
  std::vector<std::string> jobs, tasks, workers, events;
  std::vector<int> stored;
  int64_t job = 0;
  {
    TaskStore s(path_);
    job = s.add_job(make_job(4, 2, 3), {hierarchy_task(), level_task(0, 0, 4, {}, true),
                                         level_task(1, 0, 4, {{0, 0}, {0, 1}}, true)});
    const int64_t w = s.add_worker("w", "host", "2.1", 16);
    s.finish_task(s.claim_next(w)->task.id);
    s.store_hierarchy(job, "ab12cd", "hierarchy bytes");
    s.claim_next(w);
    s.record_frame(job, {0, 0}, with_kappa(7.5e8));
    s.record_frame(job, {0, 1}, FrameData{});
    s.log_event(job, 0, w, "hierarchy", "built");
    jobs = describe_all(s.jobs());
    tasks = describe_all(s.tasks(job));
    workers = describe_all(s.workers());
    events = describe_all(s.events(0));
    stored = s.frames_stored(job);
  }
  TaskStore s(path_);
  EXPECT_EQ(describe_all(s.jobs()), jobs);
  EXPECT_EQ(describe_all(s.tasks(job)), tasks);
  EXPECT_EQ(describe_all(s.workers()), workers);
  EXPECT_EQ(describe_all(s.events(0)), events);
  EXPECT_EQ(s.frames_stored(job), stored);
  EXPECT_EQ(s.frame_kappa(job, {0, 0}), std::optional<double>(7.5e8));
  EXPECT_EQ(s.job(job).hierarchy_hash, "ab12cd");
  EXPECT_EQ(s.job(job).spec.scene.files.at(0).content, "v 0 0 0\nv 1 0 0\n");
  EXPECT_EQ(s.tasks(job)[2].state, TaskState::ready);  // promoted before the close
  ASSERT_EQ(tasks.size(), 3u);
}

TEST_F(TaskStoreTest, StateNameThisProgramDoesNotKnowIsAStoreError) {
  int64_t task = 0;
  {
    TaskStore s(path_);
    task = s.tasks(s.add_job(make_job(2, 1), {level_task(0, 0, 2)}))[0].id;
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "UPDATE tasks SET state = 'paused'", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  TaskStore s(path_);
  const std::string message = store_error_of([&] { s.task(task); });
  EXPECT_EQ(message.rfind(path_ + ": task " + std::to_string(task) + ": unknown task state 'paused'", 0), 0u)
      << message;
}

TEST_F(TaskStoreTest, UnknownIdsThrowStoreErrorNamingTheId) {
  TaskStore s(path_);
  const std::string no_job = path_ + ": no job 99", no_task = path_ + ": no task 99";
  const std::string no_worker = path_ + ": no worker 99";
  EXPECT_FALSE(s.find_job(99).has_value());
  EXPECT_EQ(store_error_of([&] { s.job(99); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.tasks(99); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.add_tasks(99, {level_task(0, 0, 1)}); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.set_job_state(99, JobState::done); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.store_hierarchy(99, "x", ""); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.set_preview_only(99, false); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.cancel_job(99); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.record_frame(99, {0, 0}, FrameData{}); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.frame_stored(99, {0, 0}); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.frames_stored(99); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.stored_frames(99, 0, 0, 1); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.events(99); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.log_event(99, 0, 0, "k", ""); }), no_job);
  EXPECT_EQ(store_error_of([&] { s.task(99); }), no_task);
  EXPECT_EQ(store_error_of([&] { s.finish_task(99); }), no_task);
  EXPECT_EQ(store_error_of([&] { s.fail_task(99, "x"); }), no_task);
  EXPECT_EQ(store_error_of([&] { s.release_task(99, "lost"); }), no_task);
  EXPECT_EQ(store_error_of([&] { s.log_event(0, 99, 0, "k", ""); }), no_task);
  EXPECT_EQ(store_error_of([&] { s.worker(99); }), no_worker);
  EXPECT_EQ(store_error_of([&] { s.claim_next(99); }), no_worker);
  EXPECT_EQ(store_error_of([&] { s.set_worker_state(99, "idle"); }), no_worker);
  EXPECT_EQ(store_error_of([&] { s.touch_worker(99); }), no_worker);
  EXPECT_EQ(store_error_of([&] { s.log_event(0, 0, 99, "k", ""); }), no_worker);
  EXPECT_EQ(store_error_of([&] { s.end_attempt(99, "lost"); }), path_ + ": no attempt 99");
}

// Flamenco's rules: a task that failed on a worker is not given to it again, fails for good after
// kMaxTaskWorkers workers (dependents blocked, job failed); requeue forgets the failures.
TEST_F(TaskStoreTest, AFailedAttemptIsRetriedOnOtherWorkersAndTheTaskFailsAfterThree) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(6, 2), {level_task(0, 0, 6), level_task(1, 0, 6, {{0, 0}})});
  const std::vector<TaskRow> t = s.tasks(job);
  std::vector<int64_t> w;
  for (int i = 0; i < 4; ++i) w.push_back(s.add_worker("w" + std::to_string(i), "host", "1.0", 1));
  ASSERT_EQ(kMaxTaskWorkers, 3);
  for (int i = 0; i < kMaxTaskWorkers; ++i) {
    // Every worker that failed it is passed over; the next one gets it.
    for (int j = 0; j < i; ++j) {
      EXPECT_FALSE(s.may_run(t[0].id, w[j])) << "worker " << j << " failed it";
      EXPECT_FALSE(s.claim_next(w[j]).has_value()) << "worker " << j << " failed it";
    }
    EXPECT_TRUE(s.may_run(t[0].id, w[i]));
    const Claim c = *s.claim_next(w[i]);
    ASSERT_EQ(c.task.id, t[0].id);
    const FailOutcome o = s.fail_attempt(t[0].id, c.attempt, "no safe upsampling");
    EXPECT_EQ(o.workers_failed, i + 1);
    EXPECT_EQ(o.task_failed, i + 1 == kMaxTaskWorkers);
    EXPECT_FALSE(o.worker_blocklisted);
    EXPECT_EQ(s.worker(w[i]).state, "idle");
  }
  EXPECT_EQ(states_of(s, job), "failed blocked");
  EXPECT_EQ(s.tasks(job)[0].attempts, 3);
  EXPECT_EQ(s.job(job).state, JobState::failed);
  EXPECT_EQ(s.job(job).reason, "task " + std::to_string(t[0].id) + " failed: no safe upsampling (failed on 3 workers)");
  EXPECT_FALSE(s.claim_next(w[3]).has_value());

  // Requeued: both tasks wait again (level 0 is ready at once), and the workers that failed it may
  // take it again.
  EXPECT_EQ(s.requeue_job(job), 2);
  EXPECT_EQ(states_of(s, job), "ready waiting");
  EXPECT_EQ(s.job(job).state, JobState::running);
  EXPECT_EQ(s.job(job).reason, "");
  EXPECT_EQ(s.job(job).finished, 0.0);
  EXPECT_TRUE(s.may_run(t[0].id, w[0]));
  EXPECT_EQ(s.claim_next(w[0])->task.id, t[0].id);
  EXPECT_EQ(store_error_of([&] { s.requeue_job(job); }),
            path_ + ": job " + std::to_string(job) + " is running, only a failed job can be requeued");
}

TEST_F(TaskStoreTest, AWorkerThatFailsThreeTasksOfAJobIsBlocklistedForThatJobOnly) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(8, 1), {level_task(0, 0, 2), level_task(0, 2, 4), level_task(0, 4, 6),
                                                  level_task(0, 6, 8)});
  const int64_t other = s.add_job(make_job(2, 1), {level_task(0, 0, 2)});
  // The tasks are independent here (no frame needs), so each is ready.
  const int64_t bad = s.add_worker("bad", "host", "1.0", 1), good = s.add_worker("good", "host", "1.0", 1);
  ASSERT_EQ(kBlocklistFailures, 3);
  for (int i = 0; i < kBlocklistFailures; ++i) {
    const Claim c = *s.claim_next(bad);
    EXPECT_EQ(c.task.job, job);
    const FailOutcome o = s.fail_attempt(c.task.id, c.attempt, "out of memory");
    EXPECT_EQ(o.worker_blocklisted, i + 1 == kBlocklistFailures) << i;
    EXPECT_FALSE(o.task_failed);
  }
  const int64_t last = s.tasks(job)[3].id;
  EXPECT_FALSE(s.may_run(last, bad));  // never tried it, but blocklisted for its job
  EXPECT_TRUE(s.may_run(last, good));
  const Claim c = *s.claim_next(bad);  // only the other job is left for it
  EXPECT_EQ(c.task.job, other);
  EXPECT_EQ(s.claim_next(good)->task.job, job);
}

// A refused vertical start (protocol::FailureKind::vertical_start_refused): the subset waits for its
// own level's frames a - 1 and a, then is ready again; the refusal counts against neither the task
// nor the worker, and only a vertically started subset can be turned.
TEST_F(TaskStoreTest, ARefusedVerticalStartWaitsForTheLevelsOwnFramesAndCountsAsNoFailure) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(6, 2), {level_task(0, 0, 6), level_task(1, 0, 3, {{0, 0}}),
                                                  level_task(1, 3, 6, {{0, 2}, {0, 3}})});
  const std::vector<TaskRow> t = s.tasks(job);
  for (int f = 0; f <= 3; ++f) s.record_frame(job, {0, f}, FrameData{});
  EXPECT_EQ(states_of(s, job), "ready ready ready");
  EXPECT_FALSE(s.continues_horizontally(t[2].id));
  // Claim order is level, then first frame: the third worker gets the subset (3, 6].
  ASSERT_EQ(s.claim_next(s.add_worker("w0", "host", "1.0", 1))->task.id, t[0].id);
  ASSERT_EQ(s.claim_next(s.add_worker("w1", "host", "1.0", 1))->task.id, t[1].id);
  const int64_t w = s.add_worker("w", "host", "1.0", 1);
  const Claim c = *s.claim_next(w);
  ASSERT_EQ(c.task.id, t[2].id);
  EXPECT_EQ(store_error_of([&] { s.continue_horizontally(t[2].id, c.attempt + 1, "m"); }),
            path_ + ": continue_horizontally: attempt " + std::to_string(c.attempt + 1) + " is not task " +
                std::to_string(t[2].id) + "'s running attempt");
  s.continue_horizontally(t[2].id, c.attempt, "safe upsampling: stretch 1.0523");
  EXPECT_TRUE(s.continues_horizontally(t[2].id));
  EXPECT_EQ(s.task(t[2].id).state, TaskState::waiting);
  EXPECT_EQ(s.task(t[2].id).reason, "continues horizontally: safe upsampling: stretch 1.0523");
  EXPECT_EQ(s.worker(w).state, "idle");
  EXPECT_TRUE(s.may_run(t[2].id, w));  // not a failure of this worker
  s.record_frame(job, {1, 2}, FrameData{});
  EXPECT_EQ(s.task(t[2].id).state, TaskState::waiting);  // frame 3 of level 1 still missing
  s.record_frame(job, {1, 3}, FrameData{});
  EXPECT_EQ(s.task(t[2].id).state, TaskState::ready);
  const Claim again = *s.claim_next(w);
  EXPECT_EQ(again.task.id, t[2].id);
  EXPECT_EQ(again.task.attempts, 2);
  EXPECT_EQ(s.fail_attempt(t[2].id, again.attempt, "later error").workers_failed, 1);  // the refusal did not count

  // The preview chunk (level 0) and a first subset (first 0) never start vertically.
  const int64_t other = s.add_job(make_job(4, 2), {level_task(1, 0, 4)});
  const Claim first = *s.claim_next(w);
  ASSERT_EQ(first.task.job, other);
  EXPECT_EQ(store_error_of([&] { s.continue_horizontally(first.task.id, first.attempt, "m"); }),
            path_ + ": continue_horizontally: task " + std::to_string(first.task.id) +
                " (level 1, first 0) does not start vertically");
}

// A refused vertical start whose seam moves: subset (3, 8] of level 1, refused at 3, becomes (5, 8],
// waiting for level 0's frames 4 and 5, and a bridge (3, 5] of level 1 continues horizontally from
// level 1's frames 2 and 3; the refusal counts against neither task nor worker.
TEST_F(TaskStoreTest, AMovedSeamShrinksTheSubsetAndAddsABridgeThatContinuesHorizontally) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(8, 2), {level_task(0, 0, 8), level_task(1, 0, 3, {{0, 0}}),
                                                  level_task(1, 3, 8, {{0, 2}, {0, 3}})});
  const std::vector<TaskRow> t = s.tasks(job);
  for (int f = 0; f <= 3; ++f) s.record_frame(job, {0, f}, FrameData{});
  s.claim_next(s.add_worker("w0", "host", "1.0", 1));
  s.claim_next(s.add_worker("w1", "host", "1.0", 1));
  const int64_t w = s.add_worker("w", "host", "1.0", 1);
  const Claim c = *s.claim_next(w);
  ASSERT_EQ(c.task.id, t[2].id);
  EXPECT_EQ(s.refused_starts(t[2].id), 0);
  const std::vector<FrameKey> needs = {{0, 4}, {0, 5}};  // farm::subset_needs(1, 5, 8)
  EXPECT_EQ(store_error_of([&] { s.move_seam(t[2].id, c.attempt, 8, needs, std::nullopt, "m"); }),
            path_ + ": move_seam: task " + std::to_string(t[2].id) + " (3, 8]: the new seam 8 is not inside it");
  const int64_t bridge = s.move_seam(t[2].id, c.attempt, 5, needs, std::nullopt, "no valid perturbation");
  EXPECT_EQ(s.refused_starts(t[2].id), 1);
  const TaskRow moved = s.task(t[2].id);
  EXPECT_EQ(moved.first, 5);
  EXPECT_EQ(moved.last, 8);
  EXPECT_EQ(moved.state, TaskState::waiting);
  EXPECT_EQ(moved.reason, "seam moved from 3 to 5: no valid perturbation");
  EXPECT_FALSE(s.continues_horizontally(t[2].id));
  const TaskRow b = s.task(bridge);
  EXPECT_EQ(b.level, 1);
  EXPECT_EQ(b.first, 3);
  EXPECT_EQ(b.last, 5);
  EXPECT_TRUE(s.continues_horizontally(bridge));
  EXPECT_EQ(s.worker(w).state, "idle");
  EXPECT_TRUE(s.may_run(t[2].id, w));
  s.record_frame(job, {0, 4}, FrameData{});
  EXPECT_EQ(s.task(t[2].id).state, TaskState::waiting);  // level 0's frame 5 still missing
  s.record_frame(job, {0, 5}, FrameData{});
  EXPECT_EQ(s.task(t[2].id).state, TaskState::ready);
  EXPECT_EQ(s.task(bridge).state, TaskState::waiting);  // level 1's frames 2 and 3 missing
  s.record_frame(job, {1, 2}, FrameData{});
  s.record_frame(job, {1, 3}, FrameData{});
  EXPECT_EQ(s.task(bridge).state, TaskState::ready);
  EXPECT_EQ(store_error_of([&] { s.move_seam(t[2].id, c.attempt, 6, needs, std::nullopt, "m"); }),
            path_ + ": move_seam: attempt " + std::to_string(c.attempt) + " is not task " + std::to_string(t[2].id) +
                "'s running attempt");
}

// A seam's stitch (farm/task_graph.h): subset (5, 10] of level 1 with guides 2, and its stitch task
// (5, 7] needing level 1's frames 4 and 5 and the guide frames 6 and 7.
NewTask stitch_of(int level, int seam, int last) {
  NewTask t = level_task(level, seam, last, {{level - 1, seam - 1}, {level - 1, seam}, {level, seam - 1}, {level, seam}});
  t.stitch = true;
  for (int f = seam + 1; f <= last; ++f) t.guide_needs.push_back({level, f});
  return t;
}
std::vector<NewTask> stitched_job_tasks() {
  NewTask later = level_task(1, 5, 10, {{0, 4}, {0, 5}});
  later.guides = 2;
  return {level_task(0, 0, 10), level_task(1, 0, 5, {{0, 0}}), later, stitch_of(1, 5, 7)};
}

// Level 0's frames 0..5 stored and the first two tasks claimed: the later subset's claim (its
// vertical start).
Claim claim_later_subset(TaskStore& s, int64_t job) {
  for (int f = 0; f <= 5; ++f) s.record_frame(job, {0, f}, FrameData{});
  s.claim_next(s.add_worker("w0", "host", "1.0", 1));
  s.claim_next(s.add_worker("w1", "host", "1.0", 1));
  return *s.claim_next(s.add_worker("w", "host", "1.0", 1));
}

TEST_F(TaskStoreTest, AStitchTaskWaitsForItsGuideFramesWhichAreNotTheJobsFrames) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(10, 2), stitched_job_tasks());
  const std::vector<TaskRow> t = s.tasks(job);
  ASSERT_EQ(t.size(), 4u);
  EXPECT_EQ(t[2].guides, 2);
  EXPECT_FALSE(t[2].stitch);
  EXPECT_TRUE(t[3].stitch);
  EXPECT_EQ(t[3].first, 5);
  EXPECT_EQ(t[3].last, 7);
  for (int f = 0; f <= 7; ++f) s.record_frame(job, {0, f}, FrameData{});
  s.record_frame(job, {1, 4}, FrameData{});
  s.record_frame(job, {1, 5}, FrameData{});
  EXPECT_EQ(s.task(t[3].id).state, TaskState::waiting);
  s.record_frame(job, {1, 6}, FrameData{});  // a frame of the job is not the guide frame it waits for
  s.record_frame(job, {1, 7}, FrameData{});
  EXPECT_EQ(s.task(t[3].id).state, TaskState::waiting);
  const std::vector<double> six = {0.1, -0.0, std::numeric_limits<double>::denorm_min()};
  s.record_guide_frame(job, {1, 6}, six);
  EXPECT_EQ(s.task(t[3].id).state, TaskState::waiting);
  s.record_guide_frame(job, {1, 7}, {7.0, 7.0, 7.0});
  EXPECT_EQ(s.task(t[3].id).state, TaskState::ready);
  const std::optional<std::vector<double>> back = s.guide_frame(job, {1, 6});
  ASSERT_TRUE(back.has_value());
  ASSERT_EQ(back->size(), six.size());
  EXPECT_EQ(std::memcmp(back->data(), six.data(), sizeof(double) * six.size()), 0);
  EXPECT_FALSE(s.guide_frame(job, {1, 8}).has_value());
  EXPECT_EQ(s.stored_guide_frames(job, 1, 0, 10), (std::vector<int>{6, 7}));
  EXPECT_EQ(s.frames_stored(job)[1], 4);  // guide frames are not counted among the job's
  EXPECT_EQ(store_error_of([&] { s.record_guide_frame(job, {1, 11}, {}); }),
            path_ + ": record_guide_frame: job " + std::to_string(job) + ": frame 11 outside 0..10");
}

TEST_F(TaskStoreTest, ASubsetThatContinuesHorizontallyHasNoSeamSoItsStitchTaskIsRemoved) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(10, 2), stitched_job_tasks());
  const std::vector<TaskRow> t = s.tasks(job);
  const Claim c = claim_later_subset(s, job);
  ASSERT_EQ(c.task.id, t[2].id);
  s.continue_horizontally(t[2].id, c.attempt, "no valid perturbation");
  const std::vector<TaskRow> after = s.tasks(job);
  ASSERT_EQ(after.size(), 3u);
  for (const TaskRow& r : after) EXPECT_FALSE(r.stitch);
  EXPECT_EQ(s.task(t[2].id).guides, 0);
  EXPECT_EQ(raw_value(path_, "SELECT COUNT(*) FROM task_frames WHERE task_id = ?1", t[3].id), "0");
}

TEST_F(TaskStoreTest, AMovedSeamTakesItsStitchTaskToTheNewSeam) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(10, 2), stitched_job_tasks());
  const std::vector<TaskRow> t = s.tasks(job);
  const Claim c = claim_later_subset(s, job);
  ASSERT_EQ(c.task.id, t[2].id);
  NewTask wrong = stitch_of(1, 6, 8);
  EXPECT_EQ(store_error_of([&] { s.move_seam(t[2].id, c.attempt, 7, {{0, 6}, {0, 7}}, wrong, "m"); }),
            path_ + ": move_seam: task " + std::to_string(t[2].id) + ": the stitch given is not one for level 1 at the new seam 7");
  s.move_seam(t[2].id, c.attempt, 7, {{0, 6}, {0, 7}}, stitch_of(1, 7, 9), "m");
  std::vector<TaskRow> stitches;
  for (const TaskRow& r : s.tasks(job))
    if (r.stitch) stitches.push_back(r);
  ASSERT_EQ(stitches.size(), 1u);
  EXPECT_EQ(stitches[0].first, 7);
  EXPECT_EQ(stitches[0].last, 9);
  EXPECT_EQ(s.task(t[2].id).first, 7);
  EXPECT_EQ(s.task(t[2].id).guides, 2);
  EXPECT_EQ(s.tasks(job).size(), 5u);  // the subset's bridge (5, 7] and the new stitch, the old one gone
}

TEST_F(TaskStoreTest, AVersionTwoStoreIsUpgradedInPlaceAndKeepsItsJobs) {
  int64_t job = 0;
  {
    TaskStore s(path_);
    job = s.add_job(make_job(4, 2), {level_task(0, 0, 4)});
  }
  // What a version-2 store is: no stitch columns, no guide frames.
  for (const char* sql : {"ALTER TABLE jobs DROP COLUMN stitch", "ALTER TABLE jobs DROP COLUMN seams",
                          "ALTER TABLE tasks DROP COLUMN stitch",
                          "ALTER TABLE tasks DROP COLUMN guides", "ALTER TABLE task_frames DROP COLUMN guide",
                          "DROP TABLE guide_frames", "PRAGMA user_version = 2"})
    raw_value(path_, sql);
  ASSERT_EQ(raw_value(path_, "PRAGMA user_version"), "2");
  TaskStore s(path_);
  EXPECT_EQ(raw_value(path_, "PRAGMA user_version"), std::to_string(kTaskStoreSchemaVersion));
  EXPECT_EQ(s.job(job).spec.frames, 4);
  EXPECT_EQ(s.job(job).spec.stitch, 0);
  EXPECT_TRUE(s.job(job).seams.empty());
  EXPECT_EQ(s.tasks(job).size(), 1u);
  s.set_seams(job, {"frame 2, the even split", "caf\xc3\xa9"});
  EXPECT_EQ(s.job(job).seams, (std::vector<std::string>{"frame 2, the even split", "caf\xc3\xa9"}));
  NewJob stitched = make_job(10, 2);
  stitched.stitch = 16;
  EXPECT_EQ(s.job(s.add_job(stitched, stitched_job_tasks())).spec.stitch, 16);
}

TEST_F(TaskStoreTest, FailAttemptRefusesAnAttemptThatIsNotTheTasksRunningOne) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(2, 1), {level_task(0, 0, 2)});
  const int64_t w = s.add_worker("w", "host", "1.0", 1);
  const Claim c = *s.claim_next(w);
  s.release_task(c.task.id, "lost");
  const Claim again = *s.claim_next(w);
  EXPECT_EQ(store_error_of([&] { s.fail_attempt(c.task.id, c.attempt, "late"); }),
            path_ + ": fail_attempt: attempt " + std::to_string(c.attempt) + " is not task " +
                std::to_string(c.task.id) + "'s running attempt");
  EXPECT_EQ(s.fail_attempt(again.task.id, again.attempt, "now").workers_failed, 1);
  (void)job;
}

TEST_F(TaskStoreTest, FrameDataAndTheHierarchyRoundTripBitForBit) {
  TaskStore s(path_);
  const int64_t job = s.add_job(make_job(4, 2), {level_task(0, 0, 4)});
  FrameData d;
  d.positions = {0.0, -0.0, 1e-310, std::numeric_limits<double>::max(), -1.5, 3.25};
  d.stats = {{"newton_iterations", 7.0}, {"min_contact_distance", std::numeric_limits<double>::infinity()},
             {"energy_bending", std::numeric_limits<double>::quiet_NaN()}};
  d.center_of_mass = {0.5, 0.25, -0.125};
  d.kappa = 1.25e9;
  s.record_frame(job, {1, 3}, d);
  s.record_frame(job, {0, 2}, FrameData{});
  const std::optional<FrameData> got = s.frame_data(job, {1, 3});
  ASSERT_TRUE(got.has_value());
  ASSERT_EQ(got->positions.size(), d.positions.size());
  EXPECT_EQ(std::memcmp(got->positions.data(), d.positions.data(), sizeof(double) * d.positions.size()), 0);
  ASSERT_EQ(got->stats.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(got->stats[i].first, d.stats[i].first);
    EXPECT_EQ(std::memcmp(&got->stats[i].second, &d.stats[i].second, sizeof(double)), 0) << d.stats[i].first;
  }
  EXPECT_EQ(got->center_of_mass, d.center_of_mass);
  EXPECT_EQ(got->kappa, d.kappa);
  const std::optional<FrameData> empty = s.frame_data(job, {0, 2});
  ASSERT_TRUE(empty.has_value());
  EXPECT_TRUE(empty->positions.empty() && empty->stats.empty() && empty->center_of_mass.empty() && !empty->kappa);
  EXPECT_FALSE(s.frame_data(job, {0, 3}).has_value());
  const std::vector<FrameKey> keys = s.frame_keys(job);
  ASSERT_EQ(keys.size(), 2u);
  EXPECT_EQ(join(keys[0].level, keys[0].frame, keys[1].level, keys[1].frame), join(0, 2, 1, 3));

  const std::string blob("\x89HDF\r\n\x1a\n\0\0\xff", 11);
  s.store_hierarchy(job, "9f86", blob);
  EXPECT_EQ(s.hierarchy_blob(job), blob);
  EXPECT_EQ(s.job(job).hierarchy_hash, "9f86");
  EXPECT_EQ(store_error_of([&] { s.hierarchy_blob(job + 1); }),
            path_ + ": job " + std::to_string(job + 1) + " has no stored hierarchy");
}

TEST_F(TaskStoreTest, RecoveryAfterARestartReleasesRunningTasksAndLosesEveryWorker) {
  int64_t job = 0, running = 0, attempt = 0;
  {
    TaskStore s(path_);
    job = s.add_job(make_job(4, 1), {level_task(0, 0, 2), level_task(0, 2, 4)});
    const int64_t w = s.add_worker("w", "host", "1.0", 1);
    s.finish_task(s.claim_next(w)->task.id);
    const Claim c = *s.claim_next(w);
    running = c.task.id;
    attempt = c.attempt;
  }  // the scheduler dies with the attempt running
  TaskStore s(path_);
  const std::vector<TaskRow> released = s.recover_after_restart();
  ASSERT_EQ(released.size(), 1u);
  EXPECT_EQ(released[0].id, running);
  EXPECT_EQ(released[0].attempt, attempt);
  EXPECT_EQ(states_of(s, job), "done ready");
  EXPECT_EQ(raw_value(path_, "SELECT outcome FROM attempts WHERE id = ?1", attempt), "scheduler restarted");
  EXPECT_EQ(s.workers()[0].state, "lost");
  EXPECT_EQ(s.job(job).state, JobState::running);
  EXPECT_TRUE(s.recover_after_restart().empty());
}

}  // namespace
}  // namespace pd
