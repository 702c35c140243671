// Scenes on the wire: read_scene_source collects a scene's OBJ files, scene_from_source rebuilds the
// same Scene in another folder, bad paths are refused, and a bad scene is told as pd simulate tells it.
#include "farm/scene_source.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "scene/scene_file.h"
#include "support/input_error_of.h"
#include "support/pc2_bytes.h"
#include "support/test_paths.h"

namespace pd::farm {
namespace {

namespace fs = std::filesystem;
using test::input_error_of;

std::string write_file(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

// A unit square of two triangles, and the same square posed (lifted corner): same connectivity.
const std::string kQuadObj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
const std::string kPosedObj = "v 0 0 0\nv 1 0 0.25\nv 1 1 0.5\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";

// Two objects: the first uses an OBJ mesh and an OBJ pose, the second the same mesh written with
// "./" (one file on the wire).
std::string scene_text(const std::string& mesh_path = "meshes/quad.obj",
                       const std::string& posed_path = "poses/quad_posed.obj") {
  const std::string material =
      R"("material": {"density": 200, "youngs_modulus": 1e5, "poisson_ratio": 0.3, "thickness": 0.001})";
  return R"({"format_version": 1, "name": "objs", "time_step": 0.01, "frames": 2, "objects": [
    {"name": "posed", "mesh": {"type": "obj", "path": ")" + mesh_path + R"("},
     "initial_positions": {"obj": ")" + posed_path + R"("}, )" + material + R"(},
    {"name": "again", "mesh": {"type": "obj", "path": "./meshes/quad.obj"},
     "transform": {"translation": [0, 0, 2]}, )" + material + R"(}]})";
}

class SceneSourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    shot_dir_ = test::scratch_dir("scene_source_shot");
    write_file(fs::path(shot_dir_) / "meshes/quad.obj", kQuadObj);
    write_file(fs::path(shot_dir_) / "poses/quad_posed.obj", kPosedObj);
    scene_path_ = write_file(fs::path(shot_dir_) / "shot.json", scene_text());
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(shot_dir_, ec);
  }

  std::string shot_dir_;
  std::string scene_path_;
};

TEST_F(SceneSourceTest, CollectsTheMeshAndInitialPositionsObjsOncePerFile) {
  const protocol::SceneSource source = read_scene_source(scene_path_);
  EXPECT_EQ(source.name, scene_path_);
  EXPECT_EQ(source.text, scene_text());
  ASSERT_EQ(source.files.size(), 2u);  // "./meshes/quad.obj" is the same file as "meshes/quad.obj"
  EXPECT_EQ(source.files[0].path, "meshes/quad.obj");
  EXPECT_EQ(source.files[0].content, kQuadObj);
  EXPECT_EQ(source.files[1].path, "poses/quad_posed.obj");
  EXPECT_EQ(source.files[1].content, kPosedObj);
}

TEST_F(SceneSourceTest, SceneFromSourceInAnotherFolderEqualsLoadScene) {
  const Scene local = load_scene(scene_path_);
  const std::string scratch = test::scratch_dir("scene_source_worker");
  const Scene remote = scene_from_source(read_scene_source(scene_path_), scratch);
  EXPECT_TRUE(fs::exists(fs::path(scratch) / "meshes/quad.obj"));
  EXPECT_TRUE(fs::exists(fs::path(scratch) / "poses/quad_posed.obj"));
  EXPECT_EQ(remote.name, "objs");
  EXPECT_EQ(remote.source_path, scene_path_);
  ASSERT_EQ(remote.objects.size(), local.objects.size());
  for (std::size_t i = 0; i < local.objects.size(); ++i) {
    EXPECT_EQ(remote.objects[i].rest.V, local.objects[i].rest.V) << "object " << i;
    EXPECT_EQ(remote.objects[i].rest.F, local.objects[i].rest.F) << "object " << i;
    EXPECT_EQ(remote.objects[i].initial, local.objects[i].initial) << "object " << i;
  }
  EXPECT_DOUBLE_EQ(remote.objects[0].initial(2, 2), 0.5);  // the pose reached the worker's scene
  EXPECT_DOUBLE_EQ(remote.objects[1].initial(2, 2), 2.0);
  fs::remove_all(scratch);
}

TEST_F(SceneSourceTest, SceneFromSourceRefusesPathsOutsideTheScratchFolder) {
  const std::string scratch = test::scratch_dir("scene_source_bad");
  const fs::path inside = fs::path(scratch) / "inside";
  fs::create_directories(inside);
  protocol::SceneSource source = read_scene_source(scene_path_);
  const std::string name = scene_path_;
  struct Case {
    std::string path, message;
  };
  const Case cases[] = {
      {"", name + ": files[1].path: is empty"},
      {"/tmp/evil.obj", name + ": files[1].path: \"/tmp/evil.obj\" is absolute"},
      {"../evil.obj", name + ": files[1].path: \"../evil.obj\" has a \"..\" component"},
      {"meshes/../../evil.obj", name + ": files[1].path: \"meshes/../../evil.obj\" has a \"..\" component"},
      {"meshes/", name + ": files[1].path: \"meshes/\" names a folder, not a file"},
      {"meshes/./quad.obj", name + ": files[1].path: \"meshes/./quad.obj\" names the same file as an earlier entry"},
  };
  for (const Case& c : cases) {
    protocol::SceneSource bad = source;
    bad.files[1].path = c.path;
    EXPECT_EQ(input_error_of([&] { scene_from_source(bad, inside.string()); }), c.message) << c.path;
  }
  // Refused before writing: not even the valid first file is there, and nothing escaped the folder.
  EXPECT_TRUE(fs::is_empty(inside));
  EXPECT_FALSE(fs::exists(fs::path(scratch) / "evil.obj"));
  fs::remove_all(scratch);
}

