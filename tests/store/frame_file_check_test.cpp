// Corrupted frame files (common/store/frame_file_check.h): each class of damage is refused when the
// file is opened (or the frame read) with InputError "<file>: <dataset path>: <problem>", quickly.
// The damaged files are made here with the HDF5 C API from a valid FrameWriter file.
#include "store/frame_file_check.h"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "scene/scene_file.h"
#include "store/frame_store.h"
#include "store/hierarchy_store.h"
#include "support/input_error_of.h"
#include "support/strip_mesh.h"

namespace pd {
namespace {

namespace fs = std::filesystem;
using test::input_error_of;
constexpr int kFrames = 4;  // frames 0..3
constexpr int kVertices = 6;

// Opens `path` read-write with the C API for one edit; closes it (and every object) on destruction.
class RawFile {
 public:
  explicit RawFile(const std::string& path) : id_(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT)) {
    EXPECT_GE(id_, 0) << path;
  }
  ~RawFile() { H5Fclose(id_); }
  // Replaces dataset `name` by one of file type `type`, shape `dims`, from `data` (memory type `mem`;
  // nullptr: no data written, the dataset stays unallocated). chunk: optional chunk shape.
  void replace(const std::string& name, hid_t type, hid_t mem, const std::vector<hsize_t>& dims, const void* data,
               const std::vector<hsize_t>& chunk = {}) {
    if (H5Lexists(id_, name.c_str(), H5P_DEFAULT) > 0) H5Ldelete(id_, name.c_str(), H5P_DEFAULT);
    const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    if (!chunk.empty()) H5Pset_chunk(dcpl, static_cast<int>(chunk.size()), chunk.data());
    const hid_t d = H5Dcreate2(id_, name.c_str(), type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    ASSERT_GE(d, 0) << name;
    if (data) {
      EXPECT_GE(H5Dwrite(d, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), 0) << name;
    }
    H5Dclose(d);
    H5Pclose(dcpl);
    H5Sclose(space);
  }
  // Writes one element (at `index`, any rank) of an existing dataset.
  void set(const std::string& name, const std::vector<hsize_t>& index, hid_t mem, const void* value) {
    const hid_t d = H5Dopen2(id_, name.c_str(), H5P_DEFAULT);
    ASSERT_GE(d, 0) << name;
    const hid_t fs_ = H5Dget_space(d);
    std::vector<hsize_t> one(index.size(), 1);
    H5Sselect_hyperslab(fs_, H5S_SELECT_SET, index.data(), nullptr, one.data(), nullptr);
    const hsize_t n = 1;
    const hid_t ms = H5Screate_simple(1, &n, nullptr);
    EXPECT_GE(H5Dwrite(d, mem, ms, fs_, H5P_DEFAULT, value), 0) << name;
    H5Sclose(ms);
    H5Sclose(fs_);
    H5Dclose(d);
  }
  // Replaces the scalar attribute `attr` of `object` by one of type `type`.
  void set_attr(const char* object, const char* attr, hid_t type, const void* value) {
    if (H5Aexists_by_name(id_, object, attr, H5P_DEFAULT) > 0) H5Adelete_by_name(id_, object, attr, H5P_DEFAULT);
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t a = H5Acreate_by_name(id_, object, attr, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(a, 0) << attr;
    EXPECT_GE(H5Awrite(a, type, value), 0);
    H5Aclose(a);
    H5Sclose(space);
  }
  hid_t id() const { return id_; }

 private:
  hid_t id_;
};

class FrameFileCheckTest : public ::testing::Test {
 protected:
  void SetUp() override {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    dir_ = fs::temp_directory_path() / ("pd_frame_file_check_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    path_ = (dir_ / "frames.h5").string();
    // One level, a 3 x 2 strip (6 vertices, 4 triangles), one object; frames 0..3 all written.
    FrameWriter w = FrameWriter::create(path_, "{\"name\": \"check\"}", kFrames - 1);
    rest_ = Positions::Zero(kVertices, 3);
    for (int i = 0; i < kVertices; ++i) rest_.row(i) << i % 3, i / 3, 0.0;
    w.add_level(0, rest_, test::strip_faces(3), {0, kVertices}, {"cloth"});
    FrameStats stats;
    stats.scalars = {{"kinetic_energy", 1.0}};
    stats.center_of_mass = ObjectPoints::Zero(1, 3);
    for (int t = 0; t < kFrames; ++t) w.write_frame(0, t, rest_, stats);
    w.close();
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The message of opening the file with FrameReader (and FrameWriter::open, which checks the same).
  std::string open_error(bool writer_too = true) const {
    const std::string reader = input_error_of([&] { FrameReader r(path_); });
    if (writer_too) {
      EXPECT_EQ(reader, input_error_of([&] { FrameWriter::open(path_); })) << "reader and writer disagree";
    }
    return reader;
  }
  std::string prefix(const std::string& dataset) const { return path_ + ": " + dataset + ": "; }

  fs::path dir_;
  std::string path_;
  Positions rest_;
};

TEST_F(FrameFileCheckTest, ValidFileOpensAndEveryFrameReads) {
  const FrameReader r(path_);
  ASSERT_EQ(r.num_frames(), kFrames);
  for (int t = 0; t < kFrames; ++t) EXPECT_EQ(r.frame(0, t), rest_);
}

TEST_F(FrameFileCheckTest, WrongShapeNamesTheDataset) {
  std::vector<double> v(kVertices * 2, 0.0);
  RawFile(path_).replace("/hierarchy/0/rest_positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {kVertices, 2}, v.data());
  EXPECT_EQ(open_error(), prefix("/hierarchy/0/rest_positions") + "shape (6, 2), expected (*, 3)");
}

TEST_F(FrameFileCheckTest, PositionsOfAnotherFrameCountAreRefused) {
  RawFile(path_).replace("/levels/0/positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {kFrames + 1, kVertices, 3},
                         nullptr, {1, kVertices, 3});
  EXPECT_EQ(open_error(), prefix("/levels/0/positions") + "shape (5, 6, 3), expected (4, 6, 3)");
}

TEST_F(FrameFileCheckTest, WrongElementTypeNamesTheDataset) {
  std::vector<float> v(kVertices * 3, 0.0f);
  RawFile(path_).replace("/hierarchy/0/rest_positions", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, {kVertices, 3}, v.data());
  EXPECT_EQ(open_error(), prefix("/hierarchy/0/rest_positions") + "element type float32, expected float64");
}

TEST_F(FrameFileCheckTest, IntegerFacesStoredAsInt64AreRefused) {
  std::vector<long long> v(4 * 3, 0);
  RawFile(path_).replace("/hierarchy/0/faces", H5T_STD_I64LE, H5T_NATIVE_LLONG, {4, 3}, v.data());
  EXPECT_EQ(open_error(), prefix("/hierarchy/0/faces") + "element type int64, expected int32");
}

TEST_F(FrameFileCheckTest, StatisticOfTheWrongLengthIsRefusedOnOpening) {
  std::vector<double> v(2, 0.0);
  RawFile(path_).replace("/levels/0/stats/kinetic_energy", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {2}, v.data());
  EXPECT_EQ(open_error(), prefix("/levels/0/stats/kinetic_energy") + "shape (2), expected (4)");
}

TEST_F(FrameFileCheckTest, FaceIndexOutsideTheVertexCountIsRefused) {
  const int bad = kVertices;
  RawFile(path_).set("/hierarchy/0/faces", {2, 1}, H5T_NATIVE_INT, &bad);
  EXPECT_EQ(open_error(), prefix("/hierarchy/0/faces") + "vertex index 6 (entry 7) outside [0, 6)");
  const int negative = -1;
  RawFile(path_).set("/hierarchy/0/faces", {2, 1}, H5T_NATIVE_INT, &negative);
  EXPECT_EQ(open_error(), prefix("/hierarchy/0/faces") + "vertex index -1 (entry 7) outside [0, 6)");
}

TEST_F(FrameFileCheckTest, AFaceThatRepeatsAVertexIsRefused) {
  const int zero = 0;
  for (hsize_t k = 0; k < 3; ++k) RawFile(path_).set("/hierarchy/0/faces", {1, k}, H5T_NATIVE_INT, &zero);
  EXPECT_EQ(open_error(), prefix("/hierarchy/0/faces") + "face 1 repeats a vertex (0, 0, 0)");
}

TEST_F(FrameFileCheckTest, DoneFlagOtherThanZeroOrOneIsRefused) {
  const uint8_t two = 2;
  RawFile(path_).set("/levels/0/done", {1}, H5T_NATIVE_UINT8, &two);
  EXPECT_EQ(open_error(), prefix("/levels/0/done") + "done[1] = 2, expected 0 or 1");
}

TEST_F(FrameFileCheckTest, NegativeHugeOrDecreasingObjectOffsetsAreRefused) {
  const std::string msg = prefix("/hierarchy/0/object_offsets") + "offsets must not decrease and run from 0 to 6";
  for (std::vector<int> off : {std::vector<int>{-5, 6}, {0, std::numeric_limits<int>::max()}, {0, -6}}) {
    RawFile(path_).replace("/hierarchy/0/object_offsets", H5T_STD_I32LE, H5T_NATIVE_INT, {2}, off.data());
    EXPECT_EQ(open_error(), msg) << off[0] << ", " << off[1];
  }
  // More offsets than names: the names no longer match the object count.
  std::vector<int> three{0, 3, 6};
  RawFile(path_).replace("/hierarchy/0/object_offsets", H5T_STD_I32LE, H5T_NATIVE_INT, {3}, three.data());
  EXPECT_EQ(open_error(), prefix("/hierarchy/0/object_names") + "shape (1), expected (2)");
}

TEST_F(FrameFileCheckTest, NanRestPositionIsRefusedWithTheVertex) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  RawFile(path_).set("/hierarchy/0/rest_positions", {2, 1}, H5T_NATIVE_DOUBLE, &nan);
  EXPECT_EQ(open_error(), prefix("/hierarchy/0/rest_positions") + "vertex 2 is not finite (nan)");
}

TEST_F(FrameFileCheckTest, NonFiniteStoredFramePositionIsRefusedWithTheFrameNumber) {
  const double inf = std::numeric_limits<double>::infinity();
  RawFile(path_).set("/levels/0/positions", {2, 4, 0}, H5T_NATIVE_DOUBLE, &inf);
  const FrameReader r(path_);  // opening reads no frame
  EXPECT_EQ(r.frame(0, 1), rest_);
  const std::string msg = prefix("/levels/0/positions") + "frame 2 of level 0: vertex 4 is not finite (inf)";
  EXPECT_EQ(input_error_of([&] { r.frame(0, 2); }), msg);
  EXPECT_EQ(input_error_of([&] { export_obj_frames(r, 0, (dir_ / "obj").string()); }), msg);
}

TEST_F(FrameFileCheckTest, AttributeOfTheWrongTypeIsRefused) {
  const double one = 1.0;  // read as an int it would be 1 and pass
  RawFile(path_).set_attr("/", "format_version", H5T_NATIVE_DOUBLE, &one);
  EXPECT_EQ(open_error(), prefix("/@format_version") + "attribute is float64, expected an integer");
  const long long wide = (1LL << 32) + 1;  // clipped to INT_MAX by a plain int read
  RawFile(path_).set_attr("/", "format_version", H5T_STD_I64LE, &wide);
  EXPECT_EQ(open_error(), prefix("/@format_version") + "value 4294967297 out of range");
}

TEST_F(FrameFileCheckTest, OverlongObjectNameIsRefused) {
  const std::string name(h5::kMaxStringBytes + 1, 'x');
  const char* p = name.c_str();
  const hid_t str = H5Tcopy(H5T_C_S1);
  H5Tset_size(str, H5T_VARIABLE);
  RawFile(path_).replace("/hierarchy/0/object_names", str, str, {1}, &p);
  H5Tclose(str);
  EXPECT_EQ(open_error(), prefix("/hierarchy/0/object_names") + "string 0 has 65537 bytes, more than the limit of 65536");
}

TEST_F(FrameFileCheckTest, TruncatedFileIsRefused) {
  const auto size = fs::file_size(path_);
  for (uintmax_t keep : {uintmax_t{0}, uintmax_t{64}, size / 2, size - 1}) {
    fs::resize_file(path_, keep);
    const std::string msg = open_error(false);  // the writer words it for writing
    EXPECT_EQ(msg.rfind(path_ + ": ", 0), 0u) << msg;
    EXPECT_TRUE(msg.find("not an HDF5 file") != std::string::npos || msg.find("truncated") != std::string::npos)
        << keep << " bytes: " << msg;
  }
}

TEST_F(FrameFileCheckTest, RandomBytesAreNotAnHdf5File) {
  std::mt19937 rng(17);
  std::ofstream out(path_, std::ios::binary | std::ios::trunc);
  for (int i = 0; i < 20000; ++i) out.put(static_cast<char>(rng()));
  out.close();
  EXPECT_EQ(open_error(), path_ + ": not an HDF5 file");
}

// The former hang: a small file claiming a million done frames that were never written made pd
// export write a million OBJ files of fill values (and read all of `done` again for each frame).
TEST_F(FrameFileCheckTest, DoneFramesThatWereNeverWrittenFailFast) {
  constexpr hsize_t kClaimed = 1000000;
  {
    RawFile f(path_);
    const std::vector<uint8_t> ones(kClaimed, 1);
    f.replace("/levels/0/done", H5T_STD_U8LE, H5T_NATIVE_UINT8, {kClaimed}, ones.data());
    f.replace("/levels/0/positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {kClaimed, kVertices, 3}, nullptr,
              {1, kVertices, 3});
    f.replace("/levels/0/stats/center_of_mass", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {kClaimed, 1, 3}, nullptr,
              {1, 1, 3});
    H5Ldelete(f.id(), "/levels/0/stats/kinetic_energy", H5P_DEFAULT);
  }
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(open_error(),
            prefix("/levels/0/positions") + "1000000 frames of level 0 are marked done but at most 0 were written");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
}

// Found by the fuzzer: a global heap object of size 0 makes HDF5 1.10's heap parser loop forever
// (while reading /@scene); the file is refused before HDF5 parses it.
TEST_F(FrameFileCheckTest, GlobalHeapObjectThatMakesNoProgressIsRefusedBeforeHdf5LoopsOnIt) {
  std::string bytes;
  {
    std::ifstream in(path_, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const size_t heap = bytes.find("GCOL");
  ASSERT_NE(heap, std::string::npos) << "the file has no global heap (variable-length strings)";
  // The first object: 2-byte index, 2-byte reference count, 4 reserved, 8-byte size; index 0 and
  // size 0 is what the fuzzer made.
  std::fill(bytes.begin() + static_cast<long>(heap + 16), bytes.begin() + static_cast<long>(heap + 32), '\0');
  {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out << bytes;
  }
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(open_error(), path_ + ": corrupt global heap collection at byte " + std::to_string(heap) + " (object 0 at byte " +
                              std::to_string(heap + 16) + " has size 0)");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
}

TEST_F(FrameFileCheckTest, FrameCountAboveTheLimitIsRefused) {
  constexpr hsize_t kTooMany = kMaxFrameFileFrames + 1;
  const std::vector<uint8_t> zeros(kTooMany, 0);  // stored, so that the count is what is refused
  RawFile(path_).replace("/levels/0/done", H5T_STD_U8LE, H5T_NATIVE_UINT8, {kTooMany}, zeros.data());
  EXPECT_EQ(open_error(), prefix("/levels/0/done") + "frame count 10000002 outside [1, 10000001]");
}

// Found by the fuzzer: a dataset whose shape claims far more data than the file holds sized an
// allocation of gigabytes before anything was read.
TEST_F(FrameFileCheckTest, ShapeClaimingMoreDataThanStoredIsRefusedBeforeAllocating) {
  RawFile(path_).replace("/hierarchy/0/rest_positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {kMaxLevelVertices, 3},
                         nullptr, {1024, 3});
  EXPECT_EQ(open_error(), prefix("/hierarchy/0/rest_positions") +
                              "the shape needs 17179869168 bytes of data but the file stores 0");
}

TEST_F(FrameFileCheckTest, UnknownLinkUnderLevelsIsRefused) {
  {
    RawFile f(path_);
    const hid_t g = H5Gcreate2(f.id(), "/levels/extra", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(g, 0);
    H5Gclose(g);
  }
  EXPECT_EQ(open_error(), prefix("/levels/1") + "missing group (the levels of a file are 0..1)");
}

// The hierarchy reader: counts from attributes are checked before anything is allocated from them,
// and every stored index must lie within the mesh it indexes.
class HierarchyFileCheckTest : public FrameFileCheckTest {
 protected:
  void SetUp() override {
    FrameFileCheckTest::SetUp();
    const Scene scene = parse_scene(R"({"format_version": 1, "name": "check", "time_step": 0.01, "frames": 1,
      "hierarchy": {"levels": 2},
      "objects": [{"name": "sheet", "mesh": {"type": "rectangle", "size": [1.0, 0.5], "cells": [8, 4]},
                   "hierarchy": {"vertex_counts": [12]}, "material": {"preset": "cotton"}}]})",
                                    "check.json", "");
    load_or_build_hierarchy(scene, path_);
    ASSERT_TRUE(read_hierarchy(path_).has_value());
  }
};

TEST_F(HierarchyFileCheckTest, HugeLevelCountIsRefusedBeforeAllocating) {
  const int huge = std::numeric_limits<int>::max();
  RawFile(path_).set_attr("/hierarchy", "num_levels", H5T_NATIVE_INT, &huge);
  EXPECT_EQ(input_error_of([&] { read_hierarchy(path_); }),
            prefix("/hierarchy/@num_levels") + "must be in [1, 20], got 2147483647");
}

TEST_F(HierarchyFileCheckTest, CollapseVertexIdOutsideTheFinerLevelIsRefused) {
  const int bad = 1000000;
  RawFile(path_).set("/hierarchy/objects/0/0/collapses/removed", {0}, H5T_NATIVE_INT, &bad);
  const std::string msg = input_error_of([&] { read_hierarchy(path_); });
  EXPECT_EQ(msg.rfind(prefix("/hierarchy/objects/0/0/collapses/removed") + "vertex id 1000000 (entry 0) outside [0, ",
                      0),
            0u)
      << msg;
}

TEST_F(HierarchyFileCheckTest, NanObjectPositionIsRefused) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  RawFile(path_).set("/hierarchy/objects/0/1/positions", {3, 2}, H5T_NATIVE_DOUBLE, &nan);
  EXPECT_EQ(input_error_of([&] { read_hierarchy(path_); }),
            prefix("/hierarchy/objects/0/1/positions") + "vertex 3 is not finite (nan)");
}

}  // namespace
}  // namespace pd
