// Hostile command lines and output files for the pd binary (issue 17): one-line errors stating what
// is allowed, FIFOs, interrupts, write errors, no debris, and the frame files HDF5 crashes on.
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

// ---- hostile command lines and output files (issue 17) ---------------------------------------------

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

}  // namespace
}  // namespace pd
