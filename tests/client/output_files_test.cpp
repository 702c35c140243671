// client/output_files: input and output checks and the temporary-then-rename outputs (in-process;
// the pd commands that use them are checked end to end in pd_cli_test.cpp).
#include "output_files.h"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "store/frame_store.h"
#include "support/input_error_of.h"
#include "support/test_paths.h"

namespace pd::cli {
namespace {

namespace fs = std::filesystem;

std::string write_text(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

TEST(OutputFiles, SameFileByInodeAndByPathWhenMissing) {
  const std::string dir = test::scratch_dir("of_same");
  const std::string a = write_text(dir + "/a.json", "{}");
  fs::create_symlink(a, dir + "/link.json");
  EXPECT_TRUE(same_file(a, dir + "/./a.json"));
  EXPECT_TRUE(same_file(a, dir + "/link.json"));
  EXPECT_FALSE(same_file(a, write_text(dir + "/b.json", "{}")));
  EXPECT_TRUE(same_file(dir + "/new.h5", dir + "/sub/../new.h5"));
  EXPECT_FALSE(same_file(dir + "/new.h5", a));
}

TEST(OutputFiles, SpecialFilesAndFoldersAreRefusedWithoutOpening) {
  const std::string dir = test::scratch_dir("of_special");
  const std::string fifo = dir + "/fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  // Opening the FIFO would block this test forever: the checks must stat it only.
  EXPECT_NE(test::input_error_of([&] { check_input_file(fifo, "scene file"); }).find("is a FIFO"), std::string::npos);
  EXPECT_NE(test::input_error_of([&] { check_output_file(fifo, "--out", {}); }).find("is a FIFO"), std::string::npos);
  EXPECT_NE(test::input_error_of([&] { check_output_folder(fifo, "--out", {}); }).find("FIFO"), std::string::npos);
  EXPECT_FALSE(is_frame_file(fifo));
  EXPECT_NE(test::input_error_of([&] { check_input_file(dir, "scene file"); }).find("is a folder"), std::string::npos);
  EXPECT_NE(test::input_error_of([&] { check_output_file(dir, "--out", {}); }).find("is a folder"), std::string::npos);
  EXPECT_NE(test::input_error_of([&] { check_input_file("/dev/null", "frame file"); }).find("character device"),
            std::string::npos);
  EXPECT_NE(test::input_error_of([&] { check_output_file(dir + "/no/such/x.h5", "--out", {}); })
                .find("does not exist"), std::string::npos);
}

TEST(OutputFiles, OutputEqualToAnInputIsRefused) {
  const std::string dir = test::scratch_dir("of_in_out");
  const std::string scene = write_text(dir + "/s.json", "{}");
  const std::string msg = test::input_error_of([&] { check_output_file(dir + "/./s.json", "--out", {scene}); });
  EXPECT_EQ(msg.rfind(dir + "/./s.json: --out: is the input", 0), 0u) << msg;
  EXPECT_EQ(test::input_error_of([&] { check_output_file(dir + "/o.h5", "--out", {scene}); }), "(no InputError thrown)");
}

TEST(OutputFiles, KindChecksRecogniseFrameFilesAndCsvHeads) {
  const std::string dir = test::scratch_dir("of_kind");
  const std::string notes = write_text(dir + "/notes.h5", "my notes");
  EXPECT_FALSE(is_frame_file(notes));
  EXPECT_FALSE(is_frame_file(dir + "/missing.h5"));
  {
    FrameWriter w = FrameWriter::create(dir + "/f.h5", "{}", 1);
    Positions rest(3, 3);
    rest << 0, 0, 0, 1, 0, 0, 0, 1, 0;
    Faces faces(1, 3);
    faces << 0, 1, 2;
    w.add_level(0, rest, faces, {0, 3}, {"t"});
    w.close();
  }
  EXPECT_TRUE(is_frame_file(dir + "/f.h5"));
  EXPECT_TRUE(file_starts_with(write_text(dir + "/c.csv", "file,level,frame,x\n"), "file,level,frame,"));
  EXPECT_FALSE(file_starts_with(notes, "file,level,frame,"));
  const std::string refused =
      test::input_error_of([&] { check_replaceable(notes, "--out", false, false, "a frame file"); });
  EXPECT_NE(refused.find("exists and is not a frame file; give --force"), std::string::npos) << refused;
  EXPECT_EQ(test::input_error_of([&] { check_replaceable(notes, "--out", true, false, "a frame file"); }),
            "(no InputError thrown)");
}

TEST(OutputFiles, PartialOutputIsRenamedOnCommitAndRemovedOtherwise) {
  const std::string dir = test::scratch_dir("of_partial");
  const std::string out = dir + "/o.csv";
  write_text(out, "old");
  {
    PartialOutput p(out, "--csv");
    EXPECT_EQ(p.path(), out + ".partial");
    write_text(p.path(), "half");
  }  // not committed
  EXPECT_FALSE(fs::exists(out + ".partial"));
  std::ifstream old(out);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(old), {}), "old");
  {
    PartialOutput p(out, "--csv");
    write_text(p.path(), "new");
    p.commit();
  }
  std::ifstream now(out);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(now), {}), "new");
  EXPECT_FALSE(fs::exists(out + ".partial"));
}

