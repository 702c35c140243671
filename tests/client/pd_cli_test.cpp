// The pd binary end to end: exit codes and messages for bad input, and a small simulate + export.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "geometry/obj_io.h"
#include "store/frame_store.h"
#include "store/hierarchy_store.h"
#include "support/test_paths.h"

namespace pd {
namespace {

struct CliResult {
  int exit_code;
  std::string output;  // stdout and stderr
};

CliResult run_pd(const std::string& args) {
  const std::string cmd = test::pd_binary() + " " + args + " 2>&1 < /dev/null";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return {-1, "popen failed"};
  std::string out;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) out.append(buf.data(), n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

std::string write_file(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// A valid scene small enough to run in a second; tests break one thing at a time.
std::string small_scene(const std::string& material = R"("density": 200, "youngs_modulus": 1e5, "poisson_ratio": 0.3, "thickness": 0.001)",
                        const std::string& mesh = R"({"type": "rectangle", "size": [0.5, 0.5], "cells": [4, 4]})") {
  return R"({"format_version": 1, "name": "small", "time_step": 0.01, "frames": 3,
  "objects": [{"name": "sheet", "mesh": )" + mesh + R"(, "material": {)" + material + R"(},
               "pins": [{"indices": [20, 24]}]}]})";
}

TEST(PdCli, NoSubcommandFailsWithUsage) {
  const CliResult r = run_pd("");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("simulate"), std::string::npos) << r.output;
}

TEST(PdCli, MissingSceneFileNamesTheFile) {
  const std::string dir = test::scratch_dir("cli_missing");
  const CliResult r = run_pd("simulate " + dir + "/nope.json --out " + dir + "/o.h5");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("nope.json"), std::string::npos) << r.output;
}

TEST(PdCli, MalformedJsonNamesFileAndLine) {
  const std::string dir = test::scratch_dir("cli_malformed");
  const std::string scene = write_file(dir, "bad.json", "{\n  \"time_step\": 0.01,\n  \"frames\": ,\n}");
  const CliResult r = run_pd("simulate " + scene + " --out " + dir + "/o.h5");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("bad.json"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("3:"), std::string::npos) << "line 3 expected in: " << r.output;
}

TEST(PdCli, NegativeThicknessNamesTheKey) {
  const std::string dir = test::scratch_dir("cli_thickness");
  const std::string scene = write_file(
      dir, "s.json", small_scene(R"("density": 200, "youngs_modulus": 1e5, "poisson_ratio": 0.3, "thickness": -0.001)"));
  const CliResult r = run_pd("simulate " + scene + " --out " + dir + "/o.h5");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("thickness"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/o.h5")) << "no output file for a rejected scene";
}

TEST(PdCli, UnknownKeyIsRejected) {
  const std::string dir = test::scratch_dir("cli_unknown");
  const std::string scene = write_file(
      dir, "s.json", small_scene(R"("density": 200, "youngs_modulus": 1e5, "poisson_ratio": 0.3, "thicknes": 0.001)"));
  const CliResult r = run_pd("simulate " + scene + " --out " + dir + "/o.h5");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("thicknes"), std::string::npos) << r.output;
}

TEST(PdCli, NonManifoldObjIsRejected) {
  const std::string dir = test::scratch_dir("cli_nonmanifold");
  // Three triangles share the edge 1-2.
  write_file(dir, "fan.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 1 1 1\nf 1 2 3\nf 2 4 3\nf 3 2 5\n");
  const std::string scene = write_file(dir, "s.json",
      small_scene(R"("density": 200, "youngs_modulus": 1e5, "poisson_ratio": 0.3, "thickness": 0.001)",
                  R"({"type": "obj", "path": "fan.obj"})"));
  const CliResult r = run_pd("simulate " + scene + " --out " + dir + "/o.h5");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("objects[0].mesh"), std::string::npos) << r.output;
}

TEST(PdCli, BadCommandLineValueFails) {
  const CliResult r = run_pd("simulate x.json --out o.h5 --frames -3");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("frames"), std::string::npos) << r.output;
}

TEST(PdCli, ExportOfNonHdf5FileNamesTheFile) {
  const std::string dir = test::scratch_dir("cli_export_bad");
  const std::string bogus = write_file(dir, "bogus.h5", "this is not HDF5");
  const CliResult r = run_pd("export " + bogus + " --out " + dir + "/frames");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("bogus.h5"), std::string::npos) << r.output;
}

TEST(PdCli, SimulateThenExportWritesOneObjPerFrame) {
  const std::string dir = test::scratch_dir("cli_ok");
  const std::string scene = write_file(dir, "s.json", small_scene());
  const CliResult sim = run_pd("simulate " + scene + " --out " + dir + "/out.h5");
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const CliResult exp = run_pd("export " + dir + "/out.h5 --level 0 --format obj --out " + dir + "/frames");
  ASSERT_EQ(exp.exit_code, 0) << exp.output;
  int objs = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir + "/frames")) objs += e.path().extension() == ".obj";
  EXPECT_EQ(objs, 4);  // frames 0..3
  const CliResult lvl = run_pd("export " + dir + "/out.h5 --level 3 --out " + dir + "/frames2");
  EXPECT_EQ(lvl.exit_code, 2) << lvl.output;
}

TEST(PdCli, ContactSceneRunsAndStoresContactStatistics) {
  const std::string dir = test::scratch_dir("cli_contact");
  const CliResult sim =
      run_pd("simulate " + test::source_dir() + "/scenes/slope-friction.json --frames 5 --quiet --out " + dir + "/s.h5");
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const FrameReader reader(dir + "/s.h5");
  const auto names = reader.stat_names(0);
  for (const char* name : {"contact_active_pairs", "contact_min_gap", "barrier_stiffness", "friction_contacts"})
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
  EXPECT_GT(reader.stat(0, "contact_active_pairs")[5], 0);  // both squares have landed by frame 5
  const CliResult exp = run_pd("export " + dir + "/s.h5 --level 0 --format obj --out " + dir + "/frames");
  EXPECT_EQ(exp.exit_code, 0) << exp.output;
}

TEST(PdCli, ObjectsThatStartIntersectingAreRejectedBeforeSimulating) {
  const std::string dir = test::scratch_dir("cli_intersecting");
  // The sheet (4 x 4 cells, 0.5 m, in the z = 0 plane) passes through a ball at the origin.
  const std::string scene = R"({"format_version": 1, "time_step": 0.01, "frames": 3,
    "contact": {"dhat": 1e-3},
    "objects": [
      {"name": "sheet", "mesh": {"type": "rectangle", "size": [0.5, 0.5], "cells": [4, 4]},
       "material": {"preset": "cotton"}},
      {"name": "ball", "mesh": {"type": "icosphere", "radius": 0.1, "subdivisions": 2}, "obstacle": true}]})";
  const std::string path = write_file(dir, "bad.json", scene);
  const CliResult r = run_pd("simulate " + path + " --out " + dir + "/o.h5");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("bad.json: contact: the objects start intersecting"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("'sheet'"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("'ball'"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/o.h5")) << "no frame file for a scene that cannot start";
}

TEST(PdCli, NegativeDhatNamesTheKey) {
  const std::string dir = test::scratch_dir("cli_dhat");
  std::string scene = small_scene();
  scene.insert(scene.find("\"objects\""), R"("contact": {"dhat": -0.001}, )");
  const CliResult r = run_pd("simulate " + write_file(dir, "s.json", scene) + " --out " + dir + "/o.h5");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("s.json: contact.dhat"), std::string::npos) << r.output;
}

// ---- pd hierarchy and pd export --rest / --prolong --------------------------------------------------

// A pinned 12 x 12 sheet above a small icosphere obstacle, 3 levels.
std::string hierarchy_scene() {
  return R"({"format_version": 1, "name": "hier", "time_step": 0.01, "frames": 3,
    "hierarchy": {"levels": 3}, "contact": {"dhat": 1e-3},
    "objects": [
      {"name": "sheet", "mesh": {"type": "rectangle", "size": [1.0, 1.0], "cells": [12, 12]},
       "material": {"preset": "cotton"}, "pins": [{"indices": [0, 12]}]},
      {"name": "ball", "mesh": {"type": "icosphere", "radius": 0.2, "subdivisions": 2}, "obstacle": true,
       "transform": {"translation": [0, 0, -1]}}]})";
}

int obj_vertex_count(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) n += line.rfind("v ", 0) == 0;
  return n;
}

int count_objs(const std::string& dir) {
  int objs = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) objs += e.path().extension() == ".obj";
  return objs;
}

