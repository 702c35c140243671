// What a frame file holds after its writer is killed (SIGKILL) at a random moment, and whether a
// killed or living process keeps the file from being opened. The farm's scheduler is the only writer
// of a job's file and reopens it after a restart (FrameWriter::open); the task store (SQLite) keeps
// every frame's data, so a file that does not open is rebuilt from it.
//
// Asserted for every kill: no crash (the files are opened in a child process, so a crash shows as a
// signal), every frame whose write_frame returned is done, no frame never written is done, and a
// file that FrameWriter::open accepts, with its done frames intact, can be written on to the end of
// the job and then holds exactly what an uninterrupted run leaves.
// Measured, not asserted: how often a file does not open (InputError), and how often a done frame
// reads back wrong without any error. HDF5 1.10.8 updates its metadata (here: the chunk index of
// positions, groups gaining a statistic) in place, and a kill inside a flush can tear it: measured,
// about one kill in 700 inside write_frame left a done frame reading NaN. No write order prevents
// that, so the scheduler compares a reopened file's done frames with its task store (read_frame,
// read_stats) and rebuilds the file on a difference. Asserted: only a kill inside write_frame does it.
//
// Forked processes: the writer (killed), a checker per kill, and, in the lock test, holders of the file.
#include "store/frame_store.h"
#include "support/strip_mesh.h"
#include "support/input_error_of.h"
#include "support/test_paths.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <hdf5.h>  // H5get_libversion, for the printed figures

