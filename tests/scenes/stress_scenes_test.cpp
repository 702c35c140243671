// The stress scenes of scenes/stress/ (docs/stress.md), CI-sized: each scene file is run by the pd
// binary as a user runs it (a subprocess under `timeout`, so a crash or a hang is a test failure, not
// a dead test run), direct and progressive, with fewer frames and, where the scene allows, a smaller
// mesh (each change stated in ci_scenes()). Every stored frame of every level is then read back from
// the frame file and checked:
//   - every position finite;
//   - no intersection (the independent CGAL checker, tests/support/intersection_checker.h) and no
//     vertex through the analytic ground;
//   - energy: E(t) = kinetic + the stored conservative potentials (below) never exceeds E(0), nor
//     E(t-1), by more than a stated margin, for scenes where every external force is such a
//     potential (no wind, moving obstacle or scripted pin, whose work no stat records);
//   - Newton: unconverged steps are read from stats/newton_converged, printed, and bounded.
// A scene beyond the solver (StressBeyondTheSolver) must end in time with its failures counted.
// The same analysis prints the rows of docs/stress.md for full-size frame files
// (print_stress_table below: the program pd_stress_table, run by bench/stress_table.sh).
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "store/frame_store.h"
#include "support/intersection_checker.h"
#include "support/test_paths.h"