TEST(PdCli, HierarchyPrintsEachLevelAndExportRestWritesItsMeshes) {
  const std::string dir = test::scratch_dir("cli_hierarchy");
  const std::string scene = write_file(dir, "s.json", hierarchy_scene());
  const CliResult r = run_pd("hierarchy " + scene + " --out " + dir + "/h.h5");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* line : {"level 0: ", "level 1: ", "level 2: ", "rest prolongation error"})
    EXPECT_NE(r.output.find(line), std::string::npos) << line << " not in: " << r.output;
  EXPECT_EQ(r.output.find("level 3: "), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("reused"), std::string::npos) << r.output;

  const CliResult exp = run_pd("export " + dir + "/h.h5 --rest --out " + dir + "/rest");
  ASSERT_EQ(exp.exit_code, 0) << exp.output;
  EXPECT_EQ(count_objs(dir + "/rest"), 3);
  const FrameReader reader(dir + "/h.h5");
  ASSERT_EQ(reader.num_levels(), 3);
  for (int l = 0; l < 3; ++l) {
    const int n = reader.num_vertices(l);
    EXPECT_EQ(obj_vertex_count(dir + "/rest/level_" + std::to_string(l) + ".obj"), n) << l;
    EXPECT_NE(r.output.find("level " + std::to_string(l) + ": " + std::to_string(n) + " vertices"), std::string::npos)
        << r.output;
  }

  const CliResult again = run_pd("hierarchy " + scene + " --out " + dir + "/h.h5");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("reused"), std::string::npos) << again.output;
  const CliResult json = run_pd("hierarchy " + scene + " --out " + dir + "/h.h5 --json");
  ASSERT_EQ(json.exit_code, 0) << json.output;
  EXPECT_NE(json.output.find("\"reused\": true"), std::string::npos) << json.output;
  EXPECT_NE(json.output.find("\"level\": 2"), std::string::npos) << json.output;
}

TEST(PdCli, ExportProlongWritesCoarseFramesOnTheFinestMesh) {
  const std::string dir = test::scratch_dir("cli_prolong");
  const std::string scene = write_file(dir, "s.json", hierarchy_scene());
  ASSERT_EQ(run_pd("hierarchy " + scene + " --out " + dir + "/h.h5").exit_code, 0);
  const std::optional<SceneHierarchy> h = read_hierarchy(dir + "/h.h5");
  ASSERT_TRUE(h.has_value());
  // A job file with two stored frames of the coarsest level (rest shape, then shifted by 1 cm).
  const std::string job = dir + "/job.h5";
  {
    const std::vector<std::string> names{"sheet", "ball"};
    FrameWriter w = FrameWriter::create(job, hierarchy_scene(), 3);
    write_hierarchy(job, *h, names);
    add_hierarchy_levels(w, *h, names);
    w.write_frame(0, 0, h->levels[0].rest.V, FrameStats{});
    w.write_frame(0, 2, h->levels[0].rest.V.array() + 0.01, FrameStats{});
    w.close();
  }
  const CliResult r = run_pd("export " + job + " --prolong --level 0 --out " + dir + "/fine");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(count_objs(dir + "/fine"), 2);
  const int finest = static_cast<int>(h->levels.back().rest.V.rows());
  EXPECT_EQ(obj_vertex_count(dir + "/fine/frame_00000.obj"), finest);
  EXPECT_EQ(obj_vertex_count(dir + "/fine/frame_00002.obj"), finest);

  // The level-0 frame at rest prolongs to the finest rest shape (PSQ's rest-shape recovery).
  const TriMesh m = read_obj(dir + "/fine/frame_00000.obj");
  EXPECT_LT((m.V - h->levels.back().rest.V).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(m.F, h->levels.back().rest.F);
}

TEST(PdCli, ExportProlongWithoutHierarchySaysToRunPdHierarchy) {
  const std::string dir = test::scratch_dir("cli_prolong_none");
  const std::string scene = write_file(dir, "s.json", small_scene());
  ASSERT_EQ(run_pd("simulate " + scene + " --quiet --out " + dir + "/out.h5").exit_code, 0);
  const CliResult r = run_pd("export " + dir + "/out.h5 --prolong --level 0 --out " + dir + "/fine");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("pd: error: " + dir + "/out.h5"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("pd hierarchy"), std::string::npos) << r.output;
}

TEST(PdCli, SimulateProgressiveStoresEveryLevelAndPreviewOnlyStopsAfterLevelZero) {
  const std::string dir = test::scratch_dir("cli_progressive");
  const std::string scene = write_file(dir, "s.json", hierarchy_scene());
  const CliResult r = run_pd("simulate " + scene + " --mode progressive --out " + dir + "/p.h5");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* line : {"level 0 (3 levels)", "level 1 (3 levels)", "level 2 (3 levels)"})
    EXPECT_NE(r.output.find(line), std::string::npos) << line << " not in: " << r.output;
  {
    const FrameReader reader(dir + "/p.h5");
    ASSERT_EQ(reader.num_levels(), 3);
    for (int l = 0; l < 3; ++l) {
      const std::vector<uint8_t> done = reader.done(l);
      EXPECT_TRUE(std::all_of(done.begin(), done.end(), [](uint8_t d) { return d == 1; })) << "level " << l;
    }
    EXPECT_TRUE(read_hierarchy(dir + "/p.h5").has_value());
  }
  const CliResult preview = run_pd("simulate " + scene + " --mode progressive --preview-only --hessian coarse --out " +
                                   dir + "/q.h5");
  ASSERT_EQ(preview.exit_code, 0) << preview.output;
  const FrameReader q(dir + "/q.h5");
  EXPECT_EQ(q.done(0), std::vector<uint8_t>(4, 1));
  EXPECT_EQ(q.done(1), std::vector<uint8_t>(4, 0));
  // Direct simulation of the coarsest level, stored at its level of the hierarchy.
  const CliResult direct = run_pd("simulate " + scene + " --mode direct --level 0 --out " + dir + "/d.h5");
  ASSERT_EQ(direct.exit_code, 0) << direct.output;
  const FrameReader d(dir + "/d.h5");
  EXPECT_EQ(d.done(0), std::vector<uint8_t>(4, 1));
  EXPECT_EQ(d.done(2), std::vector<uint8_t>(4, 0));
  // Bad combinations and levels.
  EXPECT_EQ(run_pd("simulate " + scene + " --preview-only --out " + dir + "/x.h5").exit_code, 2);
  EXPECT_EQ(run_pd("simulate " + scene + " --mode sideways --out " + dir + "/x.h5").exit_code, 2);
  const CliResult far = run_pd("simulate " + scene + " --mode direct --level 5 --out " + dir + "/x.h5");
  EXPECT_EQ(far.exit_code, 2) << far.output;
  EXPECT_NE(far.output.find("level 5"), std::string::npos) << far.output;
}

TEST(PdCli, SceneModeProgressiveRunsProgressivelyWithoutFlagsAndABadModeNamesTheKey) {
  const std::string dir = test::scratch_dir("cli_mode");
  std::string text = hierarchy_scene();
  text.insert(text.find("\"hierarchy\""), "\"mode\": \"progressive\", ");
  const std::string scene = write_file(dir, "s.json", text);
  const CliResult r = run_pd("simulate " + scene + " --out " + dir + "/p.h5");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const FrameReader reader(dir + "/p.h5");
  ASSERT_EQ(reader.num_levels(), 3);
  EXPECT_EQ(reader.done(2), std::vector<uint8_t>(4, 1));
  // --mode direct still wins: the scene's meshes as given, one level.
  ASSERT_EQ(run_pd("simulate " + scene + " --mode direct --out " + dir + "/d.h5").exit_code, 0);
  EXPECT_EQ(FrameReader(dir + "/d.h5").num_levels(), 1);

  std::string bad = hierarchy_scene();
  bad.insert(bad.find("\"hierarchy\""), "\"mode\": \"fast\", ");
  const CliResult b = run_pd("simulate " + write_file(dir, "bad.json", bad) + " --out " + dir + "/b.h5");
  EXPECT_EQ(b.exit_code, 2) << b.output;
  EXPECT_NE(b.output.find("mode"), std::string::npos) << b.output;
}

TEST(PdCli, CompareReportsEachLevelAgainstTheFinestAndWritesCsv) {
  const std::string dir = test::scratch_dir("cli_compare");
  const std::string scene = write_file(dir, "s.json", hierarchy_scene());
  ASSERT_EQ(run_pd("simulate " + scene + " --mode progressive --out " + dir + "/p.h5").exit_code, 0);
  ASSERT_EQ(run_pd("simulate " + scene + " --mode direct --level 0 --out " + dir + "/d.h5").exit_code, 0);
  const CliResult r = run_pd("compare " + dir + "/p.h5 " + dir + "/d.h5 --csv " + dir + "/c.csv");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("reference: " + dir + "/p.h5 level 2"), std::string::npos) << r.output;
  std::ifstream csv(dir + "/c.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("file,level,frame,time_s,kinetic_energy_J,com_deviation_m,com_sheet_x", 0), 0u) << line;
  int rows = 0;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, 3 * 4 + 4);  // three progressive levels and one direct level, frames 0..3
  EXPECT_EQ(run_pd("compare " + dir + "/missing.h5").exit_code, 2);
  // An empty --csv or second file is an error, not the default in disguise.
  for (const char* args : {" --csv ''", " ''"}) {
    const CliResult empty = run_pd("compare " + dir + "/p.h5" + args);
    EXPECT_EQ(empty.exit_code, 2) << args;
    EXPECT_NE(empty.output.find("an empty value; leave the option out"), std::string::npos) << empty.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/p.h5.compare.csv"));
}