namespace pd {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using test::input_error_of;

// ---------------------------------------------------------------------------------------------------
// The job the writer runs: everything is a function of (level, frame t, pass), pass = how many times
// the frame was written before, so the checker knows what each frame must hold.

constexpr int kLastFrame = 69;           // frames 0..69 on each level
constexpr int kVertices[2] = {32, 128};  // per level (strips of n/2 x 2 vertices)

struct Op {
  int level, t, pass;
};

// Level 0's frames in order, level 1's at every fourth step, and overwrites of earlier frames of
// both (frame (0, 0) four times). Level 0 gets 70 frames, more than the 64 chunks a node of HDF5's
// chunk index holds, so that the index of its positions splits during the run.
const std::vector<Op>& write_ops() {
  static const std::vector<Op> ops = [] {
    std::vector<Op> out;
    std::map<std::pair<int, int>, int> passes;
    auto add = [&](int l, int t) { out.push_back({l, t, passes[{l, t}]++}); };
    for (int t = 0; t <= kLastFrame; ++t) {
      add(0, t);
      if (t % 4 == 0) add(1, t / 4);
      if (t % 3 == 2) add(0, t - 2);
      if (t % 10 == 9) add(1, t / 8);
      if (t % 25 == 24) add(0, 0);
    }
    return out;
  }();
  return ops;
}

uint64_t mix(uint64_t z) {  // splitmix64's finaliser
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// A double in [-2, 2) determined by its arguments.
double value(int level, int t, int pass, int i) {
  const uint64_t h = mix(mix(mix(static_cast<uint64_t>(level) * 1000003u + static_cast<uint64_t>(t + 1)) +
                             static_cast<uint64_t>(pass)) + static_cast<uint64_t>(i));
  return static_cast<double>(h >> 11) * 0x1.0p-51 - 2.0;
}

Positions frame_positions(int level, int t, int pass) {
  Positions X(kVertices[level], 3);
  for (Eigen::Index i = 0; i < X.size(); ++i) X.data()[i] = value(level, t, pass, static_cast<int>(i));
  return X;
}

// Stat names appear at different frames (each creates its dataset when first written), sorted by
// name as read_stats returns them; center_of_mass is left out on every fourth frame.
FrameStats frame_stats(int level, int t, int pass) {
  FrameStats s;
  auto add = [&](const char* name, bool present, int k) {
    if (present) s.scalars.emplace_back(name, value(level, t, pass, 100000 + k));
  };
  add("energy_contact", level == 1 && t >= 5, 0);
  add("kinetic_energy", t >= 2, 1);
  add("max_stretch", t >= 8, 2);
  add("newton_iterations", true, 3);
  add("solve_seconds", pass >= 1, 4);  // first written by the first overwrite
  if (t % 4 != 1) {
    s.center_of_mass.resize(level == 0 ? 1 : 2, 3);  // one object on level 0, two on level 1
    for (Eigen::Index i = 0; i < s.center_of_mass.size(); ++i)
      s.center_of_mass.data()[i] = value(level, t, pass, 200000 + static_cast<int>(i));
  }
  return s;
}

using test::strip_faces;

void add_level(FrameWriter& w, int l) {
  const int n = kVertices[l];
  const std::vector<int> offsets = l == 0 ? std::vector<int>{0, n} : std::vector<int>{0, 48, n};
  const std::vector<std::string> names = l == 0 ? std::vector<std::string>{"cloth"}
                                                : std::vector<std::string>{"cloth", "flag"};
  w.add_level(l, frame_positions(l, -1, 0), strip_faces(n / 2), offsets, names);
}

// n == 0 first: memcmp with the null data() of an empty matrix is undefined (UBSan reports it).
bool same_bits(const double* a, const double* b, Eigen::Index n) {
  return n == 0 || std::memcmp(a, b, sizeof(double) * static_cast<size_t>(n)) == 0;
}

// What differs between the frame read (X, S) and write `pass` of it, in words.
std::string difference(const Positions& X, const FrameStats& S, int level, int t, int pass) {
  const Positions want = frame_positions(level, t, pass);
  if (X.rows() != want.rows() || !same_bits(X.data(), want.data(), X.size()))
    return "positions (" + std::to_string(X.array().isNaN().count()) + " of " + std::to_string(X.size()) + " NaN)";
  std::string got = "scalars", wanted;
  for (const auto& [name, v] : S.scalars) got += " " + name + "=" + std::to_string(v);
  for (const auto& [name, v] : frame_stats(level, t, pass).scalars) wanted += " " + name + "=" + std::to_string(v);
  return got + " instead of" + wanted + " (or center_of_mass)";
}

bool same_stats(const FrameStats& a, const FrameStats& b) {
  if (a.scalars.size() != b.scalars.size() || a.center_of_mass.rows() != b.center_of_mass.rows()) return false;
  for (size_t i = 0; i < a.scalars.size(); ++i)
    if (a.scalars[i].first != b.scalars[i].first || !same_bits(&a.scalars[i].second, &b.scalars[i].second, 1))
      return false;
  return same_bits(a.center_of_mass.data(), b.center_of_mass.data(), a.center_of_mass.size());
}

// Memory the forked processes share with this one (nullptr if mmap fails).
void* shared_memory(size_t bytes) {
  void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  return p == MAP_FAILED ? nullptr : p;
}

// ---------------------------------------------------------------------------------------------------
// The writer, killed. Progress lives in shared memory (MAP_SHARED), written before and after every
// write_frame, so the parent knows after the kill which writes had begun and which had returned.
// The SIGKILL comes from a timer the writer arms itself (CLOCK_MONOTONIC, microsecond resolution), at
// a delay the parent draws: a kill sent by the parent would land late by however long the parent
// took to see the writer's progress and to be scheduled, which is most of a loop that lasts 1 ms.

enum Phase : int { kSetup, kWriting, kClosed };

struct Progress {
  std::atomic<int> phase{kSetup};
  std::atomic<int> begun{0};     // ops whose write_frame was called
  std::atomic<int> returned{0};  // ops whose write_frame returned
  std::atomic<long long> setup_ns{0}, loop_ns{0};  // durations of the setup and of the frame loop, ns
  int kill_in = -1;             // the phase in which the timer is armed (-1: no timer)
  long long kill_after_ns = 0;  // the timer's delay from the start of that phase
};

long long since_ns(Clock::time_point start) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - start).count();
}

