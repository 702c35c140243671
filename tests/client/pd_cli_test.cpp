// The pd binary end to end: exit codes and messages for bad input, a small simulate + export, pd
// hierarchy and pd compare. Hostile command lines: pd_cli_hostile_test.cpp; PC2 and ranged exports:
// export_command_test.cpp; the shared runners: support/pd_cli.h.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
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
#include "support/pd_cli.h"

namespace pd {
namespace {

using namespace cli_test;

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

}  // namespace
}  // namespace pd