TEST(PdCli, HierarchyBadInputExitsWithCode2) {
  const std::string dir = test::scratch_dir("cli_hierarchy_bad");
  const std::string scene = write_file(dir, "s.json", hierarchy_scene());
  const CliResult unknown = run_pd("hierarchy " + scene + " --out " + dir + "/h.h5 --levels 3");
  EXPECT_EQ(unknown.exit_code, 2) << unknown.output;
  EXPECT_NE(unknown.output.find("--levels"), std::string::npos) << unknown.output;
  const CliResult no_out = run_pd("hierarchy " + scene);
  EXPECT_EQ(no_out.exit_code, 2) << no_out.output;
  EXPECT_NE(no_out.output.find("--out"), std::string::npos) << no_out.output;
  const CliResult missing = run_pd("hierarchy " + dir + "/nope.json --out " + dir + "/h.h5");
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("pd: error: " + dir + "/nope.json"), std::string::npos) << missing.output;
  const CliResult unwritable = run_pd("hierarchy " + scene + " --out " + dir + "/no/such/dir/h.h5");
  EXPECT_EQ(unwritable.exit_code, 2) << unwritable.output;
  EXPECT_NE(unwritable.output.find("pd: error: " + dir + "/no/such/dir/h.h5"), std::string::npos) << unwritable.output;
  const CliResult bad_flag = run_pd("export " + dir + "/h.h5 --prolongate --out " + dir + "/x");
  EXPECT_EQ(bad_flag.exit_code, 2) << bad_flag.output;
  EXPECT_NE(bad_flag.output.find("--prolongate"), std::string::npos) << bad_flag.output;
}


// ---- pd compare --json (error measures, docs/progressive.md "Error measures") ------------------------

// The one line of `output` that is the JSON object (stderr's "wrote ..." line is mixed in by run_pd).
nlohmann::json json_line(const std::string& output) {
  std::size_t at = 0;
  while (at < output.size()) {
    const std::size_t end = std::min(output.find('\n', at), output.size());
    if (output[at] == '{') return nlohmann::json::parse(output.substr(at, end - at), nullptr, false);
    at = end + 1;
  }
  return nullptr;
}

TEST(PdCli, CompareJsonGivesEveryMeasurePerLevelAndFrameAndRejectsBadSeams) {
  // slope-friction: two sheets (simulated) on two slopes (obstacles), 3 levels, frames 0..3.
  const std::string dir = test::scratch_dir("cli_compare_json");
  const std::string scene = test::source_dir() + "/scenes/slope-friction.json";
  const std::string run = "simulate " + scene + " --frames 3 --quiet ";
  ASSERT_EQ(run_pd(run + "--mode progressive --out " + dir + "/p.h5").exit_code, 0);
  ASSERT_EQ(run_pd(run + "--mode direct --level 0 --out " + dir + "/d.h5").exit_code, 0);  // prolonged by its own file
  const CliResult r = run_pd("compare " + dir + "/p.h5 " + dir + "/d.h5 --json --seams 1 --csv " + dir + "/c.csv");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = json_line(r.output);
  ASSERT_TRUE(j.is_object()) << r.output;
  EXPECT_EQ(j["reference"]["file"], dir + "/p.h5");
  EXPECT_EQ(j["reference"]["level"], 2);
  const int finest = FrameReader(dir + "/p.h5").num_vertices(2);
  EXPECT_EQ(j["reference"]["vertices"], finest);
  ASSERT_EQ(j["levels"].size(), 4u);  // p.h5 levels 0, 1, 2 and d.h5 level 0
  const std::vector<std::string> per_frame_keys = {"frame", "com_deviation_m", "vertex_distance_mean_m",
      "vertex_distance_p95_m", "vertex_distance_max_m", "hausdorff_m", "kinetic_energy_J"};
  for (const nlohmann::json& l : j["levels"]) {
    const std::string where = l.value("file", "?") + " level " + std::to_string(l.value("level", -1));
    for (const char* key : {"file", "level", "vertices", "frames", "time_step_s", "com_deviation_m",
                            "vertex_distance_m", "hausdorff_m", "kinetic_energy_J", "per_frame"})
      EXPECT_TRUE(l.contains(key)) << key << " missing in " << where;
    EXPECT_EQ(l["frames"], 4) << where;
    EXPECT_EQ(l["time_step_s"], 0.01) << where;
    for (const char* key : {"mean", "max", "max_frame"}) {
      EXPECT_TRUE(l["com_deviation_m"][key].is_number()) << key << " " << where;
      EXPECT_TRUE(l["hausdorff_m"][key].is_number()) << key << " " << where;
    }
    for (const char* key : {"first", "max", "last"}) EXPECT_TRUE(l["kinetic_energy_J"][key].is_number()) << where;
    // Every level here reaches the finest mesh (itself, or prolonged with its file's hierarchy).
    ASSERT_TRUE(l["vertex_distance_m"].is_object()) << where << ": " << l.value("vertex_distance_note", "");
    for (const std::string& key : per_frame_keys) {
      ASSERT_TRUE(l["per_frame"].contains(key)) << key << " " << where;
      EXPECT_EQ(l["per_frame"][key].size(), 4u) << key << " " << where;
    }
    for (const nlohmann::json& h : l["per_frame"]["hausdorff_m"]) {
      ASSERT_TRUE(h.is_number()) << where;
      EXPECT_TRUE(std::isfinite(h.get<double>()) && h.get<double>() >= 0.0) << where;
      EXPECT_LT(h.get<double>(), 0.01) << where << ": 3 frames move the sheets far less than 1 cm";
    }
  }
  // The reference against itself: every vertex at distance 0 in every frame.
  const nlohmann::json& self = j["levels"][2];
  ASSERT_EQ(self["level"], 2);
  EXPECT_EQ(self["vertex_distance_m"]["max"], 0.0);
  EXPECT_EQ(self["vertex_distance_m"]["mean"], 0.0);
  for (const nlohmann::json& v : self["per_frame"]["vertex_distance_max_m"]) EXPECT_EQ(v, 0.0);
  EXPECT_EQ(self["com_deviation_m"]["max"], 0.0);
  // Seam jitter of d.h5's level 0 against p.h5's level 0 (same mesh): seams 1 and 2.
  ASSERT_TRUE(j["seam_jitter"].is_array()) << j.dump();
  ASSERT_EQ(j["seam_jitter"].size(), 1u) << j.dump();
  EXPECT_EQ(j["seam_jitter"][0]["level"], 0);
  EXPECT_EQ(j["seam_jitter"][0]["seams"], nlohmann::json::array({1, 2}));
  for (const char* key : {"seam_d_m", "median_other_d_m", "ratio"})
    EXPECT_TRUE(j["seam_jitter"][0].contains(key)) << key;
  std::ifstream csv(dir + "/c.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_NE(header.find(",vertex_distance_mean_m,vertex_distance_p95_m,vertex_distance_max_m,hausdorff_m"),
            std::string::npos) << header;

  // Bad input: exit 2 with "pd: error: <file>: ...".
  const std::string p = dir + "/p.h5", d = dir + "/d.h5";
  for (const auto& [args, file] : std::vector<std::pair<std::string, std::string>>{
           {p + " --seams 3", p}, {p + " " + d + " --seams 1,x", d}, {p + " " + d + " --seams 3", d},
           {p + " " + d + " --seams 1,-1", d}}) {
    const CliResult bad = run_pd("compare " + args + " --csv " + dir + "/bad.csv");
    EXPECT_EQ(bad.exit_code, 2) << args << ": " << bad.output;
    EXPECT_NE(bad.output.find("pd: error: " + file + ": "), std::string::npos) << args << ": " << bad.output;
  }
  const std::string one_scene = write_file(dir, "s.json", small_scene());  // one object against four
  ASSERT_EQ(run_pd("simulate " + one_scene + " --quiet --out " + dir + "/one.h5").exit_code, 0);
  const CliResult objects = run_pd("compare " + p + " " + dir + "/one.h5 --json --csv " + dir + "/bad.csv");
  EXPECT_EQ(objects.exit_code, 2) << objects.output;
  EXPECT_NE(objects.output.find("pd: error: " + dir + "/one.h5"), std::string::npos) << objects.output;
}


// ---- hostile command lines and output files (issue 17) ---------------------------------------------

struct ArgvResult {
  int exit_code = -1;  // -1: killed (timeout) or did not exit normally
  std::string output;  // stdout and stderr
  double seconds = 0;
  bool timed_out = false;
};