// Sends SIGKILL to this process `ns` nanoseconds from now.
void arm_kill_timer(long long ns) {
  sigevent ev{};
  ev.sigev_notify = SIGEV_SIGNAL;
  ev.sigev_signo = SIGKILL;
  timer_t id;
  if (timer_create(CLOCK_MONOTONIC, &ev, &id) != 0) _exit(5);
  itimerspec when{};
  ns = std::max(ns, 1LL);  // 0 would disarm
  when.it_value.tv_sec = static_cast<time_t>(ns / 1000000000);
  when.it_value.tv_nsec = static_cast<long>(ns % 1000000000);
  if (timer_settime(id, 0, &when, nullptr) != 0) _exit(5);
}

[[noreturn]] void run_writer(const std::string& path, Progress* p) {
  try {
    const auto start = Clock::now();
    if (p->kill_in == kSetup) arm_kill_timer(p->kill_after_ns);
    FrameWriter w = FrameWriter::create(path, "{\"job\": \"kill test\"}", kLastFrame);
    add_level(w, 0);
    add_level(w, 1);
    p->setup_ns = since_ns(start);
    const auto loop_start = Clock::now();
    if (p->kill_in == kWriting) arm_kill_timer(p->kill_after_ns);
    p->phase = kWriting;
    const std::vector<Op>& ops = write_ops();
    for (size_t i = 0; i < ops.size(); ++i) {
      const Op& op = ops[i];
      p->begun = static_cast<int>(i + 1);
      w.write_frame(op.level, op.t, frame_positions(op.level, op.t, op.pass), frame_stats(op.level, op.t, op.pass));
      p->returned = static_cast<int>(i + 1);
    }
    p->loop_ns = since_ns(loop_start);
    w.close();
    p->phase = kClosed;
  } catch (...) {
    _exit(3);
  }
  for (;;) pause();  // until killed
}

// ---------------------------------------------------------------------------------------------------
// The checker, in its own process: what FrameReader and FrameWriter::open make of the file.

struct Check {
  int reader_opened = 0, writer_opened = 0, resumed = 0;  // 1: yes
  int reader_levels = 0;  // levels FrameReader found
  int compared = 0;  // frames compared bit for bit with the content they must hold
  int problems = 0;  // rules broken: returned but not done, done but never written, wrong after resuming
  // Done frames whose content is that of no write (HDF5 damaged them: see the test), as FrameReader
  // and as FrameWriter::open see them. A scheduler that compares the frames of a reopened file with
  // its task store finds them and rebuilds the file: the checker then does not resume.
  int reader_damaged = 0, writer_damaged = 0;
  char reader_error[240] = "", writer_error[240] = "", first_problem[240] = "", first_damage[240] = "";
};

void copy_text(char (&to)[240], const std::string& from) { std::snprintf(to, sizeof to, "%s", from.c_str()); }

// For each frame (index level * frames + t): the pass of the last write that began (-1: none) and
// whether that write had not returned when the writer was killed.
struct Expected {
  std::vector<int> pass;
  std::vector<bool> in_flight;
};

Expected expected_frames(int begun, int returned) {
  const int frames = kLastFrame + 1;
  Expected e{std::vector<int>(2 * frames, -1), std::vector<bool>(2 * frames, false)};
  for (int i = 0; i < begun; ++i) {
    const Op& op = write_ops()[i];
    e.pass[op.level * frames + op.t] = op.pass;
    e.in_flight[op.level * frames + op.t] = i >= returned;
  }
  return e;
}

