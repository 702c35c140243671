// The pd binary end to end: exit codes and messages for bad input, and a small simulate + export.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "store/frame_store.h"
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

}  // namespace
}  // namespace pd