// Runs pd with exactly these arguments (no shell: values may hold newlines and control characters),
// stdin /dev/null. Killed after timeout_s. fsize_limit > 0: the child's RLIMIT_FSIZE in bytes with
// SIGXFSZ ignored, so a write beyond it fails with EFBIG as on a full disk. term_when_exists: send
// SIGTERM 0.5 s after that file first exists.
ArgvResult run_pd_argv(const std::vector<std::string>& args, double timeout_s = 60, rlim_t fsize_limit = 0,
                       const std::string& term_when_exists = "") {
  ArgvResult r;
  int fds[2];
  if (pipe(fds) != 0) return r;
  const std::string bin = test::pd_binary();
  std::vector<char*> argv{const_cast<char*>(bin.c_str())};
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(fds[1], 1);
    dup2(fds[1], 2);
    close(fds[0]);
    close(fds[1]);
    const int in = open("/dev/null", O_RDONLY);
    dup2(in, 0);
    if (fsize_limit > 0) {
      signal(SIGXFSZ, SIG_IGN);  // kept across exec
      const rlimit lim{fsize_limit, fsize_limit};
      setrlimit(RLIMIT_FSIZE, &lim);
    }
    execv(bin.c_str(), argv.data());
    _exit(127);
  }
  close(fds[1]);
  const auto deadline = t0 + std::chrono::duration<double>(timeout_s);
  std::array<char, 4096> buf;
  std::optional<std::chrono::steady_clock::time_point> term_at;
  bool termed = false;
  for (;;) {
    const auto now = std::chrono::steady_clock::now();
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now);
    if (left.count() <= 0) {
      r.timed_out = true;
      kill(pid, SIGKILL);
      break;
    }
    if (!term_when_exists.empty() && !term_at && std::filesystem::exists(term_when_exists))
      term_at = now + std::chrono::milliseconds(500);
    if (term_at && !termed && now >= *term_at) termed = kill(pid, SIGTERM) == 0;
    pollfd p{fds[0], POLLIN, 0};
    const int wait_ms = term_when_exists.empty() ? static_cast<int>(left.count()) : 20;
    if (poll(&p, 1, std::min(wait_ms, static_cast<int>(left.count()))) <= 0) continue;
    const ssize_t n = read(fds[0], buf.data(), buf.size());
    if (n <= 0) break;
    r.output.append(buf.data(), static_cast<size_t>(n));
  }
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!r.timed_out && WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  return r;
}

std::string joined(const std::vector<std::string>& args) {
  std::string out;
  for (const std::string& a : args) out += (out.empty() ? "" : " ") + a.substr(0, 100);
  return out;
}

// Exit 2 and exactly one line "pd: error: ...", without CLI11's "Run with --help" line.
void expect_one_line_error(const ArgvResult& r, const std::string& what) {
  EXPECT_EQ(r.exit_code, 2) << what << ": " << r.output;
  EXPECT_EQ(r.output.rfind("pd: error: ", 0), 0u) << what << ": " << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << what << ": " << r.output;
  EXPECT_EQ(r.output.find("--help"), std::string::npos) << what << ": " << r.output;
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::set<std::string> listing(const std::string& dir) {
  std::set<std::string> names;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    names.insert(std::filesystem::relative(e.path(), dir).string());
  return names;
}

// fuzz/known_hdf5_bugs/frame_file: files on which HDF5 1.10 itself crashes, loops or overflows. pd
// opens a frame file it is handed in a child first (client/frame_file_guard.h): export, compare and
// plan give a one-line error naming the file and exit 2, never a signal (two of them killed pd export
// with SIGSEGV before).
TEST(PdCliHostile, TheKnownHdf5CrashFilesGiveAClearErrorAndNoCrash) {
  const std::string dir = test::scratch_dir("cli_known_hdf5");
  int checked = 0;
  for (const auto& entry : std::filesystem::directory_iterator(test::source_dir() + "/fuzz/known_hdf5_bugs/frame_file")) {
    const std::string file = entry.path().string();
    for (const std::string& command : {"export " + file + " --out " + dir + "/out", "compare " + file + " --csv " + dir + "/c.csv",
                                       "plan " + file + " --workers 2"}) {
      const CliResult r = run_pd(command);
      EXPECT_EQ(r.exit_code, 2) << command << "\n" << r.output;
      EXPECT_EQ(r.output.rfind("pd: error: " + file + ": ", 0), 0u) << command << "\n" << r.output;
      EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << command << "\n" << r.output;
      ++checked;
    }
    std::printf("%s: %s", entry.path().filename().c_str(), run_pd("export " + file + " --out " + dir + "/out").output.c_str());
  }
  EXPECT_EQ(checked, 8 * 3);
  EXPECT_FALSE(std::filesystem::exists(dir + "/out"));
}

TEST(PdCliHostile, CommandLineErrorsAreOneLineStatingWhatIsAllowed) {
  const std::string dir = test::scratch_dir("cli_one_line");
  const std::string scene = write_file(dir, "s.json", small_scene()), o = dir + "/o.h5";
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"simulate", scene, "--out", o, "--frames", "-3"},
           {"simulate", scene, "--out", o, "--mode", "sideways"},
           {"simulate", scene, "--out", o, "--level", "99"},
           {"export", o, "--out", dir + "/e", "--format", "stl"},
           {"status", "0"},
           {"status", "--interval", "0", "--watch"},
           {"submit", scene, "--hessian", "exact"},
           {"workers", "add", "--slurm", "0"},
           {"plan", o, "--subsets", "0"}}) {
    const ArgvResult r = run_pd_argv(args);
    expect_one_line_error(r, joined(args));
    EXPECT_NE(r.output.find("; allowed: "), std::string::npos) << joined(args) << ": " << r.output;
    EXPECT_LT(r.output.size(), 200u) << "no 300-digit range: " << r.output;
  }
  expect_one_line_error(run_pd_argv({"simulate", scene}), "missing --out");
  expect_one_line_error(run_pd_argv({"simulate", scene, "--out", o, "--bogus"}), "unknown option");
}

TEST(PdCliHostile, NumbersAreDecimalNeverOctalOrHex) {
  const std::string dir = test::scratch_dir("cli_decimal");
  const std::string scene = write_file(dir, "s.json", small_scene());
  const ArgvResult ok = run_pd_argv({"simulate", scene, "--quiet", "--out", dir + "/o.h5", "--frames", "010"});
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_EQ(FrameReader(dir + "/o.h5").num_frames(), 11) << "010 is 10 frames (octal would be 8)";
  for (const char* bad : {"0x10", "1e3", "1.0", "", " 5", "010abc"}) {
    const ArgvResult r = run_pd_argv({"simulate", scene, "--out", dir + "/x.h5", "--frames", bad});
    expect_one_line_error(r, std::string("--frames '") + bad + "'");
    EXPECT_NE(r.output.find("is not a decimal integer"), std::string::npos) << r.output;
  }
  const ArgvResult hex_job = run_pd_argv({"status", "0x10"});
  expect_one_line_error(hex_job, "status 0x10");
  const ArgvResult hex_interval = run_pd_argv({"status", "--watch", "--interval", "0x1p1"});
  expect_one_line_error(hex_interval, "--interval 0x1p1");
  EXPECT_FALSE(std::filesystem::exists(dir + "/x.h5"));
}

TEST(PdCliHostile, OverflowingNumbersAreRefusedInOneLine) {
  const std::string dir = test::scratch_dir("cli_overflow");
  const std::string scene = write_file(dir, "s.json", small_scene());
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"simulate", scene, "--out", dir + "/o.h5", "--frames", "99999999999999999999999999"},
           {"status", "9223372036854775808"},
           {"cancel", "99999999999999999999"},
           {"submit", scene, "--priority", "2147483648"},
           {"submit", scene, "--priority", "-2147483649"},
           {"workers", "add", "--slurm", "4294967297"}}) {
    const ArgvResult r = run_pd_argv(args);
    expect_one_line_error(r, joined(args));
    EXPECT_NE(r.output.find("is out of range; allowed: "), std::string::npos) << joined(args) << ": " << r.output;
  }
}

TEST(PdCliHostile, FrameCountsNearIntMaxAreRefusedBeforeAnythingRuns) {
  const std::string dir = test::scratch_dir("cli_int_max");
  const std::string scene = write_file(dir, "s.json", small_scene());
  for (const char* frames : {"2147483647", "2147483646", "10000001"})
    for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
             {"simulate", scene, "--out", dir + "/o.h5", "--frames", frames},
             {"run", scene, "--workers", "1", "--out", dir + "/o.h5", "--frames", frames},
             {"submit", scene, "--frames", frames}}) {
      const ArgvResult r = run_pd_argv(args, 10);
      expect_one_line_error(r, joined(args));
      EXPECT_NE(r.output.find("allowed: 1..10000000"), std::string::npos) << r.output;
      EXPECT_LT(r.seconds, 2.0) << joined(args);
    }
  EXPECT_EQ(listing(dir), std::set<std::string>{"s.json"}) << "no output, no temporary";
}

TEST(PdCliHostile, OptionsThatDoNotApplyToTheModeAreRefusedNamingBoth) {
  const std::string dir = test::scratch_dir("cli_not_applying");
  const std::string direct = write_file(dir, "d.json", hierarchy_scene());  // no "mode": direct
  std::string text = hierarchy_scene();
  text.insert(text.find("\"hierarchy\""), "\"mode\": \"progressive\", ");
  const std::string progressive = write_file(dir, "p.json", text), o = dir + "/o.h5";
  ASSERT_EQ(run_pd_argv({"hierarchy", direct, "--out", dir + "/h.h5"}).exit_code, 0);
  const std::set<std::string> before = listing(dir);
  struct Case {
    std::vector<std::string> args;
    std::vector<std::string> named;
  };
  for (const Case& c : std::vector<Case>{
           {{"simulate", direct, "--out", o, "--mode", "direct", "--hessian", "coarse"}, {"--hessian", "--mode direct"}},
           {{"simulate", direct, "--out", o, "--hessian", "coarse"}, {"--hessian", "the scene's"}},
           {{"simulate", direct, "--out", o, "--mode", "direct", "--preview-only"}, {"--preview-only", "--mode direct"}},
           {{"simulate", direct, "--out", o, "--mode", "progressive", "--level", "0"}, {"--level", "--mode progressive"}},
           {{"simulate", progressive, "--out", o, "--level", "1"}, {"--level", "--mode progressive (the scene's"}},
           {{"export", dir + "/h.h5", "--rest", "--level", "1", "--out", dir + "/e"}, {"--level", "--rest"}},
           {{"submit", direct, "--preview-only", "--subsets", "2"}, {"--subsets", "--preview-only"}},
           {{"run", direct, "--workers", "1", "--out", o, "--preview-only", "--subsets", "2"},
            {"--subsets", "--preview-only"}},
           {{"status", "1", "--interval", "2"}, {"--interval", "--watch"}}}) {
    const ArgvResult r = run_pd_argv(c.args, 20);
    expect_one_line_error(r, joined(c.args));
    for (const std::string& n : c.named) EXPECT_NE(r.output.find(n), std::string::npos) << n << " in " << r.output;
  }
  EXPECT_EQ(listing(dir), before) << "nothing written";
}