// Checks one frame: `done` as the file says, and (if done) its content read through `read`. Returns
// the pass whose content it holds (-1 if not done).
template <typename Read>
int check_frame(Check& c, int* damaged, const Expected& e, int level, int t, bool done, Read&& read,
                const char* who) {
  const int i = level * (kLastFrame + 1) + t, pass = e.pass[i];
  const std::string where = std::string(who) + ": level " + std::to_string(level) + " frame " + std::to_string(t);
  auto problem = [&](const std::string& what) {
    if (c.problems++ == 0) copy_text(c.first_problem, where + ": " + what);
    return -1;
  };
  if (!done) {
    if (pass >= 0 && !e.in_flight[i]) return problem("write_frame returned but the frame is not done");
    return -1;
  }
  if (pass < 0) return problem("done but never written");
  Positions X;
  FrameStats S;
  read(X, S);
  ++c.compared;
  for (int p : {pass, pass - 1}) {
    if (p < 0 || (p == pass - 1 && !e.in_flight[i])) continue;  // the older content only mid-overwrite
    const Positions want = frame_positions(level, t, p);
    const bool same_x = X.rows() == want.rows() && same_bits(X.data(), want.data(), X.size());
    if (same_x && same_stats(S, frame_stats(level, t, p))) return p;
  }
  if ((*damaged)++ == 0 && c.first_damage[0] == '\0')
    copy_text(c.first_damage, where + ": done, but differs from write " + std::to_string(pass) + ": " +
                                  difference(X, S, level, t, pass));
  return -1;
}

// The FrameReader view of a frame's stats, in read_stats' form.
FrameStats reader_stats(const FrameReader& r, int level, int t) {
  FrameStats s;
  for (const std::string& name : r.stat_names(level)) {
    const double v = r.stat(level, name)[t];
    if (!std::isnan(v)) s.scalars.emplace_back(name, v);
  }
  s.center_of_mass = r.center_of_mass(level, t);
  if (s.center_of_mass.array().isNaN().all()) s.center_of_mass.resize(0, 3);
  return s;
}

// Checks every frame through a FrameReader: counts into c (damage into *damaged); returns the number of
// levels (-1 if an InputError came, its text in `error`).
int check_with_reader(Check& c, int* damaged, const std::string& path, const Expected& e, const char* who,
                      char (&error)[240]) {
  try {
    FrameReader r(path);
    for (int l = 0; l < r.num_levels(); ++l) {
      const std::vector<uint8_t> done = r.done(l);
      for (int t = 0; t <= kLastFrame; ++t)
        check_frame(c, damaged, e, l, t, done[t] == 1, [&](Positions& X, FrameStats& S) {
          X = r.frame(l, t);
          S = reader_stats(r, l, t);
        }, who);
    }
    return r.num_levels();
  } catch (const InputError& err) {
    copy_text(error, err.what());
    return -1;
  }
}

// Opens for writing, checks every frame, then resumes the job as a restarted scheduler would: adds a
// level the killed writer did not get to, redoes the write that had not returned and the rest; closes
// and checks with a reader that the file holds what an uninterrupted run leaves.
void check_with_writer(Check& c, const std::string& path, const Expected& e, int returned) {
  const std::vector<Op>& ops = write_ops();
  try {
    FrameWriter w = FrameWriter::open(path);
    c.writer_opened = 1;
    for (int l = 0; l < w.num_levels(); ++l)
      for (int t = 0; t <= kLastFrame; ++t)
        check_frame(c, &c.writer_damaged, e, l, t, w.is_done(l, t), [&](Positions& X, FrameStats& S) {
          X = w.read_frame(l, t);
          S = w.read_stats(l, t);
        }, "FrameWriter::open");
    if (c.writer_damaged > 0) return;  // to be rebuilt
    for (int l = w.num_levels(); l < 2; ++l) add_level(w, l);  // killed between two add_level calls
    for (size_t i = static_cast<size_t>(returned); i < ops.size(); ++i)
      w.write_frame(ops[i].level, ops[i].t, frame_positions(ops[i].level, ops[i].t, ops[i].pass),
                    frame_stats(ops[i].level, ops[i].t, ops[i].pass));
    w.close();
  } catch (const InputError& err) {
    copy_text(c.writer_error, err.what());
    return;
  }
  const int total = static_cast<int>(ops.size());
  const Expected all = expected_frames(total, total);
  Check after;
  int after_damaged = 0;
  if (check_with_reader(after, &after_damaged, path, all, "after resuming", after.first_problem) < 0) ++after.problems;
  int written = 0;  // frames the whole job writes
  for (int p : all.pass) written += p >= 0;
  if (after_damaged > 0 && after.problems++ == 0) copy_text(after.first_problem, after.first_damage);
  c.resumed = after.problems == 0 && after.compared == written;
  c.compared += after.compared;
  if (after.problems > 0 && c.problems++ == 0) copy_text(c.first_problem, after.first_problem);
}