TEST(OutputFiles, PartialFolderMovesFilesInOrLeavesNothing) {
  const std::string dir = test::scratch_dir("of_folder");
  {
    PartialFolder f(dir + "/new", "--out");
    fs::create_directories(f.path());
    write_text(f.path() + "/frame_00000.obj", "v 0 0 0\n");
  }  // not committed: no folder at all
  EXPECT_FALSE(fs::exists(dir + "/new"));
  EXPECT_FALSE(fs::exists(dir + "/new.partial"));
  fs::create_directories(dir + "/old");
  write_text(dir + "/old/keep.txt", "mine");
  {
    PartialFolder f(dir + "/old", "--out");
    fs::create_directories(f.path());
    write_text(f.path() + "/frame_00000.obj", "v 0 0 0\n");
    f.commit();
  }
  EXPECT_TRUE(fs::exists(dir + "/old/frame_00000.obj"));
  EXPECT_TRUE(fs::exists(dir + "/old/keep.txt"));
  EXPECT_FALSE(fs::exists(dir + "/old/.pd-export.partial"));
}

TEST(OutputFiles, SceneFilesCheckStatsTheObjMeshesItNames) {
  const std::string dir = test::scratch_dir("of_scene_objs");
  ASSERT_EQ(mkfifo((dir + "/m.obj").c_str(), 0600), 0);
  const std::string scene = write_text(dir + "/s.json", R"({"objects": [{"mesh": {"type": "rectangle"}},
    {"mesh": {"type": "obj", "path": "m.obj"}}]})");
  const std::string msg = test::input_error_of([&] { check_scene_files(scene); });
  EXPECT_EQ(msg.rfind(scene + ": objects[1].mesh.path: " + dir + "/m.obj is a FIFO", 0), 0u) << msg;
  const std::string missing = write_text(dir + "/t.json", R"({"objects": [{"mesh": {"type": "obj", "path": "no.obj"}}]})");
  EXPECT_EQ(test::input_error_of([&] { check_scene_files(missing); }), "(no InputError thrown)");
}

TEST(OutputFiles, SceneObjPathsAreResolvedAgainstTheSceneFolder) {
  const std::string text = R"({"objects": [{"mesh": {"type": "obj", "path": "m/hat.obj"}},
    {"mesh": {"type": "rectangle"}, "initial_positions": {"obj": "/abs/start.obj"}}]})";
  const std::vector<std::string> paths = scene_obj_paths("shots/s.json", text);
  ASSERT_EQ(paths.size(), 2u);
  EXPECT_EQ(paths[0], "shots/m/hat.obj");
  EXPECT_EQ(paths[1], "/abs/start.obj");
  EXPECT_TRUE(scene_obj_paths("s.json", "not json").empty());
}

}  // namespace
}  // namespace pd::cli