TEST(PdCliHostile, LongAndControlCharacterValuesAreEchoedCutAndEscaped) {
  const std::string dir = test::scratch_dir("cli_echo");
  const std::string scene = write_file(dir, "s.json", small_scene());
  const std::string huge = std::string(100000, 'x') + "\n\x01";
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"simulate", scene, "--out", dir + "/o.h5", "--mode", huge},
           {"simulate", scene, "--out", dir + "/o.h5", "--frames", huge},
           {"keys", dir + "/k", huge}}) {  // an unexpected argument, repeated by CLI11
    const ArgvResult r = run_pd_argv(args);
    expect_one_line_error(r, joined(args));
    EXPECT_LT(r.output.size(), 400u) << r.output.substr(0, 400);
    EXPECT_NE(r.output.find("chars)"), std::string::npos) << r.output.substr(0, 400);
  }
  const ArgvResult ctl = run_pd_argv({"simulate", scene, "--out", dir + "/o.h5", "--mode", "a\nb\x1b[31mc\td"});
  expect_one_line_error(ctl, "control characters");
  EXPECT_NE(ctl.output.find("'a\\nb\\x1b[31mc\\td'"), std::string::npos) << ctl.output;
  const ArgvResult path = run_pd_argv({"simulate", dir + "/new\nline.json", "--out", dir + "/o.h5"});
  expect_one_line_error(path, "scene path with a newline");
  EXPECT_NE(path.output.find("new\\nline.json"), std::string::npos) << path.output;
}

TEST(PdCliHostile, OutputEqualToAnInputIsRefusedAndTheInputIsUnchanged) {
  const std::string dir = test::scratch_dir("cli_out_is_in");
  write_file(dir, "sheet.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n");
  std::string obj_text = small_scene(R"("density": 200, "youngs_modulus": 1e5, "poisson_ratio": 0.3, "thickness": 0.001)",
                                     R"({"type": "obj", "path": "sheet.obj"})");
  obj_text.replace(obj_text.find("[20, 24]"), 8, "[0, 1]");
  const std::string obj_scene = write_file(dir, "obj.json", obj_text);
  const std::string scene = write_file(dir, "s.json", small_scene());
  ASSERT_EQ(run_pd_argv({"simulate", scene, "--quiet", "--out", dir + "/o.h5"}).exit_code, 0);
  std::filesystem::create_symlink(dir + "/s.json", dir + "/link.json");
  const std::set<std::string> before = listing(dir);
  const std::string scene_text = file_bytes(scene), obj_bytes = file_bytes(dir + "/sheet.obj"),
                    frames = file_bytes(dir + "/o.h5");
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"simulate", scene, "--out", scene},
           {"simulate", scene, "--out", dir + "/./s.json"},
           {"simulate", scene, "--out", dir + "/link.json"},
           {"simulate", obj_scene, "--out", dir + "/sheet.obj"},
           {"hierarchy", scene, "--out", scene},
           {"compare", dir + "/o.h5", "--csv", dir + "/o.h5"},
           {"run", scene, "--workers", "1", "--out", scene}}) {
    const ArgvResult r = run_pd_argv(args, 20);
    expect_one_line_error(r, joined(args));
    EXPECT_NE(r.output.find("is the input"), std::string::npos) << joined(args) << ": " << r.output;
  }
  EXPECT_EQ(file_bytes(scene), scene_text);
  EXPECT_EQ(file_bytes(dir + "/sheet.obj"), obj_bytes);
  EXPECT_EQ(file_bytes(dir + "/o.h5"), frames);
  EXPECT_EQ(listing(dir), before);
}

TEST(PdCliHostile, FifoAsInputOrOutputIsRefusedWithinBoundedTime) {
  const std::string dir = test::scratch_dir("cli_fifo");
  const std::string scene = write_file(dir, "s.json", small_scene()), fifo = dir + "/fifo";
  ASSERT_EQ(run_pd_argv({"simulate", scene, "--quiet", "--out", dir + "/o.h5"}).exit_code, 0);
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string o = dir + "/o.h5";
  const std::string obj_fifo = write_file(dir, "obj.json",  // a mesh path naming the FIFO
      small_scene(R"("density": 200, "youngs_modulus": 1e5, "poisson_ratio": 0.3, "thickness": 0.001)",
                  R"({"type": "obj", "path": "fifo"})"));
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"simulate", obj_fifo, "--out", dir + "/x.h5"},
           {"hierarchy", obj_fifo, "--out", dir + "/x.h5"},
           {"submit", obj_fifo},
           {"simulate", fifo, "--out", dir + "/x.h5"},
           {"hierarchy", fifo, "--out", dir + "/x.h5"},
           {"submit", fifo},
           {"export", fifo, "--out", dir + "/e"},
           {"compare", fifo, "--csv", dir + "/c.csv"},
           {"compare", o, fifo, "--csv", dir + "/c.csv"},
           {"plan", fifo},
           {"simulate", scene, "--out", fifo},
           {"hierarchy", scene, "--out", fifo},
           {"compare", o, "--csv", fifo},
           {"export", o, "--out", fifo}}) {
    const ArgvResult r = run_pd_argv(args, 10);
    EXPECT_FALSE(r.timed_out) << joined(args) << " blocked on the FIFO";
    expect_one_line_error(r, joined(args));
    EXPECT_NE(r.output.find("FIFO"), std::string::npos) << joined(args) << ": " << r.output;
    EXPECT_LT(r.seconds, 5.0) << joined(args);
  }
}

TEST(PdCliHostile, FolderAsOutputFileAndFileAsOutputFolderAreRefused) {
  const std::string dir = test::scratch_dir("cli_folder_out");
  const std::string scene = write_file(dir, "s.json", small_scene()), sub = dir + "/sub";
  ASSERT_EQ(run_pd_argv({"simulate", scene, "--quiet", "--out", dir + "/o.h5"}).exit_code, 0);
  std::filesystem::create_directories(sub);
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"simulate", scene, "--out", sub}, {"hierarchy", scene, "--out", sub},
           {"compare", dir + "/o.h5", "--csv", sub}, {"simulate", scene, "--out", dir + "/no/such/o.h5"}}) {
    const ArgvResult r = run_pd_argv(args);
    expect_one_line_error(r, joined(args));
  }
  EXPECT_TRUE(std::filesystem::is_empty(sub));
  const ArgvResult onto_file = run_pd_argv({"export", dir + "/o.h5", "--out", scene});
  expect_one_line_error(onto_file, "export --out FILE");
  EXPECT_NE(onto_file.output.find("not a folder"), std::string::npos) << onto_file.output;
}

TEST(PdCliHostile, NoDebrisAfterAnError) {
  const std::string dir = test::scratch_dir("cli_debris");
  const std::string scene = write_file(dir, "s.json", hierarchy_scene());
  ASSERT_EQ(run_pd_argv({"simulate", scene, "--quiet", "--frames", "60", "--out", dir + "/o.h5"}).exit_code, 0);
  ASSERT_EQ(run_pd_argv({"compare", dir + "/o.h5", "--csv", dir + "/c.csv"}).exit_code, 0);
  std::filesystem::create_directories(dir + "/frames/frame_00001.obj");  // a folder where a frame goes
  const std::string csv = file_bytes(dir + "/c.csv");
  const std::set<std::string> before = listing(dir);
  // Writes that fail part-way (file size limit 8 KB: EFBIG, as on a full disk).
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"hierarchy", scene, "--out", dir + "/h.h5"},
           {"compare", dir + "/o.h5", "--csv", dir + "/c.csv"},
           {"export", dir + "/o.h5", "--out", dir + "/e"}}) {
    const ArgvResult r = run_pd_argv(args, 60, 8192);
    EXPECT_NE(r.exit_code, 0) << joined(args) << ": " << r.output;
    EXPECT_TRUE(r.exit_code == 1 || r.exit_code == 2) << "no crash: " << joined(args) << ": " << r.output;
    EXPECT_EQ(listing(dir), before) << joined(args);
  }
  // A failure after every frame was written: one target is a folder.
  const ArgvResult blocked = run_pd_argv({"export", dir + "/o.h5", "--out", dir + "/frames"});
  expect_one_line_error(blocked, "export onto a folder named like a frame");
  // A scene refused before simulating.
  std::string bad = hierarchy_scene();
  bad.replace(bad.find("[0, 0, -1]"), 10, "[0, 0, 0]");  // the ball through the sheet
  const ArgvResult refused = run_pd_argv({"simulate", write_file(dir, "bad.json", bad), "--out", dir + "/b.h5"});
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  std::set<std::string> expected = before;
  expected.insert("bad.json");
  EXPECT_EQ(listing(dir), expected);
  EXPECT_EQ(file_bytes(dir + "/c.csv"), csv);
}