// Waits up to 20 s for the child to end; kills it if it does not. Returns its wait status.
int reap(pid_t pid) {
  int status = 0;
  for (auto end = Clock::now() + std::chrono::seconds(20); Clock::now() < end;) {
    if (waitpid(pid, &status, WNOHANG) == pid) return status;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return -1;
}

// Runs the checker in a child process; false (and `crash` says why) if it died of a signal, failed or
// hung (20 s).
bool run_checker(const std::string& path, int begun, int returned, Check* out, std::string* crash) {
  auto* shared = static_cast<Check*>(shared_memory(sizeof(Check)));
  if (shared == nullptr) {
    *crash = "mmap failed";
    return false;
  }
  new (shared) Check();
  const pid_t pid = fork();
  if (pid == 0) {
    try {
      const Expected e = expected_frames(begun, returned);
      shared->reader_levels = check_with_reader(*shared, &shared->reader_damaged, path, e, "FrameReader",
                                                shared->reader_error);
      shared->reader_opened = shared->reader_levels >= 0;
      check_with_writer(*shared, path, e, returned);
    } catch (...) {
      _exit(4);  // anything but InputError
    }
    _exit(0);
  }
  const int status = pid > 0 ? reap(pid) : 0;
  if (pid < 0) {
    *crash = "fork failed";
  } else if (status == -1) {
    *crash = "checker hung (killed after 20 s)";
  } else if (WIFSIGNALED(status)) {
    *crash = "checker died of signal " + std::to_string(WTERMSIG(status));
  } else if (WEXITSTATUS(status) != 0) {
    *crash = "checker exited with " + std::to_string(WEXITSTATUS(status)) + " (an exception other than InputError)";
  }
  *out = *shared;
  munmap(shared, sizeof(Check));
  return crash->empty();
}

// Starts the writer on `path` with its kill timer armed in phase `kill_in` (-1: none); progress must
// be in shared memory.
pid_t start_writer(const std::string& path, Progress* progress, int kill_in, double kill_after_ms) {
  new (progress) Progress();
  progress->kill_in = kill_in;
  progress->kill_after_ns = static_cast<long long>(kill_after_ms * 1e6);
  const pid_t pid = fork();
  if (pid == 0) run_writer(path, progress);
  return pid;
}

// `text` with every run of digits replaced by "#", so that messages differing only in sizes count as one.
std::string without_numbers(const std::string& text) {
  std::string out;
  for (char ch : text) {
    if (!std::isdigit(static_cast<unsigned char>(ch))) {
      out += ch;
    } else if (out.empty() || out.back() != '#') {
      out += '#';
    }
  }
  return out;
}

// What the kills of one medium gave.
struct Counts {
  double setup_ms = 0, loop_ms = 0;  // of one uninterrupted run: create + add_level, the frame loop
  int kills = 0, in_setup = 0, in_write = 0, between = 0, after_close = 0;
  int reader_opened = 0, writer_opened = 0, resumed = 0, compared = 0, problems = 0;
  int unreadable_in_loop = 0, refused_in_loop = 0;  // after kills in the frame loop: FrameReader, FrameWriter::open
  int damaged_frames = 0, damaged_files = 0;  // as FrameReader sees them
  std::map<std::string, int> errors;  // InputError texts without the path and numbers, counted
  std::string damage;                 // the first damaged frame, in words
};

// Kills the writer `kills` times and checks each file it leaves in `dir`. One kill in five comes at a
// delay drawn from `rng` over the setup (create, add_level); the others at a delay from the start of
// the frame loop drawn over the loop and 5 % beyond (close, then idle). The durations come from one
// uninterrupted run first.
void measure_kills(const std::string& dir, int kills, std::mt19937& rng, Counts* out) {
  Counts& n = *out;
  const std::string path = dir + "/job.h5";
  auto* progress = static_cast<Progress*>(shared_memory(sizeof(Progress)));
  ASSERT_NE(progress, nullptr);
  fs::remove(path);
  pid_t pid = start_writer(path, progress, -1, 0);
  ASSERT_GT(pid, 0);
  for (auto end = Clock::now() + std::chrono::seconds(20); progress->phase != kClosed && Clock::now() < end;)
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  ASSERT_EQ(progress->phase.load(), kClosed) << "the writer did not finish in 20 s";
  ASSERT_EQ(progress->returned.load(), static_cast<int>(write_ops().size()));
  n.setup_ms = progress->setup_ns * 1e-6;
  n.loop_ms = progress->loop_ns * 1e-6;

  // The latest durations seen: on a disk they vary from run to run (fsync), so each run that gets
  // through a phase updates its estimate.
  double setup_ms = n.setup_ms, loop_ms = n.loop_ms;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < kills; ++k) {
    fs::remove(path);
    const bool in_setup = k % 5 == 0;
    const double delay_ms = in_setup ? u(rng) * setup_ms : u(rng) * 1.05 * loop_ms;
    pid = start_writer(path, progress, in_setup ? kSetup : kWriting, delay_ms);
    ASSERT_GT(pid, 0);
    const int status = reap(pid);
    ASSERT_TRUE(status != -1 && WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
        << "kill " << k << ": the writer failed or its timer did not fire (status " << status << ")";
    const int begun = progress->begun, returned = progress->returned, phase = progress->phase;
    if (progress->setup_ns > 0) setup_ms = progress->setup_ns * 1e-6;
    if (progress->loop_ns > 0) loop_ms = progress->loop_ns * 1e-6;
    (phase == kSetup ? n.in_setup : phase == kClosed ? n.after_close : begun > returned ? n.in_write : n.between)++;

    Check c;
    std::string crash;
    ASSERT_TRUE(run_checker(path, begun, returned, &c, &crash)) << "kill " << k << ": " << crash;
    ++n.kills;
    n.reader_opened += c.reader_opened;
    n.writer_opened += c.writer_opened;
    n.resumed += c.resumed;
    n.compared += c.compared;
    n.problems += c.problems;
    EXPECT_EQ(c.problems, 0) << "kill " << k << " (phase " << phase << ", " << returned << " of " << begun
                             << " writes returned): " << c.first_problem;
    if (c.writer_opened && c.writer_damaged == 0) {
      EXPECT_EQ(c.resumed, 1) << "kill " << k << ": " << c.first_problem;
    }
    // Damage is measured, not ruled out (see the test); but only a kill inside write_frame, in one of
    // its flushes, may cause it.
    n.damaged_frames += c.reader_damaged;
    n.damaged_files += c.reader_damaged > 0 || c.writer_damaged > 0;
    if (n.damage.empty()) n.damage = c.first_damage;
    const bool inside_write = phase == kWriting && begun > returned;
    if (!inside_write) {
      EXPECT_EQ(c.reader_damaged + c.writer_damaged, 0) << "kill " << k << ": " << c.first_damage;
    }
    for (const char* e : {c.reader_error, c.writer_error})
      if (e[0] != '\0') ++n.errors[without_numbers(std::string(e).substr(path.size()))];
    // Counted, not asserted: a file that does not open is rebuilt from the task store.
    if (phase != kSetup) {
      n.unreadable_in_loop += !c.reader_opened;
      n.refused_in_loop += c.reader_opened && !c.writer_opened;
      if (c.reader_opened) {
        EXPECT_EQ(c.reader_levels, 2) << "kill " << k;
      }
    }
  }
  munmap(progress, sizeof(Progress));
}

void print_counts(const char* medium, const Counts& n) {
  std::printf("[kill test] %s: setup %.1f ms, frame loop %.1f ms; %d kills: %d in setup, %d inside write_frame, %d "
              "between writes, %d after close\n",
              medium, n.setup_ms, n.loop_ms, n.kills, n.in_setup, n.in_write, n.between, n.after_close);
  std::printf("[kill test] %s: FrameReader opened %d/%d, FrameWriter::open opened %d/%d, resumed %d; after a kill in "
              "the frame loop: unreadable %d, readable but refused by FrameWriter::open %d; frames compared %d, "
              "problems %d; damaged done frames %d in %d files\n",
              medium, n.reader_opened, n.kills, n.writer_opened, n.kills, n.resumed, n.unreadable_in_loop,
              n.refused_in_loop, n.compared, n.problems, n.damaged_frames, n.damaged_files);
  if (!n.damage.empty()) std::printf("[kill test] %s: first damage: %s\n", medium, n.damage.c_str());
  for (const auto& [what, count] : n.errors)
    std::printf("[kill test] %s: %dx <path>%s\n", medium, count, what.c_str());
}

// Two media: the scratch folder (a disk: every flush's fsync takes milliseconds, so most kills land in
// fsync) and /dev/shm (tmpfs: fsync is free, so the kills land among HDF5's own writes inside H5Fflush
// and between them). A killed process loses nothing the kernel has accepted, so the medium changes
// where the kills land, not what they can do.
TEST(FrameStoreKillTest, WriterKilledAtRandomMomentsKeepsDoneFramesOrFailsToOpen) {
  std::mt19937 rng(20240611);
  const std::string disk = test::scratch_dir("frame_kill");
  Counts on_disk, in_memory;
  measure_kills(disk, 12, rng, &on_disk);
  fs::remove_all(disk);
  std::error_code ec;
  const bool shm = fs::is_directory("/dev/shm", ec) && access("/dev/shm", W_OK) == 0;
  const std::string memory =
      shm ? "/dev/shm/pd_frame_kill_" + std::to_string(getpid()) : test::scratch_dir("frame_kill");
  fs::create_directories(memory, ec);
  measure_kills(memory, 48, rng, &in_memory);
  fs::remove_all(memory, ec);

  unsigned major = 0, minor = 0, release = 0;
  H5get_libversion(&major, &minor, &release);
  std::printf("[kill test] HDF5 %u.%u.%u, %zu write_frame calls per run (level 0: %d frames, level 1: every fourth "
              "step, overwrites)\n", major, minor, release, write_ops().size(), kLastFrame + 1);
  print_counts("disk", on_disk);
  print_counts(shm ? "/dev/shm" : "disk again (no /dev/shm)", in_memory);
  EXPECT_EQ(on_disk.kills + in_memory.kills, 60);
  EXPECT_GT(on_disk.compared + in_memory.compared, 0);
  EXPECT_GE(on_disk.in_write + on_disk.between + in_memory.in_write + in_memory.between, 60 / 2)
      << "too few kills landed in the frame loop to measure it";
}

// ---------------------------------------------------------------------------------------------------
// Locks: a living process that has the file open keeps a writer out; a killed one does not.

// A forked process that runs `hold` (which opens the file and may start a program), reports through a
// pipe and waits to be killed. Returns {its pid, what hold returned: the started program's pid, 0 for
// none, -1 if hold failed}.
template <typename Hold>
std::pair<pid_t, pid_t> holder(Hold&& hold) {
  int fds[2];
  if (pipe(fds) != 0) return {-1, -1};
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    pid_t started = -1;
    try {
      started = hold();
    } catch (...) {
    }
    (void)!write(fds[1], &started, sizeof started);
    for (;;) pause();
  }
  close(fds[1]);
  pid_t started = -1;
  if (pid < 0 || read(fds[0], &started, sizeof started) != static_cast<ssize_t>(sizeof started)) started = -1;
  close(fds[0]);
  return {pid, started};
}