namespace pd {
namespace {

using nlohmann::json;

// Stored energy terms (stats energy_<term>) that are potentials of the positions alone, so that
// implicit Euler on them cannot gain energy beyond its solve error (with convex terms the scheme is
// dissipative; the non-convex membrane and bending, the Newton tolerance and the adaptive barrier
// stiffness, which raises the stored barrier energy when it doubles, are what the margins allow).
const std::set<std::string> kConservative = {"membrane", "bending",      "gravity", "pressure",
                                             "contact",  "strain_limit", "ground"};
// Stored terms that are not energies of the state: friction's value is IPC's lagged dissipation
// potential of the step, wind's the drag's incremental potential of the step, pin_target the
// augmented-Lagrangian pull toward scripted pins. They are excluded from E(t); their work is not stored.
const std::set<std::string> kNotStateEnergy = {"friction", "wind", "pin_target"};

// What one level of a frame file shows.
struct LevelCheck {
  int level = 0;
  int frames = 0;             // stored frames, frame 0 included
  int missing = 0;            // frames 0..N not stored
  int nonfinite = 0;          // frames with a NaN or infinite position or energy
  int intersecting = 0;       // frames the CGAL checker rejects
  int below_ground = 0;       // frames with a vertex at or below the ground plus the contact offset
  double worst_excess = 0;    // max_t E(t) - E(0), J
  int worst_frame = 0;
  double worst_step_gain = 0; // max_t E(t) - E(t-1), J: a gain the start's dissipation cannot hide
  int worst_step_frame = 0;
  double scale = 0;           // max_t KE(t) + max_t |E(t) - E(0)|: the energy the scene moves, J
  std::string worst_terms;    // "term +dE ..." at worst_frame, J: which terms carry the excess
  std::string series;         // "t: E-E0 (KE)" for frames 1..worst_frame, J, for failure messages
  std::vector<std::string> unknown_terms;  // energy_<term> stats in neither list above
  int steps = 0;              // frames 1..N
  double newton_mean = 0;
  int newton_max = 0;
  int unconverged = 0;
  double solve_seconds = 0;   // sum over the level's steps
};

struct FileCheck {
  std::string scene_name;
  bool unstored_work = false;  // wind, a moving obstacle or a scripted pin act on the scene
  std::string unstored_why;
  std::vector<LevelCheck> levels;
};

// Forces whose work no stored energy records, read from the scene text the frame file keeps.
std::string unstored_work(const json& scene) {
  std::string why;
  if (scene.contains("wind")) why += "wind ";
  for (const json& o : scene["objects"]) {
    if (o.contains("motion")) why += "moving obstacle " + o.value("name", std::string("?")) + " ";
    for (const json& p : o.value("pins", json::array()))
      if (p.contains("script")) why += "scripted pin ";
  }
  return why;
}

// The analytic ground is no mesh, so the CGAL checker cannot see a vertex through it: checked here.
struct Ground {
  bool present = false;
  Vec3 normal = Vec3(0, 1, 0);  // unit
  double level = 0;             // height + contact offset, m: free space is normal . p > level
  std::vector<char> felt;       // per object in scene order: simulated with ground_contact on
};

Ground ground_of(const json& scene) {
  Ground g;
  if (!scene.contains("ground")) return g;
  const json& j = scene["ground"];
  g.present = true;
  if (j.contains("normal")) g.normal = Vec3(j["normal"][0], j["normal"][1], j["normal"][2]).normalized();
  g.level = j.value("height", 0.0) + scene["contact"].value("offset", 0.0);
  for (const json& o : scene["objects"]) g.felt.push_back(!o.value("obstacle", false) && o.value("ground_contact", true));
  return g;
}

bool above_ground(const Positions& x, const std::vector<int>& offsets, const Ground& g) {
  for (std::size_t k = 0; k + 1 < offsets.size() && k < g.felt.size(); ++k)
    if (g.felt[k])
      for (int v = offsets[k]; v < offsets[k + 1]; ++v)
        if (!(x.row(v).dot(g.normal.transpose()) > g.level)) return false;
  return true;
}

// E(t) = kinetic + every stored conservative term (J), for frames 0..N (NaN where not stored); each
// included term's series goes to `terms`, names of unclassified terms to c.unknown_terms.
std::vector<double> total_energy(const FrameReader& reader, int level, LevelCheck& c,
                                 std::vector<std::pair<std::string, std::vector<double>>>& terms) {
  std::vector<double> energy = reader.stat(level, "kinetic_energy");
  terms = {{"kinetic", energy}};
  for (const std::string& name : reader.stat_names(level)) {
    if (name.rfind("energy_", 0) != 0) continue;
    const std::string term = name.substr(7);
    if (kNotStateEnergy.count(term)) continue;
    if (!kConservative.count(term)) {
      c.unknown_terms.push_back(term);
      continue;
    }
    const std::vector<double> values = reader.stat(level, name);
    // A term first reported after frame 0 (NaN before) was zero until then: contact appears late.
    for (std::size_t t = 0; t < energy.size(); ++t) energy[t] += std::isnan(values[t]) ? 0.0 : values[t];
    terms.emplace_back(term, values);
  }
  return energy;
}

LevelCheck check_level(const FrameReader& reader, int level, const Ground& ground, bool check_intersections) {
  LevelCheck c;
  c.level = level;
  const Faces F = reader.faces(level);
  const std::vector<int> offsets = reader.object_offsets(level);
  const std::vector<uint8_t> done = reader.done(level);
  const int n = reader.num_frames();
  std::vector<std::pair<std::string, std::vector<double>>> terms;
  const std::vector<double> energy = total_energy(reader, level, c, terms);
  const std::vector<double>& kinetic = terms.front().second;
  const std::vector<double> iterations = reader.stat(level, "newton_iterations");
  const std::vector<double> converged = reader.stat(level, "newton_converged");
  const std::vector<double> seconds = reader.stat(level, "solve_seconds");
  double max_kinetic = 0, max_change = 0, iteration_sum = 0;
  for (int t = 0; t < n; ++t) {
    if (!done[static_cast<std::size_t>(t)]) {
      ++c.missing;
      continue;
    }
    ++c.frames;
    const Positions x = reader.frame(level, t);
    const double e = energy[static_cast<std::size_t>(t)];
    if (!x.allFinite() || !std::isfinite(e)) {
      ++c.nonfinite;
      continue;  // the checker rejects non-finite coordinates; the frame already counts as bad
    }
    if (check_intersections && !test::intersection_free(x, F)) ++c.intersecting;
    if (ground.present && !above_ground(x, offsets, ground)) ++c.below_ground;
    max_kinetic = std::max(max_kinetic, kinetic[static_cast<std::size_t>(t)]);
    max_change = std::max(max_change, std::abs(e - energy[0]));
    if (e - energy[0] > c.worst_excess) {
      c.worst_excess = e - energy[0];
      c.worst_frame = t;
    }
    if (t == 0) continue;
    const double gain = e - energy[static_cast<std::size_t>(t - 1)];
    if (gain > c.worst_step_gain) {
      c.worst_step_gain = gain;
      c.worst_step_frame = t;
    }
    ++c.steps;
    iteration_sum += iterations[static_cast<std::size_t>(t)];
    c.newton_max = std::max(c.newton_max, static_cast<int>(iterations[static_cast<std::size_t>(t)]));
    c.unconverged += converged[static_cast<std::size_t>(t)] != 1.0;
    c.solve_seconds += seconds[static_cast<std::size_t>(t)];
  }
  c.scale = max_kinetic + max_change;
  for (int t = 1; t <= c.worst_frame; ++t) {
    char part[64];
    std::snprintf(part, sizeof part, " %d: %.3g (%.3g)", t, energy[static_cast<std::size_t>(t)] - energy[0],
                  kinetic[static_cast<std::size_t>(t)]);
    c.series += part;
  }
  for (const auto& [term, values] : terms) {
    auto at = [&v = values](int t) { return std::isnan(v[static_cast<std::size_t>(t)]) ? 0.0 : v[static_cast<std::size_t>(t)]; };
    char part[96];
    std::snprintf(part, sizeof part, "%s%s %+.3g", c.worst_terms.empty() ? "" : ", ", term.c_str(),
                  at(c.worst_frame) - at(0));
    c.worst_terms += part;
  }
  c.newton_mean = c.steps ? iteration_sum / c.steps : 0.0;
  return c;
}

FileCheck check_file(const std::string& path, bool check_intersections = true) {
  const FrameReader reader(path);
  FileCheck f;
  const json scene = json::parse(reader.scene_json());
  const Ground ground = ground_of(scene);
  f.scene_name = scene.value("name", path);
  f.unstored_why = unstored_work(scene);
  f.unstored_work = !f.unstored_why.empty();
  // pd simulate --mode direct --level L stores the hierarchy with frames on level L only.
  for (int level = 0; level < reader.num_levels(); ++level) {
    const std::vector<uint8_t> done = reader.done(level);
    if (std::find(done.begin(), done.end(), 1) != done.end())
      f.levels.push_back(check_level(reader, level, ground, check_intersections));
  }
  return f;
}

// One CI-sized stress scene: what is changed from the scene file, and the bounds it must meet.
struct CiScene {
  std::string name;                 // scenes/stress/<name>.json
  int frames;                       // --frames
  std::function<void(json&)> edit;  // smaller meshes; empty: the scene's own meshes
  // Allowed max_t E(t) - E(0), as a fraction of the level's energy scale (LevelCheck::scale); NaN
  // where external work is not stored (then the excess is printed, not bounded).
  double energy_margin;
  int max_unconverged;              // per level
};

// pd's result: exit code (128 + signal when a signal ended it, 124 when `timeout` stopped it), its
// output (stdout and stderr) and wall time.
struct PdRun {
  int exit_code = -1;
  std::string output;
  double seconds = 0;
  std::string describe() const {
    return "pd exit " + std::to_string(exit_code) + " after " + std::to_string(seconds) + " s: " + output;
  }
};

// Runs pd with `args` (shell words, no quoting needed for the scratch paths used here), bounded by
// coreutils `timeout` (SIGTERM after `limit_s` seconds, SIGKILL 5 s later): pclose waits for it, so
// nothing is left running when this returns, whatever the test asserts next.
PdRun run_pd(const std::string& args, int limit_s) {
  const std::string cmd = "timeout -k 5 " + std::to_string(limit_s) + " " + test::pd_binary() + " " + args +
                          " 2>&1 < /dev/null";
  const auto t0 = std::chrono::steady_clock::now();
  PdRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) {
    r.output = "popen failed";
    return r;
  }
  std::array<char, 4096> buf;
  std::size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

json& object_named(json& scene, const std::string& name) {
  for (json& o : scene["objects"])
    if (o["name"] == name) return o;
  throw std::runtime_error("no object " + name);
}

// Margins: implicit Euler loses energy on these scenes (impacts, friction, numerical damping), so
// any excess is solve error or barrier-stiffness growth. Measured: max_t E(t) - E(0) is 0 J on every
// level of every variant below (E never rises above its start). 2% of the scale leaves room for
// other machines' round-off and iteration paths and stays far below what a real gain gives (PSQ's
// frozen offsets on the sharp edge: 50-62%; a blow-up or a tunnelling rebound exceeds the scale).
void small_drape(json& j) {
  object_named(j, "cloth")["mesh"]["cells"] = {8, 8};
  json& sphere = object_named(j, "sphere");
  sphere["mesh"]["subdivisions"] = 2;
  sphere["hierarchy"]["vertex_counts"] = {162};
}

const std::vector<CiScene>& ci_scenes() {
  static const std::vector<CiScene> scenes = {
      // 0.4 s: the fall (0.23 s) and the dent. Meshes as in the file.
      {"stiff-shell-on-rubber", 40, {}, 0.02, 0},
      // 12 x 12 sheet, 0.4 s: the sheet lands on the ridge (0.04 s) and folds over it. (With PSQ's
      // frozen offsets its progressive run gained 0.64 J at the landing, docs/stress.md finding 1.)
      {"sharp-edge-drape", 40, [](json& j) { object_named(j, "sheet")["mesh"]["cells"] = {12, 12}; }, 0.02, 0},
      // 10 x 10 cloth, sphere with 2 subdivisions (162 vertices), 0.3 s: lands (0.06 s) and is spun.
      {"spin-sphere-fast", 30,
       [](json& j) {
         object_named(j, "cloth")["mesh"]["cells"] = {10, 10};
         json& sphere = object_named(j, "sphere");
         sphere["mesh"]["subdivisions"] = 2;
         sphere["hierarchy"]["vertex_counts"] = {162};
       },
       NAN, 0},
      // 162-vertex ball, 0.1 s: impact at 0.02 s, the dimple and the start of the rebound.
      {"ball-impact-10ms", 40,
       [](json& j) {
         json& ball = object_named(j, "ball");
         ball["mesh"]["subdivisions"] = 2;
         ball["hierarchy"]["vertex_counts"] = {100, 62};
       },
       0.02, 0},
      // 0.15 s: the cube reaches the sheet at once (5 cm at 10 m/s) and dents it to its deepest.
      {"cube-impact-sheet", 30, {}, 0.02, 0},
      // 8 x 5 flag, 1 s of the 10 s.
      {"flag-10s", 100, [](json& j) { j["objects"][0]["mesh"]["cells"] = {8, 5}; }, NAN, 0},
      // 8 x 8 cloth, sphere with 2 subdivisions, the whole second (25 steps).
      {"drape-h25", 25, small_drape, 0.02, 0},
      // 8 x 8 cloth, sphere with 2 subdivisions, 0.2 s: the fall (0.09 s) and the impact on the sphere.
      {"drape-h400", 80, small_drape, 0.02, 0},
  };
  return scenes;
}

json scene_json(const std::string& name) {
  std::ifstream in(test::source_dir() + "/scenes/stress/" + name + ".json");
  std::stringstream text;
  text << in.rdbuf();
  return json::parse(text.str());
}

std::string write_scene(const std::string& dir, const std::string& name, const json& j) {
  const std::string path = dir + "/" + name + ".json";
  std::ofstream(path) << j.dump(2);
  return path;
}

void print_level(const CiScene& s, const std::string& mode, const FileCheck& f, const LevelCheck& c, double seconds) {
  const double relative = c.scale > 0 ? c.worst_excess / c.scale : 0.0;
  std::printf("[%s %s level %d] %d frames, %d intersecting, %d below ground, %d non-finite; energy excess %.3g J = "
              "%.3g of %.3g J (frame %d: %s), largest one-step gain %.3g J (frame %d)%s; Newton %.1f mean, %d max, "
              "%d unconverged; %.2f s solving (pd: %.1f s)\n",
              s.name.c_str(), mode.c_str(), c.level, c.frames, c.intersecting, c.below_ground, c.nonfinite,
              c.worst_excess, relative, c.scale, c.worst_frame, c.worst_terms.c_str(), c.worst_step_gain,
              c.worst_step_frame, f.unstored_work ? (" [not bounded: " + f.unstored_why + "]").c_str() : "",
              c.newton_mean, c.newton_max, c.unconverged, c.solve_seconds, seconds);
}

// Runs one CI scene in one mode and checks its frame file; prints one summary line per level.
void run_and_check(const CiScene& s, const std::string& mode) {
  json j = scene_json(s.name);
  if (s.edit) s.edit(j);
  const int frames = s.frames;
  const std::string dir = test::scratch_dir("stress_" + s.name);
  const std::string scene = write_scene(dir, s.name, j), out = dir + "/" + mode + ".h5";
  // 150 s: the slowest variant took 33 s on the loaded 2-core machine; a hang must not stall CI.
  const PdRun r = run_pd("simulate " + scene + " --mode " + mode + " --frames " + std::to_string(frames) +
                             " --quiet --out " + out, 150);
  ASSERT_EQ(r.exit_code, 0) << r.describe();
  const FileCheck f = check_file(out);
  EXPECT_EQ(f.unstored_work, std::isnan(s.energy_margin)) << s.name << ": " << f.unstored_why;
  const std::string where = s.name + " " + mode + " level ";
  for (const LevelCheck& c : f.levels) {
    print_level(s, mode, f, c, r.seconds);
    const double relative = c.scale > 0 ? c.worst_excess / c.scale : 0.0;
    // Progressive stores every level; direct stores one. All frames 0..N are stored.
    EXPECT_EQ(c.missing, 0) << where << c.level;
    EXPECT_EQ(c.frames, frames + 1) << where << c.level;
    EXPECT_EQ(c.nonfinite, 0) << where << c.level;
    EXPECT_EQ(c.intersecting, 0) << where << c.level;
    EXPECT_EQ(c.below_ground, 0) << where << c.level;
    if (!c.unknown_terms.empty()) ADD_FAILURE() << "energy term to classify in this test: " << c.unknown_terms.front();
    if (!f.unstored_work) {
      EXPECT_LE(relative, s.energy_margin) << where << c.level << ": frame: E(t) - E(0) (kinetic), J:" << c.series;
      // One step, which an impact's early dissipation cannot hide. Measured: direct at most 0.7% of
      // the scale (sharp-edge-drape, frame 14: contact along the edge); progressive refinement
      // levels up to 8% (drape-h25 level 1; ball-impact-10ms's finest level 6% at the impact): the
      // prolonged momentum of the level below does work no stored energy records (docs/stress.md).
      // Bounds 2% and 15%.
      const double step_relative = c.scale > 0 ? c.worst_step_gain / c.scale : 0.0;
      EXPECT_LE(step_relative, mode == "direct" ? 0.02 : 0.15)
          << where << c.level << ": frame " << c.worst_step_frame << " gained " << c.worst_step_gain << " J";
    }
    EXPECT_LE(c.unconverged, s.max_unconverged) << where << c.level;
  }
  EXPECT_EQ(f.levels.size() > 1, mode == "progressive");
  // The frame file stays for a failure's diagnosis; a passing run leaves nothing behind.
  if (!::testing::Test::HasFailure()) std::filesystem::remove_all(dir);
}

class StressScenes : public ::testing::TestWithParam<std::tuple<int, std::string>> {};

TEST_P(StressScenes, FramesAreFiniteIntersectionFreeAndGainNoEnergy) {
  const auto& [index, mode] = GetParam();
  run_and_check(ci_scenes()[static_cast<std::size_t>(index)], mode);
}

INSTANTIATE_TEST_SUITE_P(CiSized, StressScenes,
                         ::testing::Combine(::testing::Range(0, 8), ::testing::Values("direct", "progressive")),
                         [](const auto& info) {
                           std::string name = ci_scenes()[static_cast<std::size_t>(std::get<0>(info.param))].name +
                                              "_" + std::get<1>(info.param);
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;
                         });

// Beyond the solver: the cube of cube-impact-sheet fired at 300 m/s with h = 1/100 s (3 m per step
// against a 1 mm barrier, 54 kJ) and at most 10 Newton iterations per step. pd neither crashes nor
// hangs: it ends within the timeout, stores every frame (finite, intersection-free), counts the steps
// it could not solve in stats/newton_converged, and fails clearly: exit 3 with one error line giving
// the count (--allow-unconverged: exit 0 and a warning). Measured: every step unconverged (direct 4
// of 4 with 20 iterations). The crushed sheet folds onto itself under the cube, so the test turns on
// its self-contact: without it the scene lets the sheet pass through itself (with 11 or 12 Newton
// iterations per step instead of 10, frame 3 of the direct run did, measured 2026-12-06), and the
// intersection check below is the contact promise only for what the scene declares.
TEST(StressBeyondTheSolver, UnsolvableImpactEndsInTimeFailsWithExitThreeAndCountsEveryUnconvergedStep) {
  json j = scene_json("cube-impact-sheet");
  j["time_step"] = 0.01;
  object_named(j, "trampoline")["self_contact"] = true;
  j["solver"] = {{"max_newton_iterations", 10}};
  object_named(j, "cube")["initial_velocity"] = {0, -300.0, 0};
  const std::string dir = test::scratch_dir("stress_beyond");
  const std::string scene = write_scene(dir, "cube-300ms", j);
  for (const std::string mode : {"direct", "progressive"}) {
    const std::string out = dir + "/" + mode + ".h5";
    const int frames = 3;
    const PdRun r = run_pd("simulate " + scene + " --mode " + mode + " --frames " + std::to_string(frames) +
                               " --quiet --out " + out, 120);
    std::printf("[cube at 300 m/s, %s] %s\n", mode.c_str(), r.describe().c_str());
    // A clear failure (exit 3, one error line with the count), the frames kept.
    ASSERT_EQ(r.exit_code, 3) << r.describe();
    const std::string key = "pd: error: " + scene + ": ";
    const std::size_t at = r.output.find(key);
    ASSERT_NE(at, std::string::npos) << "no error about unconverged steps: " << r.describe();
    EXPECT_NE(r.output.find("stopped before convergence", at), std::string::npos) << r.describe();
    EXPECT_NE(r.output.find("--allow-unconverged", at), std::string::npos) << r.describe();
    const int reported = std::atoi(r.output.c_str() + at + key.size());
    const FileCheck f = check_file(out);
    int unconverged = 0;
    for (const LevelCheck& c : f.levels) {
      unconverged += c.unconverged;
      EXPECT_EQ(c.frames, frames + 1) << mode << " level " << c.level;
      EXPECT_EQ(c.nonfinite, 0) << mode << " level " << c.level;
      EXPECT_EQ(c.intersecting, 0) << mode << " level " << c.level;
    }
    EXPECT_EQ(reported, unconverged) << mode << ": stderr and stats/newton_converged disagree";
    EXPECT_GT(unconverged, 0) << mode;
    // Accepted on request: exit 0 and a warning, the same frames.
    const PdRun accepted = run_pd("simulate " + scene + " --mode " + mode + " --frames " + std::to_string(frames) +
                                      " --quiet --allow-unconverged --out " + out, 120);
    EXPECT_EQ(accepted.exit_code, 0) << accepted.describe();
    EXPECT_NE(accepted.output.find("warning: " + std::to_string(reported)), std::string::npos) << accepted.describe();
  }
  if (!::testing::Test::HasFailure()) std::filesystem::remove_all(dir);
}

// Diverged: a state no shot reaches (progressive/level_stepper.h: a coordinate beyond 1e6 m). A
// sheet in free fall at the format's largest gravity and time step passes it at frame 45: pd stops
// there with one error line naming the frame and the object, exit 3, and keeps frames 0..44.
TEST(StressBeyondTheSolver, ADivergingRunStopsNamingTheFrameAndKeepsTheFramesBeforeIt) {
  const json j = {{"format_version", 1},
                  {"name", "free-fall-1000g"},
                  {"time_step", 1.0},
                  {"frames", 50},
                  {"gravity", {0, -1000, 0}},
                  {"objects",
                   {{{"name", "sheet"},
                     {"mesh", {{"type", "rectangle"}, {"size", {0.5, 0.5}}, {"cells", {2, 2}}}},
                     {"material", {{"preset", "cotton"}}}}}}};
  const std::string dir = test::scratch_dir("stress_diverged");
  const std::string scene = write_scene(dir, "free-fall", j), out = dir + "/direct.h5";
  const PdRun r = run_pd("simulate " + scene + " --quiet --out " + out, 60);
  EXPECT_EQ(r.exit_code, 3) << r.describe();
  EXPECT_NE(r.output.find("pd: error: " + scene + ": frame 45: the simulation diverged: object 'sheet' vertex 0: "
                                                  "a coordinate of "),
            std::string::npos)
      << r.describe();
  EXPECT_NE(r.output.find("44 frames stored before the error"), std::string::npos) << r.describe();
  const FrameReader reader(out);
  const std::vector<uint8_t> done = reader.done(0);
  ASSERT_EQ(done.size(), 51u);
  for (int t = 0; t <= 50; ++t) EXPECT_EQ(done[static_cast<std::size_t>(t)], t <= 44 ? 1 : 0) << "frame " << t;
  if (!::testing::Test::HasFailure()) std::filesystem::remove_all(dir);
}

// With PD_STRESS_SERIES set: every stored frame's kinetic energy and E(t) - E(0) with its terms' changes
// from frame 0 (J), one line per frame and level, for diagnosing where an energy gain comes from.
void print_series(const FrameReader& reader, const FileCheck& f) {
  for (const LevelCheck& c : f.levels) {
    LevelCheck unused;
    std::vector<std::pair<std::string, std::vector<double>>> terms;
    const std::vector<double> energy = total_energy(reader, c.level, unused, terms);
    for (std::size_t t = 0; t < energy.size(); ++t) {
      if (std::isnan(energy[t])) continue;
      std::printf("SERIES %s level %d frame %zu: E-E0 %.4g", f.scene_name.c_str(), c.level, t, energy[t] - energy[0]);
      for (const auto& [term, values] : terms)
        std::printf(" %s %.4g", term.c_str(), (std::isnan(values[t]) ? 0.0 : values[t]) - (std::isnan(values[0]) ? 0.0 : values[0]));
      const ObjectPoints com = reader.center_of_mass(c.level, static_cast<int>(t));
      for (int k = 0; k < com.rows(); ++k) std::printf(" com%d %.6f %.6f %.6f", k, com(k, 0), com(k, 1), com(k, 2));
      std::printf("\n");
    }
  }
}

// Rows of docs/stress.md for the frame files in $PD_STRESS_TABLE_FILES (':'-separated), as
// bench/stress_table.sh runs it: one row per file (scene and mode), every level of a progressive
// file summed (frames, intersecting frames, Newton iterations, unconverged steps, cost) or maximised
// (energy excess, naming the level). Cost: solve seconds of all levels per step of the shot.
// A tool, not a check: the program pd_stress_table (this file built with PD_STRESS_TABLE_MAIN,
// tests/CMakeLists.txt) runs it; the test suite does not.
[[maybe_unused]] void print_stress_table(const char* list) {
  std::stringstream files(list);
  std::string path;
  std::printf("TABLE | scene | mode | levels | frames | intersecting (below ground) | worst energy excess J (relative, "
              "level) | largest one-step gain J (relative, level) | Newton its/step mean, max | unconverged steps | "
              "s/step |\n");
  std::printf("TABLE |---|---|---:|---:|---:|---|---|---|---:|---:|\n");
  while (std::getline(files, path, ':')) {
    const FileCheck f = check_file(path);
    int frames = 0, intersecting = 0, below_ground = 0, nonfinite = 0, unconverged = 0, newton_max = 0, steps = 0;
    double iterations = 0, seconds = 0, excess = 0, relative = 0, step_gain = 0, step_relative = 0;
    int excess_level = 0, step_level = 0;
    for (const LevelCheck& c : f.levels) {
      frames += c.frames;
      intersecting += c.intersecting;
      below_ground += c.below_ground;
      if (c.worst_step_gain >= step_gain) {
        step_gain = c.worst_step_gain;
        step_relative = c.scale > 0 ? c.worst_step_gain / c.scale : 0.0;
        step_level = c.level;
      }
      nonfinite += c.nonfinite;
      unconverged += c.unconverged;
      newton_max = std::max(newton_max, c.newton_max);
      iterations += c.newton_mean * c.steps;
      steps += c.steps;
      seconds += c.solve_seconds;
      if (c.worst_excess >= excess) {
        excess = c.worst_excess;
        relative = c.scale > 0 ? c.worst_excess / c.scale : 0.0;
        excess_level = c.level;
      }
    }
    const int shot_steps = f.levels.empty() ? 0 : f.levels.back().steps;
    const FrameReader reader(path);
    std::string mode = f.levels.size() > 1 ? "progressive" : "direct";
    if (f.levels.size() == 1 && reader.num_levels() > 1)  // --preview-only, or direct --level L
      mode = "level " + std::to_string(f.levels[0].level) + " of " + std::to_string(reader.num_levels());
    if (std::getenv("PD_STRESS_SERIES")) print_series(reader, f);
    std::printf("TABLE | %s | %s | %zu | %d%s | %d (%d) | %.3g (%.2g, L%d)%s | %.3g (%.2g, L%d) | %.1f, %d | %d | %.3f |\n",
                f.scene_name.c_str(), mode.c_str(), f.levels.size(), frames,
                nonfinite ? (" (" + std::to_string(nonfinite) + " non-finite)").c_str() : "", intersecting, below_ground,
                excess, relative, excess_level, f.unstored_work ? " (unstored work)" : "", step_gain, step_relative,
                step_level, steps ? iterations / steps : 0.0, newton_max, unconverged,
                shot_steps ? seconds / shot_steps : 0.0);
  }
}

}  // namespace
}  // namespace pd

#ifdef PD_STRESS_TABLE_MAIN
// pd_stress_table: the rows for the frame files in $PD_STRESS_TABLE_FILES (bench/stress_table.sh).
int main() {
  const char* list = std::getenv("PD_STRESS_TABLE_FILES");
  if (!list || !*list) {
    std::fprintf(stderr, "pd_stress_table: error: PD_STRESS_TABLE_FILES: set it to frame files, ':'-separated\n");
    return 2;
  }
  pd::print_stress_table(list);
  return 0;
}
#endif