// A long scene: frames 0..2000 of the small sheet (seconds to run).
std::string long_scene() {
  std::string text = small_scene();
  text.replace(text.find("\"frames\": 3"), 11, "\"frames\": 2000");
  return text;
}

TEST(PdCliHostile, SimulateKeepsTheFramesStoredBeforeAnInterrupt) {
  const std::string dir = test::scratch_dir("cli_keep_frames");
  const std::string scene = write_file(dir, "s.json", long_scene()), o = dir + "/o.h5";
  const ArgvResult r = run_pd_argv({"simulate", scene, "--quiet", "--out", o}, 120, 0, o + ".partial");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_NE(r.output.find("interrupted by SIGTERM"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("stored before the error are in " + o), std::string::npos) << r.output;
  EXPECT_EQ(listing(dir), (std::set<std::string>{"s.json", "o.h5"})) << "renamed, no o.h5.partial";
  if (!std::filesystem::exists(o)) return;
  const FrameReader reader(o);
  const std::vector<uint8_t> done = reader.done(0);
  ASSERT_EQ(done.size(), 2001u);
  const auto stored = std::count(done.begin(), done.end(), 1);
  EXPECT_GE(stored, 2);
  EXPECT_LT(stored, 2001) << "the run stopped early";
  for (int t = 0; t < stored; ++t) EXPECT_EQ(done[static_cast<std::size_t>(t)], 1) << "frames 0..k in order, t " << t;
  EXPECT_EQ(reader.frame(0, static_cast<int>(stored) - 1).rows(), 25);
}

TEST(PdCliHostile, SimulateWriteErrorLeavesTheOldOutputAndNoDamagedFile) {
  const std::string dir = test::scratch_dir("cli_write_error");
  const std::string o = dir + "/o.h5";
  ASSERT_EQ(run_pd_argv({"simulate", write_file(dir, "small.json", small_scene()), "--quiet", "--out", o}).exit_code, 0);
  const std::string old = file_bytes(o);
  const std::string scene = write_file(dir, "s.json", long_scene());
  // File size limit 100 KB: HDF5's write fails part-way, as on a full disk (EFBIG).
  const ArgvResult r = run_pd_argv({"simulate", scene, "--quiet", "--out", o}, 120, 100 * 1024);
  EXPECT_EQ(r.exit_code, 2) << "an error, not a crash (HDF5's exit handler): " << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_FALSE(std::filesystem::exists(o + ".partial"));
  if (r.output.find("stored before the error are in") == std::string::npos) {
    EXPECT_EQ(file_bytes(o), old) << "a damaged run does not replace OUT: " << r.output;
    return;
  }
  const FrameReader reader(o);  // kept: then every stored frame reads back
  const std::vector<uint8_t> done = reader.done(0);
  for (int t = 0; t < static_cast<int>(done.size()); ++t)
    if (done[static_cast<std::size_t>(t)]) {
      EXPECT_NO_THROW(reader.frame(0, t)) << t;
    }
}

TEST(PdCliHostile, AnExistingOutputOfAnotherKindIsRefusedUnlessForce) {
  const std::string dir = test::scratch_dir("cli_force");
  const std::string scene = write_file(dir, "s.json", hierarchy_scene());
  const std::string notes = write_file(dir, "notes.h5", "my notes, not a frame file");
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"hierarchy", scene, "--out", notes}, {"simulate", scene, "--quiet", "--out", notes}}) {
    const ArgvResult r = run_pd_argv(args);
    expect_one_line_error(r, joined(args));
    EXPECT_NE(r.output.find("exists and is not a frame file; give --force"), std::string::npos) << r.output;
    EXPECT_EQ(file_bytes(notes), "my notes, not a frame file");
  }
  ASSERT_EQ(run_pd_argv({"hierarchy", scene, "--out", notes, "--force"}).exit_code, 0);
  EXPECT_TRUE(read_hierarchy(notes).has_value());
  // A frame file is the kind simulate and hierarchy write: replaced without --force.
  ASSERT_EQ(run_pd_argv({"simulate", scene, "--quiet", "--out", notes}).exit_code, 0);
  ASSERT_EQ(run_pd_argv({"hierarchy", scene, "--out", notes}).exit_code, 0);
  const std::string table = write_file(dir, "table.csv", "a,b\n1,2\n");
  const ArgvResult csv = run_pd_argv({"compare", notes, "--csv", table});
  expect_one_line_error(csv, "compare --csv onto another CSV");
  EXPECT_EQ(file_bytes(table), "a,b\n1,2\n");
}

TEST(PdCliHostile, CompareRefusesFilesOfDifferentScenes) {
  const std::string dir = test::scratch_dir("cli_compare_scenes");
  const std::string a = write_file(dir, "a.json", small_scene());
  std::string bigger = small_scene();
  bigger.replace(bigger.find("[0.5, 0.5]"), 10, "[0.6, 0.6]");  // same topology, other rest shape
  std::string renamed = small_scene();
  renamed.replace(renamed.find("\"sheet\""), 7, "\"cloth\"");
  std::string finer = small_scene();
  finer.replace(finer.find("[4, 4]"), 6, "[4, 5]");
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"a", small_scene()}, {"bigger", bigger}, {"renamed", renamed}, {"finer", finer}}) {
    const std::string s = name == "a" ? a : write_file(dir, name + ".json", text);
    ASSERT_EQ(run_pd_argv({"simulate", s, "--quiet", "--out", dir + "/" + name + ".h5"}).exit_code, 0) << name;
  }
  ASSERT_EQ(run_pd_argv({"simulate", a, "--quiet", "--frames", "5", "--out", dir + "/a5.h5"}).exit_code, 0);
  EXPECT_EQ(run_pd_argv({"compare", dir + "/a.h5", dir + "/a5.h5", "--csv", dir + "/ok.csv"}).exit_code, 0)
      << "another frame count is the same scene";
  for (const char* other : {"bigger", "renamed", "finer"}) {
    const std::string f = dir + "/" + other + ".h5";
    const ArgvResult r = run_pd_argv({"compare", dir + "/a.h5", f, "--json", "--csv", dir + "/c.csv"});
    expect_one_line_error(r, other);
    EXPECT_NE(r.output.find(f + ": is not a run of the scene of " + dir + "/a.h5"), std::string::npos) << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/c.csv"));
}


// ---- pd export --format pc2, --frames, --per-object (issue 45, item 4) ------------------------------

// A PC2 file read from the format's specification alone (not with pd's writer): little-endian
// char[12] "POINTCACHE2\0", int32 version, int32 points, float32 start frame, float32 sample rate,
// int32 samples, then samples x points x (x, y, z) float32.
struct Pc2Read {
  std::string bytes;  // the whole file
  int32_t version = 0, points = 0, samples = 0;
  float start = 0, rate = 0;
  uint32_t word(std::size_t at) const {
    return static_cast<uint32_t>(static_cast<unsigned char>(bytes[at])) |
           static_cast<uint32_t>(static_cast<unsigned char>(bytes[at + 1])) << 8 |
           static_cast<uint32_t>(static_cast<unsigned char>(bytes[at + 2])) << 16 |
           static_cast<uint32_t>(static_cast<unsigned char>(bytes[at + 3])) << 24;
  }
  float real(std::size_t at) const {
    const uint32_t w = word(at);
    float f;
    std::memcpy(&f, &w, 4);
    return f;
  }
  // Coordinate k (0 = x) of point v in sample s.
  float at(int s, int v, int k) const { return real(32 + (static_cast<std::size_t>(s) * points + v) * 12 + 4 * k); }
};

Pc2Read read_pc2(const std::string& path) {
  Pc2Read r;
  std::ifstream in(path, std::ios::binary);
  r.bytes.assign(std::istreambuf_iterator<char>(in), {});
  if (r.bytes.size() < 32) return r;
  r.version = static_cast<int32_t>(r.word(12));
  r.points = static_cast<int32_t>(r.word(16));
  r.start = r.real(20);
  r.rate = r.real(24);
  r.samples = static_cast<int32_t>(r.word(28));
  return r;
}

// The little-endian bytes of a 32-bit value, to compare the header byte by byte.
std::string le_bytes(uint32_t w) {
  return {static_cast<char>(w & 0xff), static_cast<char>((w >> 8) & 0xff), static_cast<char>((w >> 16) & 0xff),
          static_cast<char>((w >> 24) & 0xff)};
}
std::string le_bytes(float f) {
  uint32_t w;
  std::memcpy(&w, &f, 4);
  return le_bytes(w);
}