void kill_and_reap(pid_t pid) {
  if (pid <= 0) return;
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
}

// Starts /bin/sleep 60 and returns its pid once it runs (after its exec: a close-on-exec pipe closes).
pid_t start_sleeper() {
  int p[2];
  if (pipe2(p, O_CLOEXEC) != 0) return -1;
  const pid_t pid = fork();
  if (pid == 0) {
    execl("/bin/sleep", "sleep", "60", static_cast<char*>(nullptr));
    const char failed = 1;
    (void)!write(p[1], &failed, 1);
    _exit(127);
  }
  close(p[1]);
  char c = 0;
  const ssize_t n = read(p[0], &c, 1);  // 0 (end of file): the exec happened
  close(p[0]);
  return pid > 0 && n == 0 ? pid : -1;
}

TEST(FrameStoreKillTest, OpenFailsWhileAProcessHoldsTheFileAndWorksOnceItIsKilled) {
  // HDF5 reads HDF5_USE_FILE_LOCKING at every open; this test is about the default, locking on.
  const char* env = std::getenv("HDF5_USE_FILE_LOCKING");
  const std::string saved = env ? env : "";
  unsetenv("HDF5_USE_FILE_LOCKING");
  const std::string dir = test::scratch_dir("frame_lock");
  const std::string path = dir + "/job.h5";
  {
    FrameWriter w = FrameWriter::create(path, "{}", kLastFrame);
    add_level(w, 0);
    add_level(w, 1);
  }
  // What the held process has open (leaked on purpose: the process is killed with it open).
  enum Hold { kWriter, kReader, kWriterThatStartedAProgram };
  for (Hold what : {kWriter, kReader, kWriterThatStartedAProgram}) {
    SCOPED_TRACE("held by " + std::string(what == kWriter ? "a writer" : what == kReader ? "a reader" :
                                          "a writer that started a program"));
    auto [pid, program] = holder([&]() -> pid_t {
      if (what == kReader) {
        new FrameReader(path);
        return 0;
      }
      auto* w = new FrameWriter(FrameWriter::open(path));
      w->write_frame(0, what, frame_positions(0, what, 0), frame_stats(0, what, 0));  // returns before the kill
      return what == kWriterThatStartedAProgram ? start_sleeper() : 0;
    });
    ASSERT_GT(pid, 0);
    ASSERT_GE(program, 0) << "the holding process failed";
    if (what == kWriterThatStartedAProgram) {
      ASSERT_GT(program, 0);
      kill_and_reap(pid);  // the writer dies; the program it started (with its descriptors) lives on
      EXPECT_EQ(kill(program, 0), 0) << "the started program is not running";
    } else {
      const std::string msg = input_error_of([&] { FrameWriter::open(path); });
      EXPECT_EQ(msg.rfind(path + ": cannot open the HDF5 file for writing", 0), 0u) << msg;
      EXPECT_NE(msg.find("unable to lock file"), std::string::npos) << msg;
      if (what == kWriter) {
        EXPECT_NE(input_error_of([&] { FrameReader r(path); }).find("unable to lock file"), std::string::npos);
      }
      kill_and_reap(pid);
    }
    std::string error;
    try {
      FrameWriter w = FrameWriter::open(path);
      if (what != kReader) {
        EXPECT_TRUE(w.is_done(0, what));
        const Positions X = w.read_frame(0, what), want = frame_positions(0, what, 0);
        EXPECT_TRUE(same_bits(X.data(), want.data(), want.size()));
      }
      w.write_frame(1, what, frame_positions(1, what, 0), frame_stats(1, what, 0));
    } catch (const InputError& e) {
      error = e.what();
    }
    EXPECT_EQ(error, "");
    if (program > 0) kill(program, SIGKILL);  // its parent was killed, so init reaps it
  }
  fs::remove_all(dir);
  if (env) setenv("HDF5_USE_FILE_LOCKING", saved.c_str(), 1);
}

}  // namespace
}  // namespace pd
