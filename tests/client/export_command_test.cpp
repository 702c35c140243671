// pd export end to end (client/export_command.cpp): PC2 point caches read back with a reader written
// from the format, --frames ranges, --per-object, --prolong, and their bad input.
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