// Checks the 32-byte header field by field, byte by byte, and the file's length.
void expect_pc2_header(const Pc2Read& c, int points, float start, int samples, const std::string& what) {
  ASSERT_GE(c.bytes.size(), 32u) << what;
  EXPECT_EQ(c.bytes.substr(0, 12), std::string("POINTCACHE2\0", 12)) << what;
  EXPECT_EQ(c.bytes.substr(12, 4), std::string("\x01\x00\x00\x00", 4)) << what << ": file version 1";
  EXPECT_EQ(c.bytes.substr(16, 4), le_bytes(static_cast<uint32_t>(points))) << what << ": points";
  EXPECT_EQ(c.bytes.substr(20, 4), le_bytes(start)) << what << ": start frame";
  EXPECT_EQ(c.bytes.substr(24, 4), std::string("\x00\x00\x80\x3f", 4)) << what << ": sample rate 1.0f";
  EXPECT_EQ(c.bytes.substr(28, 4), le_bytes(static_cast<uint32_t>(samples))) << what << ": samples";
  EXPECT_EQ(c.bytes.size(), 32u + static_cast<std::size_t>(samples) * points * 12) << what << ": file length";
}

// Every coordinate of every sample equals static_cast<float> of frame first + s, rows [row0, row0 + points).
void expect_pc2_samples(const Pc2Read& c, const std::vector<Positions>& frames, int row0, const std::string& what) {
  ASSERT_EQ(c.samples, static_cast<int>(frames.size())) << what;
  int mismatches = 0;
  for (int s = 0; s < c.samples; ++s)
    for (int v = 0; v < c.points; ++v)
      for (int k = 0; k < 3; ++k)
        if (c.at(s, v, k) != static_cast<float>(frames[s](row0 + v, k)) && ++mismatches <= 5)
          ADD_FAILURE() << what << ": sample " << s << " vertex " << v << " axis " << k << ": " << c.at(s, v, k)
                        << " != " << static_cast<float>(frames[s](row0 + v, k));
  EXPECT_EQ(mismatches, 0) << what;
}

std::vector<Positions> stored_frames(const FrameReader& r, int level, int first, int last) {
  std::vector<Positions> out;
  for (int t = first; t <= last; ++t) out.push_back(r.frame(level, t));
  return out;
}

// Two objects: the small pinned sheet and a second, 2 x 3-cell sheet 2 m away, named with a space.
std::string two_object_scene(int frames) {
  return R"({"format_version": 1, "name": "two", "time_step": 0.01, "frames": )" + std::to_string(frames) + R"(,
  "objects": [
    {"name": "sheet", "mesh": {"type": "rectangle", "size": [0.5, 0.5], "cells": [4, 4]},
     "material": {"density": 200, "youngs_modulus": 1e5, "poisson_ratio": 0.3, "thickness": 0.001},
     "pins": [{"indices": [20, 24]}]},
    {"name": "flag two", "mesh": {"type": "rectangle", "size": [0.4, 0.3], "cells": [2, 3]},
     "material": {"density": 200, "youngs_modulus": 1e5, "poisson_ratio": 0.3, "thickness": 0.001},
     "transform": {"translation": [2, 0, 0]}, "pins": [{"indices": [0, 1]}]}]})";
}

