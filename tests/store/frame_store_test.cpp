#include "store/frame_store.h"
#include "support/strip_mesh.h"
#include "support/input_error_of.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

// Some tests edit or read a file with the HDF5 C API directly (tests/CMakeLists.txt puts HDF5's
// headers on the test target's include path).
#include <hdf5.h>

namespace pd {
namespace {

namespace fs = std::filesystem;

// n == 0 first: an empty matrix's data() is null, and memcmp with a null pointer is undefined
// behaviour even for 0 bytes (UBSan reports it).
bool bits_equal(const double* a, const double* b, Eigen::Index n) {
  return n == 0 || std::memcmp(a, b, sizeof(double) * static_cast<size_t>(n)) == 0;
}

Positions random_positions(int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  Positions X(n, 3);
  for (Eigen::Index i = 0; i < X.size(); ++i) X.data()[i] = u(rng);
  X(0, 0) = -0.0;  // sign of zero, extreme and non-terminating values must survive
  X(0, 1) = 1e-300;
  X(0, 2) = 1.0 / 3.0;
  return X;
}

using test::strip_faces;

FrameStats make_stats(int t, int num_objects) {
  FrameStats s;
  s.scalars = {{"newton_iterations", t + 1.0}, {"kinetic_energy", 0.1 * t + 1e-17}, {"solve_seconds", t / 7.0}};
  s.center_of_mass = ObjectPoints::Constant(num_objects, 3, t * 0.25);
  return s;
}

using test::input_error_of;

bool same_positions(const Positions& a, const Positions& b) {
  return a.rows() == b.rows() && bits_equal(a.data(), b.data(), a.size());
}

class FrameStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("pd_frame_store_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    path_ = (dir_ / "frames.h5").string();
    rest0_ = random_positions(6, rng_);  // level 0: 3 x 2 strip, one object
    rest1_ = random_positions(10, rng_);  // level 1: two objects of 4 and 6 vertices
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A file with levels 0 and 1 for frames 0..last_frame; nothing written yet.
  FrameWriter make_writer(int last_frame, const std::string& scene = "{\"name\": \"flag\"}") {
    FrameWriter w = FrameWriter::create(path_, scene, last_frame);
    w.add_level(0, rest0_, strip_faces(3), {0, 6}, {"cloth"});
    w.add_level(1, rest1_, strip_faces(5), {0, 4, 10}, {"cloth", "sphere"});
    return w;
  }

  fs::path dir_;
  std::string path_;
  std::mt19937_64 rng_{42};
  Positions rest0_, rest1_;
};

TEST_F(FrameStoreTest, RoundTripIsBitExactForPositionsFacesRestAndStats) {
  std::string scene = "{\"text\": \"\xc3\xa9t\xc3\xa9\", \"pad\": \"" + std::string(200000, 'x') + "\"}";
  std::vector<Positions> frames;
  {
    FrameWriter w = make_writer(3, scene);
    for (int t = 0; t <= 3; ++t) {
      frames.push_back(random_positions(10, rng_));
      w.write_frame(1, t, frames.back(), make_stats(t, 2));
    }
    w.close();
  }
  FrameReader r(path_);
  EXPECT_EQ(r.format_version(), kFrameFormatVersion);
  EXPECT_EQ(r.scene_json(), scene);
  ASSERT_EQ(r.num_levels(), 2);
  EXPECT_EQ(r.num_frames(), 4);
  EXPECT_EQ(r.num_vertices(1), 10);
  EXPECT_EQ(r.num_objects(1), 2);
  Positions rest = r.rest_positions(1);
  EXPECT_TRUE(bits_equal(rest.data(), rest1_.data(), rest1_.size()));
  EXPECT_EQ(r.faces(1), strip_faces(5));
  EXPECT_EQ(r.faces(0), strip_faces(3));
  EXPECT_EQ(r.object_offsets(1), (std::vector<int>{0, 4, 10}));
  EXPECT_EQ(r.object_names(1), (std::vector<std::string>{"cloth", "sphere"}));
  EXPECT_EQ(r.object_names(0), (std::vector<std::string>{"cloth"}));
  for (int t = 0; t <= 3; ++t) {
    Positions X = r.frame(1, t);
    ASSERT_EQ(X.rows(), 10);
    EXPECT_TRUE(bits_equal(X.data(), frames[t].data(), X.size())) << "frame " << t;
    EXPECT_EQ(r.center_of_mass(1, t), ObjectPoints::Constant(2, 3, t * 0.25));
  }
  EXPECT_EQ(r.stat_names(1), (std::vector<std::string>{"kinetic_energy", "newton_iterations", "solve_seconds"}));
  for (int t = 0; t <= 3; ++t) {
    FrameStats expected = make_stats(t, 2);
    for (const auto& [name, value] : expected.scalars) {
      double got = r.stat(1, name)[t];
      EXPECT_TRUE(bits_equal(&got, &value, 1)) << name << " at frame " << t;
    }
  }
}

// The scheduler's mode: no flush per frame, one flush (or the close) at the end; the file holds the
// same frames and statistics bit for bit.
TEST_F(FrameStoreTest, WithoutAFlushPerFrameTheFlushedFileHoldsTheSameFrames) {
  std::vector<Positions> frames;
  {
    FrameWriter w = make_writer(3, "{}");
    w.set_flush_each_frame(false);
    for (int t = 0; t <= 3; ++t) {
      frames.push_back(random_positions(10, rng_));
      w.write_frame(1, t, frames.back(), make_stats(t, 2));
    }
    w.write_frame(1, 2, frames[1], make_stats(5, 2));  // an overwrite, unflushed too
    frames[2] = frames[1];
    EXPECT_TRUE(w.is_done(1, 2));
    EXPECT_TRUE(same_positions(w.read_frame(1, 2), frames[1]));
    w.flush();
    w.close();
  }
  FrameReader r(path_);
  int compared = 0;
  for (int t = 0; t <= 3; ++t) {
    EXPECT_TRUE(same_positions(r.frame(1, t), frames[t])) << t;
    ++compared;
  }
  EXPECT_EQ(compared, 4);
  EXPECT_EQ(r.stat(1, "newton_iterations"), (std::vector<double>{1.0, 2.0, 6.0, 4.0}));
}

TEST_F(FrameStoreTest, DoneFlagsOnlyForWrittenFrames) {
  {
    FrameWriter w = make_writer(5);
    w.write_frame(0, 0, rest0_, {});
    w.write_frame(0, 2, rest0_, {});
    w.write_frame(1, 5, rest1_, {});
  }
  FrameReader r(path_);
  EXPECT_EQ(r.done(0), (std::vector<uint8_t>{1, 0, 1, 0, 0, 0}));
  EXPECT_EQ(r.done(1), (std::vector<uint8_t>{0, 0, 0, 0, 0, 1}));
}

TEST_F(FrameStoreTest, FramesWrittenOutOfOrderReadBackInPlace) {
  std::vector<Positions> frames(5);
  {
    FrameWriter w = make_writer(4);
    for (int t : {3, 0, 4, 1, 2}) {
      frames[t] = random_positions(6, rng_);
      w.write_frame(0, t, frames[t], make_stats(t, 1));
    }
    frames[3] = random_positions(6, rng_);  // writing a frame again replaces it
    w.write_frame(0, 3, frames[3], make_stats(3, 1));
  }
  FrameReader r(path_);
  EXPECT_EQ(r.done(0), std::vector<uint8_t>(5, 1));
  for (int t = 0; t < 5; ++t) {
    Positions X = r.frame(0, t);
    EXPECT_TRUE(bits_equal(X.data(), frames[t].data(), X.size())) << "frame " << t;
    EXPECT_EQ(r.stat(0, "newton_iterations")[t], t + 1.0);
  }
}

TEST_F(FrameStoreTest, WriterReadsBackItsStoredFramesBitExactAndRefusesOthers) {
  FrameWriter w = make_writer(4);
  const Positions a = random_positions(10, rng_), b = random_positions(6, rng_);
  w.write_frame(1, 2, a, make_stats(2, 2));
  w.write_frame(0, 4, b, {});
  const Positions ra = w.read_frame(1, 2), rb = w.read_frame(0, 4);
  ASSERT_EQ(ra.rows(), 10);
  ASSERT_EQ(rb.rows(), 6);
  EXPECT_TRUE(bits_equal(ra.data(), a.data(), a.size()));
  EXPECT_TRUE(bits_equal(rb.data(), b.data(), b.size()));
  EXPECT_TRUE(w.is_done(1, 2));
  EXPECT_FALSE(w.is_done(1, 3));
  EXPECT_FALSE(w.is_done(2, 0));
  EXPECT_FALSE(w.is_done(0, 5));
  EXPECT_NE(input_error_of([&] { w.read_frame(1, 3); }).find("frame 3 of level 1 is not done"), std::string::npos);
  EXPECT_NE(input_error_of([&] { w.read_frame(1, 5); }).find("out of range"), std::string::npos);
  EXPECT_NE(input_error_of([&] { w.read_frame(2, 0); }).find("level out of range"), std::string::npos);
}

TEST_F(FrameStoreTest, ReopeningAFileAndReadingAgain) {
  Positions X = random_positions(10, rng_);
  {
    FrameWriter w = make_writer(2);
    w.write_frame(1, 1, X, make_stats(1, 2));
  }  // destroyed without close(): the destructor closes the file
  for (int round = 0; round < 2; ++round) {
    FrameReader r(path_);
    EXPECT_EQ(r.num_frames(), 3);
    Positions Y = r.frame(1, 1);
    EXPECT_TRUE(bits_equal(X.data(), Y.data(), X.size()));
  }
  FrameReader a(path_), b(path_);  // two readers at once
  EXPECT_EQ(a.done(1), b.done(1));
}

TEST_F(FrameStoreTest, StatsAreNaNForUnwrittenFrames) {
  {
    FrameWriter w = make_writer(4);
    w.write_frame(0, 1, rest0_, make_stats(1, 1));
    w.write_frame(0, 3, rest0_, make_stats(3, 1));
  }
  FrameReader r(path_);
  std::vector<double> it = r.stat(0, "newton_iterations");
  ASSERT_EQ(it.size(), 5u);
  EXPECT_TRUE(std::isnan(it[0]));
  EXPECT_EQ(it[1], 2.0);
  EXPECT_TRUE(std::isnan(it[2]));
  EXPECT_EQ(it[3], 4.0);
  EXPECT_TRUE(std::isnan(it[4]));
  EXPECT_TRUE(r.stat_names(1).empty());
  EXPECT_TRUE(r.center_of_mass(0, 1).isApproxToConstant(0.25));
}

TEST_F(FrameStoreTest, StatIntroducedAtFrame5IsNaNBefore) {
  {
    FrameWriter w = make_writer(7);
    for (int t = 0; t <= 7; ++t) {
      FrameStats s = make_stats(t, 2);
      if (t >= 5) s.scalars.emplace_back("energy_contact", 10.0 * t);
      if (t == 6) s.center_of_mass.resize(0, 3);  // not computed for this frame
      w.write_frame(1, t, rest1_, s);
    }
  }
  FrameReader r(path_);
  std::vector<double> e = r.stat(1, "energy_contact");
  for (int t = 0; t < 5; ++t) EXPECT_TRUE(std::isnan(e[t])) << "frame " << t;
  for (int t = 5; t <= 7; ++t) EXPECT_EQ(e[t], 10.0 * t);
  EXPECT_TRUE(r.center_of_mass(1, 6).array().isNaN().all());
  EXPECT_EQ(r.center_of_mass(1, 7), ObjectPoints::Constant(2, 3, 7 * 0.25));
}

TEST_F(FrameStoreTest, MissingFileThrowsInputErrorWithPath) {
  std::string missing = (dir_ / "nope.h5").string();
  std::string msg = input_error_of([&] { FrameReader r(missing); });
  EXPECT_NE(msg.find(missing + ": "), std::string::npos) << msg;
  EXPECT_NE(msg.find("no such file"), std::string::npos) << msg;
}

TEST_F(FrameStoreTest, NotHdf5FileThrowsInputErrorWithPath) {
  std::ofstream(path_, std::ios::binary) << std::string("this is not HDF5\0\x01\x02 garbage bytes", 34);
  std::string msg = input_error_of([&] { FrameReader r(path_); });
  EXPECT_NE(msg.find(path_ + ": "), std::string::npos) << msg;
  EXPECT_NE(msg.find("not an HDF5 file"), std::string::npos) << msg;
}

TEST_F(FrameStoreTest, TruncatedFileThrowsInputErrorWithPath) {
  {
    FrameWriter w = make_writer(3);
    for (int t = 0; t <= 3; ++t) w.write_frame(1, t, random_positions(10, rng_), make_stats(t, 2));
  }
  fs::resize_file(path_, fs::file_size(path_) / 2);
  std::string msg = input_error_of([&] {
    FrameReader r(path_);
    for (int t = 0; t <= 3; ++t) r.frame(1, t);
  });
  EXPECT_EQ(msg.rfind(path_ + ": ", 0), 0u) << msg;
}

TEST_F(FrameStoreTest, FrameNotDoneOrOutOfRangeThrowsInputErrorWithPath) {
  {
    FrameWriter w = make_writer(3);
    w.write_frame(0, 1, rest0_, {});
  }
  FrameReader r(path_);
  std::string msg = input_error_of([&] { r.frame(0, 2); });
  EXPECT_EQ(msg, path_ + ": /levels/0/positions: frame 2 of level 0 is not done");
  msg = input_error_of([&] { r.frame(0, 4); });
  EXPECT_NE(msg.find(path_ + ": "), std::string::npos) << msg;
  EXPECT_NE(msg.find("out of range"), std::string::npos) << msg;
  EXPECT_NE(input_error_of([&] { r.frame(0, -1); }).find("out of range"), std::string::npos);
  EXPECT_NE(input_error_of([&] { r.center_of_mass(0, 3); }).find("not done"), std::string::npos);
}

TEST_F(FrameStoreTest, LevelOutOfRangeThrowsInputErrorWithPath) {
  FrameWriter w = make_writer(2);
  std::string msg = input_error_of([&] { w.write_frame(2, 0, rest1_, {}); });
  EXPECT_EQ(msg, path_ + ": /levels/2: level out of range [0, 2)");
  w.close();
  FrameReader r(path_);
  for (int level : {-1, 2}) {
    EXPECT_NE(input_error_of([&] { r.frame(level, 0); }).find(path_ + ": "), std::string::npos);
    EXPECT_NE(input_error_of([&] { r.faces(level); }).find("level out of range"), std::string::npos);
    EXPECT_NE(input_error_of([&] { r.stat_names(level); }).find("level out of range"), std::string::npos);
  }
  msg = input_error_of([&] { r.stat(0, "no_such_stat"); });
  EXPECT_EQ(msg, path_ + ": /levels/0/stats/no_such_stat: no such statistic");
}

TEST_F(FrameStoreTest, WriterRejectsInconsistentInput) {
  FrameWriter w = FrameWriter::create(path_, "{}", 2);
  auto fails = [&](auto&& f) { return input_error_of(f).rfind(path_ + ": ", 0) == 0; };
  EXPECT_TRUE(fails([&] { w.add_level(1, rest0_, strip_faces(3), {0, 6}, {"a"}); }));      // out of order
  EXPECT_TRUE(fails([&] { w.add_level(0, rest0_, strip_faces(3), {0, 5}, {"a"}); }));      // offsets end
  EXPECT_TRUE(fails([&] { w.add_level(0, rest0_, strip_faces(3), {0, 6}, {}); }));         // no objects
  EXPECT_TRUE(fails([&] { w.add_level(0, rest0_, strip_faces(4), {0, 6}, {"a"}); }));      // face index
  w.add_level(0, rest0_, strip_faces(3), {0, 6}, {"a"});
  EXPECT_TRUE(fails([&] { w.write_frame(0, 0, rest1_, {}); }));                           // vertex count
  EXPECT_TRUE(fails([&] { w.write_frame(0, 3, rest0_, {}); }));                           // frame range
  FrameStats bad;
  bad.scalars = {{"a/b", 1.0}};
  EXPECT_TRUE(fails([&] { w.write_frame(0, 0, rest0_, bad); }));
  bad.scalars = {{"x", 1.0}, {"x", 2.0}};
  EXPECT_TRUE(fails([&] { w.write_frame(0, 0, rest0_, bad); }));
  bad.scalars.clear();
  bad.center_of_mass = ObjectPoints::Zero(2, 3);
  EXPECT_TRUE(fails([&] { w.write_frame(0, 0, rest0_, bad); }));
  w.close();
  EXPECT_TRUE(fails([&] { w.write_frame(0, 0, rest0_, {}); }));  // closed
  FrameReader r(path_);
  EXPECT_EQ(r.done(0), std::vector<uint8_t>(3, 0));  // nothing was written by the failed calls
  EXPECT_TRUE(r.stat_names(0).empty());
}

TEST_F(FrameStoreTest, WrongFormatVersionOrMissingDatasetThrowsInputErrorNamingIt) {
  make_writer(2).close();
  hid_t file = H5Fopen(path_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  ASSERT_GE(H5Ldelete(file, "/levels/1/done", H5P_DEFAULT), 0);
  H5Fclose(file);
  std::string msg = input_error_of([&] { FrameReader r(path_); });
  EXPECT_EQ(msg.rfind(path_ + ": /levels/1/done: missing dataset", 0), 0u) << msg;

  file = H5Fopen(path_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  hid_t attr = H5Aopen(file, "format_version", H5P_DEFAULT);
  int two = 2;
  ASSERT_GE(H5Awrite(attr, H5T_NATIVE_INT, &two), 0);
  H5Aclose(attr);
  H5Fclose(file);
  msg = input_error_of([&] { FrameReader r(path_); });
  EXPECT_EQ(msg, path_ + ": /@format_version: format_version 2 unsupported (expected 1)");
}

TEST_F(FrameStoreTest, ExportWritesOneObjPerDoneFrameWithExactVertices) {
  std::map<int, Positions> frames;
  {
    FrameWriter w = make_writer(6);
    for (int t : {0, 1, 2, 4, 6}) {
      frames[t] = random_positions(10, rng_);
      w.write_frame(1, t, frames[t], make_stats(t, 2));
    }
  }
  FrameReader r(path_);
  fs::path out = dir_ / "obj" / "level1";
  EXPECT_EQ(export_obj_frames(r, 1, out.string()), 5);
  int files = 0;
  for (const auto& entry : fs::directory_iterator(out)) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 5);
  for (const auto& [t, X] : frames) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", t);
    std::ifstream in(out / name);
    ASSERT_TRUE(in) << name;
    std::vector<double> values;
    int face_lines = 0;
    for (std::string line; std::getline(in, line);) {
      std::istringstream ls(line);
      std::string tag;
      ls >> tag;
      if (tag == "f") ++face_lines;
      if (tag != "v") continue;
      for (std::string word; ls >> word;) values.push_back(std::strtod(word.c_str(), nullptr));
    }
    ASSERT_EQ(values.size(), 30u) << name;
    EXPECT_TRUE(bits_equal(values.data(), X.data(), 30)) << name;
    EXPECT_EQ(face_lines, 8) << name;
  }
  EXPECT_FALSE(fs::exists(out / "frame_00003.obj"));
  EXPECT_NE(input_error_of([&] { export_obj_frames(r, 5, out.string()); }).find("level out of range"),
            std::string::npos);
}

// ---------------------------------------------------------------------------------------------------
// FrameWriter::open, read_stats, clear_frame

void expect_frame_stats_bits(const FrameStats& got, const FrameStats& want, const std::string& where) {
  ASSERT_EQ(got.scalars.size(), want.scalars.size()) << where;
  for (size_t i = 0; i < want.scalars.size(); ++i) {
    EXPECT_EQ(got.scalars[i].first, want.scalars[i].first) << where;
    EXPECT_TRUE(bits_equal(&got.scalars[i].second, &want.scalars[i].second, 1))
        << where << " " << want.scalars[i].first;
  }
  ASSERT_EQ(got.center_of_mass.rows(), want.center_of_mass.rows()) << where;
  EXPECT_TRUE(bits_equal(got.center_of_mass.data(), want.center_of_mass.data(), want.center_of_mass.size())) << where;
}

TEST_F(FrameStoreTest, OpenedFileGoesOnWritingNewFramesOverwritesAndNewStats) {
  std::map<int, Positions> level0, level1;
  {
    FrameWriter w = make_writer(5);
    level0[0] = random_positions(6, rng_);
    level1[1] = random_positions(10, rng_);
    w.write_frame(0, 0, level0[0], make_stats(0, 1));
    w.write_frame(1, 1, level1[1], make_stats(1, 2));
    w.close();
  }
  {
    FrameWriter w = FrameWriter::open(path_);
    EXPECT_EQ(w.path(), path_);
    ASSERT_EQ(w.num_levels(), 2);
    EXPECT_EQ(w.num_frames(), 6);
    EXPECT_TRUE(w.is_done(0, 0));
    EXPECT_TRUE(w.is_done(1, 1));
    EXPECT_FALSE(w.is_done(0, 1));
    Positions x = w.read_frame(1, 1);
    EXPECT_TRUE(bits_equal(x.data(), level1[1].data(), x.size()));
    level0[3] = random_positions(6, rng_);  // a new frame with a statistic the file does not have yet
    FrameStats s = make_stats(3, 1);
    s.scalars.emplace_back("energy_contact", -0.0);
    w.write_frame(0, 3, level0[3], s);
    level1[1] = random_positions(10, rng_);  // overwrite of a frame stored before the reopening
    w.write_frame(1, 1, level1[1], make_stats(4, 2));
  }  // destructor closes
  FrameReader r(path_);
  EXPECT_EQ(r.done(0), (std::vector<uint8_t>{1, 0, 0, 1, 0, 0}));
  EXPECT_EQ(r.done(1), (std::vector<uint8_t>{0, 1, 0, 0, 0, 0}));
  int compared = 0;
  for (const auto* frames : {&level0, &level1}) {
    const int level = frames == &level0 ? 0 : 1;
    for (const auto& [t, X] : *frames) {
      Positions Y = r.frame(level, t);
      EXPECT_TRUE(bits_equal(X.data(), Y.data(), X.size())) << "level " << level << " frame " << t;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 3);
  EXPECT_EQ(r.stat_names(0), (std::vector<std::string>{"energy_contact", "kinetic_energy", "newton_iterations",
                                                       "solve_seconds"}));
  std::vector<double> e = r.stat(0, "energy_contact");
  EXPECT_TRUE(std::signbit(e[3]) && e[3] == 0.0);
  EXPECT_TRUE(std::isnan(e[0]));
  EXPECT_EQ(r.stat(1, "newton_iterations")[1], 5.0);  // make_stats(4, ...) replaced make_stats(1, ...)
  EXPECT_EQ(r.center_of_mass(1, 1), ObjectPoints::Constant(2, 3, 4 * 0.25));
}

TEST_F(FrameStoreTest, OpenedFileTakesTheNextLevel) {
  {
    FrameWriter w = FrameWriter::create(path_, "{}", 2);
    w.add_level(0, rest0_, strip_faces(3), {0, 6}, {"cloth"});
    w.write_frame(0, 2, rest0_, make_stats(2, 1));
  }
  {
    FrameWriter w = FrameWriter::open(path_);
    ASSERT_EQ(w.num_levels(), 1);
    EXPECT_NE(input_error_of([&] { w.add_level(2, rest1_, strip_faces(5), {0, 10}, {"a"}); }).find("in order"),
              std::string::npos);
    w.add_level(1, rest1_, strip_faces(5), {0, 4, 10}, {"cloth", "sphere"});
    w.write_frame(1, 0, rest1_, make_stats(0, 2));
  }
  FrameReader r(path_);
  ASSERT_EQ(r.num_levels(), 2);
  EXPECT_EQ(r.done(0), (std::vector<uint8_t>{0, 0, 1}));
  EXPECT_EQ(r.done(1), (std::vector<uint8_t>{1, 0, 0}));
  EXPECT_EQ(r.object_names(1), (std::vector<std::string>{"cloth", "sphere"}));
}

TEST_F(FrameStoreTest, ReadStatsGivesTheStoredStatsBackBitForBitSortedByName) {
  FrameStats a;
  a.scalars = {{"solve_seconds", 1.0 / 3.0}, {"energy_bending", -0.0}, {"contact_min_gap", HUGE_VAL},
               {"newton_iterations", 5e-324}, {"kinetic_energy", 1e-300}};
  a.center_of_mass = ObjectPoints(2, 3);
  a.center_of_mass << -0.0, 1.0 / 7.0, 2.5e-310, 1e300, -HUGE_VAL, 3.0;
  FrameStats b;  // fewer scalars, centre of mass not computed
  b.scalars = {{"newton_iterations", 7.0}};
  FrameStats a_sorted = a;
  std::sort(a_sorted.scalars.begin(), a_sorted.scalars.end());
  {
    FrameWriter w = make_writer(3);
    w.write_frame(1, 0, rest1_, a);
    w.write_frame(1, 2, rest1_, b);
    expect_frame_stats_bits(w.read_stats(1, 0), a_sorted, "writer, frame 0");
    expect_frame_stats_bits(w.read_stats(1, 2), b, "writer, frame 2");  // the other names read NaN: left out
    EXPECT_EQ(input_error_of([&] { w.read_stats(1, 1); }), path_ + ": /levels/1/stats: frame 1 of level 1 is not done");
    EXPECT_NE(input_error_of([&] { w.read_stats(1, 4); }).find("out of range [0, 4)"), std::string::npos);
    EXPECT_NE(input_error_of([&] { w.read_stats(2, 0); }).find("level out of range"), std::string::npos);
  }
  FrameWriter w = FrameWriter::open(path_);
  expect_frame_stats_bits(w.read_stats(1, 0), a_sorted, "reopened, frame 0");
  expect_frame_stats_bits(w.read_stats(1, 2), b, "reopened, frame 2");
  FrameStats none = w.read_stats(1, 2);
  EXPECT_EQ(none.center_of_mass.rows(), 0);
  EXPECT_EQ(none.center_of_mass.cols(), 3);
}

TEST_F(FrameStoreTest, ClearFrameWithdrawsTheFrameAndLeavesItsData) {
  const Positions X = random_positions(10, rng_);
  {
    FrameWriter w = make_writer(3);
    w.write_frame(1, 1, X, make_stats(1, 2));
    w.write_frame(1, 2, X, make_stats(2, 2));
    w.clear_frame(1, 1);
    EXPECT_FALSE(w.is_done(1, 1));
    EXPECT_TRUE(w.is_done(1, 2));
    EXPECT_EQ(input_error_of([&] { w.read_frame(1, 1); }),
              path_ + ": /levels/1/positions: frame 1 of level 1 is not done");
    w.clear_frame(1, 3);  // not done: stays so
    EXPECT_EQ(input_error_of([&] { w.clear_frame(1, 4); }),
              path_ + ": /levels/1/done: frame 4 of level 1 out of range [0, 4)");
    EXPECT_EQ(input_error_of([&] { w.clear_frame(-1, 0); }), path_ + ": /levels/-1/done: level out of range [0, 2)");
  }
  {
    FrameReader r(path_);
    EXPECT_EQ(r.done(1), (std::vector<uint8_t>{0, 0, 1, 0}));
  }
  hid_t file = H5Fopen(path_.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);  // the row itself is still there
  ASSERT_GE(file, 0);
  hid_t dset = H5Dopen2(file, "/levels/1/positions", H5P_DEFAULT);
  std::vector<double> all(4 * 10 * 3);
  ASSERT_GE(H5Dread(dset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, all.data()), 0);
  H5Dclose(dset);
  H5Fclose(file);
  EXPECT_TRUE(bits_equal(all.data() + 30, X.data(), 30));
  FrameWriter w = FrameWriter::open(path_);  // the cleared flag was flushed: the reopened file agrees
  EXPECT_FALSE(w.is_done(1, 1));
  EXPECT_TRUE(w.is_done(1, 2));
  w.write_frame(1, 1, X, make_stats(1, 2));
  EXPECT_TRUE(w.is_done(1, 1));
}

TEST_F(FrameStoreTest, OpenOfABadFileThrowsInputErrorNamingIt) {
  const std::string missing = (dir_ / "nope.h5").string();
  EXPECT_EQ(input_error_of([&] { FrameWriter::open(missing); }), missing + ": no such file");

  const std::string garbage = (dir_ / "garbage.h5").string();
  std::ofstream(garbage, std::ios::binary) << std::string("this is not HDF5\0\x01\x02 garbage bytes", 34);
  EXPECT_EQ(input_error_of([&] { FrameWriter::open(garbage); }), garbage + ": not an HDF5 file");

  const std::string no_levels = (dir_ / "no_levels.h5").string();
  FrameWriter::create(no_levels, "{}", 3).close();
  EXPECT_EQ(input_error_of([&] { FrameWriter::open(no_levels); }), no_levels + ": /levels: the file has no levels");

  {
    FrameWriter w = make_writer(3);
    for (int t = 0; t <= 3; ++t) w.write_frame(1, t, random_positions(10, rng_), make_stats(t, 2));
  }
  // Longer than HDF5's recorded end, as a writer killed inside a flush can leave it: readable, but not
  // to be written on.
  const std::string grown = (dir_ / "grown.h5").string();
  fs::copy_file(path_, grown);
  const auto clean_size = fs::file_size(grown);
  std::ofstream(grown, std::ios::binary | std::ios::app) << std::string(100, '\0');
  EXPECT_EQ(input_error_of([&] { FrameWriter::open(grown); }),
            grown + ": not closed cleanly by its last writer (killed while flushing?): the file has " +
                std::to_string(clean_size + 100) + " bytes but HDF5 allocated " + std::to_string(clean_size) +
                "; writing on could overwrite stored data, so it must be rebuilt");
  EXPECT_EQ(FrameReader(grown).done(1), std::vector<uint8_t>(4, 1));

  const std::string truncated = (dir_ / "truncated.h5").string();
  fs::copy_file(path_, truncated);
  fs::resize_file(truncated, fs::file_size(truncated) / 2);
  std::string msg = input_error_of([&] { FrameWriter::open(truncated); });
  EXPECT_EQ(msg.rfind(truncated + ": cannot open the HDF5 file for writing", 0), 0u) << msg;
  EXPECT_NE(msg.find("truncated file"), std::string::npos) << msg;  // HDF5's own words, appended

  // Edits with the C API: a mis-shaped statistic, a missing level dataset, another format_version.
  hid_t file = H5Fopen(path_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  hsize_t three = 3;
  hid_t space = H5Screate_simple(1, &three, nullptr);
  hid_t dset = H5Dcreate2(file, "/levels/0/stats/bad", H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(dset, 0);
  H5Dclose(dset);
  H5Sclose(space);
  H5Fclose(file);
  EXPECT_EQ(input_error_of([&] { FrameWriter::open(path_); }),
            path_ + ": /levels/0/stats/bad: shape (3), expected (4)");

  file = H5Fopen(path_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(H5Ldelete(file, "/levels/0/stats/bad", H5P_DEFAULT), 0);
  ASSERT_GE(H5Ldelete(file, "/levels/1/positions", H5P_DEFAULT), 0);
  H5Fclose(file);
  msg = input_error_of([&] { FrameWriter::open(path_); });
  EXPECT_EQ(msg.rfind(path_ + ": /levels/1/positions: missing dataset", 0), 0u) << msg;

  file = H5Fopen(path_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  hid_t attr = H5Aopen(file, "format_version", H5P_DEFAULT);
  int two = 2;
  ASSERT_GE(H5Awrite(attr, H5T_NATIVE_INT, &two), 0);
  H5Aclose(attr);
  H5Fclose(file);
  EXPECT_EQ(input_error_of([&] { FrameWriter::open(path_); }),
            path_ + ": /@format_version: format_version 2 unsupported (expected 1)");
}

}  // namespace
}  // namespace pd