TEST_F(SceneSourceTest, ABadSceneGivesTheSameMessageAsLoadScene) {
  // A typo in a key, a missing OBJ file, and a pose with the wrong vertex count: three kinds of error.
  const std::string texts[] = {
      std::string(scene_text()).replace(scene_text().find("\"frames\""), 8, "\"framez\""),
      scene_text("meshes/missing.obj"),
      scene_text("meshes/quad.obj", "poses/tri.obj"),
  };
  write_file(fs::path(shot_dir_) / "poses/tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  for (const std::string& text : texts) {
    const std::string path = write_file(fs::path(shot_dir_) / "bad.json", text);
    const std::string expected = input_error_of([&] { load_scene(path); });
    ASSERT_NE(expected, "(no InputError thrown)") << text;
    EXPECT_EQ(input_error_of([&] { read_scene_source(path); }), expected);
  }
  const std::string missing = (fs::path(shot_dir_) / "nothing.json").string();
  EXPECT_EQ(input_error_of([&] { read_scene_source(missing); }), missing + ": cannot open scene file");
}

TEST_F(SceneSourceTest, ReadSceneSourceRefusesObjPathsAWorkerCannotRebuild) {
  // Valid for load_scene (the files exist), but neither can be placed under a worker's scratch folder.
  const fs::path sub = fs::path(shot_dir_) / "sub";
  write_file(sub / "meshes/quad.obj", kQuadObj);  // the second object's "./meshes/quad.obj"
  const std::string relative =
      write_file(sub / "shot.json", scene_text("../meshes/quad.obj", "../poses/quad_posed.obj"));
  EXPECT_EQ(input_error_of([&] { read_scene_source(relative); }),
            relative + ": objects[0].mesh.path: \"../meshes/quad.obj\" has a \"..\" component; a farm job needs file "
                       "paths relative to the scene file's folder (without \"..\")");
  const std::string absolute =
      write_file(sub / "abs.json", scene_text("meshes/quad.obj", shot_dir_ + "/poses/quad_posed.obj"));
  EXPECT_EQ(input_error_of([&] { read_scene_source(absolute); }),
            absolute + ": objects[0].initial_positions.obj: \"" + shot_dir_ +
                "/poses/quad_posed.obj\" is absolute; a farm job needs file paths relative to the scene file's folder "
                "(without \"..\")");
}

// An animated obstacle's files travel with the scene: each frame of an OBJ sequence, or the PC2 file
// (bytes that are not text), and the worker's copy animates the body identically.
TEST_F(SceneSourceTest, AnAnimatedObstaclesCacheFilesTravelAndRebuildTheSameAnimation) {
  const std::vector<Positions> samples = {Positions::Zero(4, 3), Positions::Constant(4, 3, 0.25),
                                          Positions::Constant(4, 3, 0.5)};
  write_file(fs::path(shot_dir_) / "body/walk.pc2", test::pc2_bytes(samples));
  for (int k = 1; k <= 3; ++k) write_file(fs::path(shot_dir_) / ("body/f" + std::to_string(k) + ".obj"), kQuadObj);
  const std::string text = R"({"format_version": 1, "time_step": 0.01, "frames": 2, "contact": {"dhat": 0.001},
    "objects": [
    {"name": "pc2", "obstacle": true, "mesh": {"type": "obj", "path": "meshes/quad.obj"},
     "animation": {"pc2": "body/walk.pc2", "fps": 100}},
    {"name": "seq", "obstacle": true, "mesh": {"type": "obj", "path": "meshes/quad.obj"},
     "animation": {"obj_sequence": "body/f#.obj", "frames": [1, 3], "fps": 100}}]})";
  const std::string path = write_file(fs::path(shot_dir_) / "body.json", text);
  Scene loaded;
  const protocol::SceneSource source = read_scene_source(path, &loaded);
  std::vector<std::string> paths;
  for (const protocol::SceneFile& f : source.files) paths.push_back(f.path);
  EXPECT_EQ(paths, (std::vector<std::string>{"meshes/quad.obj", "body/walk.pc2", "body/f1.obj", "body/f2.obj",
                                             "body/f3.obj"}));
  const std::string worker = test::scratch_dir("scene_source_worker");
  const Scene rebuilt = scene_from_source(source, worker);
  for (std::size_t k = 0; k < 2; ++k) {
    const VertexAnimation& a = *loaded.objects[k].motion->animation;
    const VertexAnimation& b = *rebuilt.objects[k].motion->animation;
    ASSERT_EQ(a.frames(), b.frames());
    for (int f = 0; f < a.frames(); ++f) EXPECT_EQ(a.frame(f), b.frame(f));
  }
  // The hash names every byte: one changed sample changes it.
  protocol::SceneSource changed = source;
  changed.files[1].content.back() ^= 1;
  EXPECT_NE(scene_source_hash(changed), scene_source_hash(source));
  EXPECT_EQ(scene_source_hash(source), scene_source_hash(read_scene_source(path)));
  fs::remove_all(worker);
}

}  // namespace
}  // namespace pd::farm