TEST(PdCliExport, Pc2HeaderAndEveryVertexOfEveryFrameMatchTheFrameFileAsFloat32) {
  const std::string dir = test::scratch_dir("cli_pc2");
  const std::string scene = write_file(dir, "s.json", small_scene());
  ASSERT_EQ(run_pd_argv({"simulate", scene, "--quiet", "--frames", "8", "--out", dir + "/o.h5"}).exit_code, 0);
  const ArgvResult r = run_pd_argv({"export", dir + "/o.h5", "--format", "pc2", "--out", dir + "/cache"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(listing(dir + "/cache"), (std::set<std::string>{"level_0.pc2", "level_0.obj"}));
  EXPECT_EQ(r.output.find("note"), std::string::npos) << "every frame stored: " << r.output;
  const FrameReader reader(dir + "/o.h5");
  ASSERT_EQ(reader.num_frames(), 9);
  const Pc2Read c = read_pc2(dir + "/cache/level_0.pc2");
  expect_pc2_header(c, reader.num_vertices(0), 0.0f, 9, "level_0.pc2");
  EXPECT_EQ(c.version, 1);
  EXPECT_EQ(c.rate, 1.0f);
  expect_pc2_samples(c, stored_frames(reader, 0, 0, 8), 0, "level_0.pc2");

  // The rest mesh beside it: the level's rest positions and faces, in the cache's vertex order.
  const TriMesh rest = read_obj(dir + "/cache/level_0.obj");
  EXPECT_EQ(rest.V.rows(), c.points);
  EXPECT_EQ(rest.V, reader.rest_positions(0));
  EXPECT_EQ(rest.F, reader.faces(0));
}

TEST(PdCliExport, FramesRangeSetsThePc2StartFrameAndSampleCountAndTheObjFilesWritten) {
  const std::string dir = test::scratch_dir("cli_pc2_range");
  const std::string scene = write_file(dir, "s.json", small_scene());
  ASSERT_EQ(run_pd_argv({"simulate", scene, "--quiet", "--frames", "8", "--out", dir + "/o.h5"}).exit_code, 0);
  const ArgvResult r =
      run_pd_argv({"export", dir + "/o.h5", "--format", "pc2", "--frames", "3:6", "--out", dir + "/cache"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const FrameReader reader(dir + "/o.h5");
  const Pc2Read c = read_pc2(dir + "/cache/level_0.pc2");
  expect_pc2_header(c, reader.num_vertices(0), 3.0f, 4, "--frames 3:6");
  expect_pc2_samples(c, stored_frames(reader, 0, 3, 6), 0, "--frames 3:6");

  const ArgvResult one =
      run_pd_argv({"export", dir + "/o.h5", "--format", "pc2", "--frames", "8:8", "--out", dir + "/last"});
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const Pc2Read l = read_pc2(dir + "/last/level_0.pc2");
  expect_pc2_header(l, reader.num_vertices(0), 8.0f, 1, "--frames 8:8");
  expect_pc2_samples(l, stored_frames(reader, 0, 8, 8), 0, "--frames 8:8");

  const ArgvResult obj = run_pd_argv({"export", dir + "/o.h5", "--frames", "1:2", "--out", dir + "/objs"});
  ASSERT_EQ(obj.exit_code, 0) << obj.output;
  EXPECT_EQ(listing(dir + "/objs"), (std::set<std::string>{"frame_00001.obj", "frame_00002.obj"}));
  EXPECT_EQ(read_obj(dir + "/objs/frame_00002.obj").V, reader.frame(0, 2));
}

TEST(PdCliExport, PerObjectWritesOnePc2AndRestObjPairPerObjectWithItsVertices) {
  const std::string dir = test::scratch_dir("cli_pc2_objects");
  const std::string scene = write_file(dir, "s.json", two_object_scene(4));
  ASSERT_EQ(run_pd_argv({"simulate", scene, "--quiet", "--out", dir + "/o.h5"}).exit_code, 0);
  const ArgvResult r = run_pd_argv({"export", dir + "/o.h5", "--format", "pc2", "--per-object", "--out", dir + "/c"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(listing(dir + "/c"), (std::set<std::string>{"level_0_sheet.pc2", "level_0_sheet.obj",
                                                        "level_0_flag_two.pc2", "level_0_flag_two.obj"}));
  const FrameReader reader(dir + "/o.h5");
  const std::vector<int> off = reader.object_offsets(0);
  ASSERT_EQ(off, (std::vector<int>{0, 25, 37}));  // 5 x 5 and 3 x 4 grid vertices
  const Faces F = reader.faces(0);
  const std::vector<Positions> frames = stored_frames(reader, 0, 0, 4);
  int faces_seen = 0;
  const std::vector<std::pair<int, std::string>> objects{{0, "level_0_sheet"}, {1, "level_0_flag_two"}};
  for (const auto& [k, stem] : objects) {
    const int n = off[k + 1] - off[k];
    const Pc2Read c = read_pc2(dir + "/c/" + stem + ".pc2");
    expect_pc2_header(c, n, 0.0f, 5, stem);
    expect_pc2_samples(c, frames, off[k], stem);
    const TriMesh rest = read_obj(dir + "/c/" + stem + ".obj");
    EXPECT_EQ(rest.V.rows(), n) << stem;
    EXPECT_EQ(rest.V, reader.rest_positions(0).middleRows(off[k], n)) << stem;
    // The object's faces of the level, in order, renumbered from its first vertex.
    for (Eigen::Index f = 0; f < rest.F.rows(); ++f)
      EXPECT_TRUE(((rest.F.row(f).array() + off[k]) == F.row(faces_seen + f).array()).all()) << stem << " face " << f;
    faces_seen += static_cast<int>(rest.F.rows());
  }
  EXPECT_EQ(faces_seen, F.rows()) << "every face in one object's OBJ";

  const ArgvResult obj = run_pd_argv({"export", dir + "/o.h5", "--per-object", "--frames", "4:4", "--out", dir + "/o"});
  ASSERT_EQ(obj.exit_code, 0) << obj.output;
  EXPECT_EQ(listing(dir + "/o"), (std::set<std::string>{"sheet_frame_00004.obj", "flag_two_frame_00004.obj"}));
  EXPECT_EQ(read_obj(dir + "/o/flag_two_frame_00004.obj").V, frames[4].middleRows(25, 12));
}

// A job file of hierarchy_scene() with frames 0..5, of which level 0 has 0, 1, 2 and 4 stored (3 and 5
// missing, as in a job still being written): rest shape, then shifted by t cm.
std::string job_with_a_gap(const std::string& dir, std::optional<SceneHierarchy>& h) {
  const std::string scene = write_file(dir, "s.json", hierarchy_scene());
  EXPECT_EQ(run_pd_argv({"hierarchy", scene, "--out", dir + "/h.h5"}).exit_code, 0);
  h = read_hierarchy(dir + "/h.h5");
  const std::string job = dir + "/job.h5";
  if (!h) return job;
  const std::vector<std::string> names{"sheet", "ball"};
  FrameWriter w = FrameWriter::create(job, hierarchy_scene(), 5);
  write_hierarchy(job, *h, names);
  add_hierarchy_levels(w, *h, names);
  for (const int t : {0, 1, 2, 4}) w.write_frame(0, t, h->levels[0].rest.V.array() + 0.01 * t, FrameStats{});
  w.close();
  return job;
}

TEST(PdCliExport, ProlongPc2CachesTheFinestMeshAndStopsAtTheFirstMissingFrame) {
  const std::string dir = test::scratch_dir("cli_pc2_prolong");
  std::optional<SceneHierarchy> h;
  const std::string job = job_with_a_gap(dir, h);
  ASSERT_TRUE(h.has_value());
  const ArgvResult r =
      run_pd_argv({"export", job, "--prolong", "--level", "0", "--format", "pc2", "--out", dir + "/c"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(listing(dir + "/c"), (std::set<std::string>{"level_0_prolonged.pc2", "level_0_prolonged.obj"}));
  // Frames 0..2 (the run before the missing frame 3), and stderr says what was left out.
  EXPECT_NE(r.output.find("pd export: note: level 0: exported frames 0..2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("stored: 0..2, 4"), std::string::npos) << r.output;
  const SceneLevel& finest = h->levels.back();
  const int n = static_cast<int>(finest.rest.V.rows());
  const Pc2Read c = read_pc2(dir + "/c/level_0_prolonged.pc2");
  expect_pc2_header(c, n, 0.0f, 3, "prolonged");
  const FrameReader reader(job);
  std::vector<Positions> fine;
  for (int t = 0; t <= 2; ++t) fine.push_back(h->levels[0].to_finest_prolongation->apply(reader.frame(0, t)));
  expect_pc2_samples(c, fine, 0, "prolonged");
  const TriMesh rest = read_obj(dir + "/c/level_0_prolonged.obj");
  EXPECT_EQ(rest.V.rows(), n);
  EXPECT_EQ(rest.V, finest.rest.V);
  EXPECT_EQ(rest.F, finest.rest.F);

  // Per object on the finest mesh: the finest objects' vertex counts.
  const ArgvResult po = run_pd_argv(
      {"export", job, "--prolong", "--format", "pc2", "--per-object", "--frames", "1:2", "--out", dir + "/po"});
  ASSERT_EQ(po.exit_code, 0) << po.output;
  const std::vector<int>& off = finest.vertex_offsets;
  EXPECT_EQ(read_pc2(dir + "/po/level_0_prolonged_sheet.pc2").points, off[1] - off[0]);
  EXPECT_EQ(read_pc2(dir + "/po/level_0_prolonged_ball.pc2").points, off[2] - off[1]);
  EXPECT_EQ(read_pc2(dir + "/po/level_0_prolonged_ball.pc2").start, 1.0f);
}

TEST(PdCliExport, AMissingFrameInsideFramesIsRefusedNamingItAndObjWithoutFramesSaysWhatIsMissing) {
  const std::string dir = test::scratch_dir("cli_pc2_missing");
  std::optional<SceneHierarchy> h;
  const std::string job = job_with_a_gap(dir, h);
  ASSERT_TRUE(h.has_value());
  for (const char* format : {"pc2", "obj"}) {
    const ArgvResult r = run_pd_argv({"export", job, "--format", format, "--frames", "1:4", "--out", dir + "/e"});
    expect_one_line_error(r, format);
    EXPECT_NE(r.output.find("--frames 1:4: frame 3 of level 0 is not stored yet"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(dir + "/e")) << format;
  }
  // OBJ frames are one file each: every stored frame is written, and the missing ones are named.
  const ArgvResult obj = run_pd_argv({"export", job, "--out", dir + "/objs"});
  ASSERT_EQ(obj.exit_code, 0) << obj.output;
  EXPECT_EQ(count_objs(dir + "/objs"), 4);
  EXPECT_NE(obj.output.find("2 of frames 0..5 are not stored yet and were not written (stored: 0..2, 4)"),
            std::string::npos) << obj.output;
}

TEST(PdCliExport, BadFramesOptionExitsWith2NamingFramesAndWritesNothing) {
  const std::string dir = test::scratch_dir("cli_pc2_bad_frames");
  const std::string scene = write_file(dir, "s.json", small_scene());
  ASSERT_EQ(run_pd_argv({"simulate", scene, "--quiet", "--out", dir + "/o.h5"}).exit_code, 0);  // frames 0..3
  const std::set<std::string> before = listing(dir);
  struct Case {
    std::string value, expected;
  };
  for (const char* format : {"pc2", "obj"})
    for (const Case& c : std::vector<Case>{{"0:4", "--frames 0:4: level 0 has frames 0..3 (stored: 0..3)"},
                                           {"7:9", "--frames 7:9: level 0 has frames 0..3"},
                                           {"3:1", "--frames: '3:1' is reversed"},
                                           {"2", "--frames: '2' is not FIRST:LAST"},
                                           {"1:2:3", "--frames: '1:2:3' is not FIRST:LAST"},
                                           {"-1:2", "--frames: FIRST of '-1:2': '-1' is out of range"},
                                           {"0x1:2", "--frames: FIRST of '0x1:2': '0x1' is not a decimal integer"},
                                           {"1:", "--frames: LAST of '1:': '' is not a decimal integer"},
                                           {"a:b", "--frames: FIRST of 'a:b'"},
                                           {"", "--frames: an empty value"}}) {
      const ArgvResult r = run_pd_argv({"export", dir + "/o.h5", "--format", format, "--frames", c.value, "--out",
                                        dir + "/e"});
      expect_one_line_error(r, format + (" --frames " + c.value));
      EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.value << ": " << r.output;
    }
  EXPECT_EQ(listing(dir), before) << "nothing written";
}

TEST(PdCliExport, Pc2RefusesCoordinatesBeyondFloat32NamingFrameAndVertexAndWritesNothing) {
  const std::string dir = test::scratch_dir("cli_pc2_overflow");
  // A one-triangle frame file whose frame 1 puts vertex 2 at z = 1e39 m (a double, beyond float32).
  const std::string file = dir + "/big.h5";
  {
    Positions rest(3, 3);
    rest << 0, 0, 0, 1, 0, 0, 0, 1, 0;
    Faces F(1, 3);
    F << 0, 1, 2;
    FrameWriter w = FrameWriter::create(file, small_scene(), 1);
    w.add_level(0, rest, F, {0, 3}, {"tri"});
    w.write_frame(0, 0, rest, FrameStats{});
    Positions far = rest;
    far(2, 2) = 1e39;
    w.write_frame(0, 1, far, FrameStats{});
    w.close();
  }
  const ArgvResult r = run_pd_argv({"export", file, "--format", "pc2", "--out", dir + "/c"});
  expect_one_line_error(r, "1e39");
  EXPECT_NE(r.output.find("/levels/0/positions: frame 1: vertex 2 (object 'tri' vertex 2): coordinate z = 1e+39 m "
                          "does not fit a float32"),
            std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/c"));
  // Frame 0 alone fits; OBJ keeps doubles, so it writes 1e39 as it is.
  EXPECT_EQ(run_pd_argv({"export", file, "--format", "pc2", "--frames", "0:0", "--out", dir + "/c0"}).exit_code, 0);
  ASSERT_EQ(run_pd_argv({"export", file, "--out", dir + "/objs"}).exit_code, 0);
  EXPECT_EQ(read_obj(dir + "/objs/frame_00001.obj").V(2, 2), 1e39);
}

TEST(PdCliExport, FramesPerObjectAndPc2DoNotApplyToRestAlone) {
  const std::string dir = test::scratch_dir("cli_pc2_rest");
  const std::string scene = write_file(dir, "s.json", small_scene());
  ASSERT_EQ(run_pd_argv({"simulate", scene, "--quiet", "--out", dir + "/o.h5"}).exit_code, 0);
  for (const auto& [extra, named] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--frames", "0:1"}, "--frames"},
           {{"--per-object"}, "--per-object"},
           {{"--format", "pc2"}, "--format pc2"}}) {
    std::vector<std::string> args{"export", dir + "/o.h5", "--rest", "--out", dir + "/e"};
    args.insert(args.end(), extra.begin(), extra.end());
    const ArgvResult r = run_pd_argv(args);
    expect_one_line_error(r, joined(args));
    EXPECT_NE(r.output.find(named + ": does not apply to --rest alone"), std::string::npos) << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/e"));
}

}  // namespace
}  // namespace pd
