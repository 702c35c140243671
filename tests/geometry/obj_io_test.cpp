// Tests of read_obj / write_obj: exact round trips, the accepted OBJ subset, and one test per kind of
// malformed input, each checking that the InputError names the file and the offending line.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <limits>
#include <string>
#include <thread>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "geometry/obj_io.h"
#include "geometry/shapes.h"

namespace pd {
namespace {

namespace fs = std::filesystem;

// A fresh directory per test, removed afterwards, so tests can run in parallel processes.
class ObjIo : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("pd_obj_io_" + std::string(info->name()) + "_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + std::to_string(reinterpret_cast<std::uintptr_t>(this)));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string write_text(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  // Reading `text` must throw InputError whose message starts "<path>:<line>:" and contains `detail`.
  void expect_error_at(const std::string& text, int line, const std::string& detail) {
    const std::string path = write_text("bad.obj", text);
    try {
      read_obj(path);
      ADD_FAILURE() << "no InputError for:\n" << text;
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind(path + ":" + std::to_string(line) + ": ", 0), 0u) << msg;
      EXPECT_NE(msg.find(detail), std::string::npos) << msg;
    }
  }
  fs::path dir_;
};

bool bit_equal(const TriMesh& a, const TriMesh& b) {
  return a.V.rows() == b.V.rows() && a.F.rows() == b.F.rows() &&
         std::memcmp(a.V.data(), b.V.data(), sizeof(double) * a.V.size()) == 0 &&
         std::memcmp(a.F.data(), b.F.data(), sizeof(int) * a.F.size()) == 0;
}

TEST_F(ObjIo, RoundTripIsBitExactForAwkwardDoubles) {
  // Values that need all 17 digits, the extremes of the double range, subnormals and -0.0.
  TriMesh m;
  m.V.resize(4, 3);
  m.V << 0.1, 1.0 / 3.0, -0.0,                                   //
      std::numeric_limits<double>::max(), std::numeric_limits<double>::denorm_min(), -2.0 / 3.0,  //
      std::numeric_limits<double>::min(), 3.141592653589793, -1e-300,                             //
      123456789.12345679, -9.8765432109876543e-5, 2.0000000000000004;
  m.F.resize(2, 3);
  m.F << 0, 1, 2, 0, 2, 3;
  const std::string path = (dir_ / "awkward.obj").string();
  write_obj(path, m.V, m.F);
  const TriMesh back = read_obj(path);
  EXPECT_TRUE(bit_equal(m, back));
  EXPECT_TRUE(std::signbit(back.V(0, 2)));  // -0.0 keeps its sign
}

TEST_F(ObjIo, RoundTripIsBitExactForRotatedIcosphere) {
  TriMesh m = make_icosphere(0.37, 2);
  // A rotation makes every coordinate a "random" double with a full mantissa.
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  m.V = (m.V * R.transpose()).eval();
  const std::string path = (dir_ / "sphere.obj").string();
  write_obj(path, m.V, m.F);
  EXPECT_TRUE(bit_equal(m, read_obj(path)));
}

TEST_F(ObjIo, PolygonsAreFanTriangulatedAroundFirstCorner) {
  const TriMesh m = read_obj(write_text("poly.obj",
                                        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 1 0\n"
                                        "f 1 2 3 4\n"         // quad -> 2 triangles
                                        "f 1 2 3 4 5\n"));    // pentagon -> 3 triangles
  ASSERT_EQ(m.num_faces(), 5);
  Faces expected(5, 3);
  expected << 0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 3, 0, 3, 4;
  EXPECT_EQ(m.F, expected);
}

TEST_F(ObjIo, NegativeIndicesAreRelativeToVerticesReadSoFar) {
  const TriMesh m = read_obj(write_text("rel.obj",
                                        "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                        "f -3 -2 -1\n"          // the three vertices above
                                        "v 1 1 0\n"
                                        "f -3 -1 -2\n"));       // vertices 2, 4, 3 (1-based)
  Faces expected(2, 3);
  expected << 0, 1, 2, 1, 3, 2;
  EXPECT_EQ(m.F, expected);
}

TEST_F(ObjIo, SlashFormsCommentsCrlfAndOtherStatementsAreHandled) {
  const TriMesh m = read_obj(write_text("mixed.obj",
                                        "# comment\r\nmtllib a.mtl\r\no thing\r\ng group\r\n"
                                        "v 0 0 0 1\r\nv +1 0 0\r\n\tv 0 1e0 0   # trailing comment\r\n"
                                        "vt 0 0\r\nvn 0 0 1\r\nusemtl red\r\ns off\r\n"
                                        "f 1/1 2/1/1 3//1\r\n"));
  ASSERT_EQ(m.num_vertices(), 3);
  ASSERT_EQ(m.num_faces(), 1);
  EXPECT_EQ(m.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(m.V(1, 0), 1.0);
  EXPECT_EQ(m.V(2, 1), 1.0);
}

TEST_F(ObjIo, FacesMayReferenceVerticesDefinedLater) {
  const TriMesh m = read_obj(write_text("later.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"));
  EXPECT_EQ(m.num_faces(), 1);
  EXPECT_EQ(m.num_vertices(), 3);
}

TEST_F(ObjIo, MissingFileNamesPathAndReason) {
  const std::string path = (dir_ / "does_not_exist.obj").string();
  try {
    read_obj(path);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": cannot open: " + std::strerror(ENOENT));
  }
}

TEST_F(ObjIo, DirectoryIsRefusedAsNotARegularFile) {
  try {
    read_obj(dir_.string());
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), dir_.string() + ": is a directory, not an OBJ file");
  }
}

// read_obj(path) in a thread, waited for at most 5 s. If it blocks in open() on a FIFO, opening the
// FIFO's write end (non-blocking) releases it, so a regression fails the test instead of hanging it.
std::string error_within_five_seconds(const std::string& path, bool* in_time) {
  std::promise<std::string> result;
  std::future<std::string> done = result.get_future();
  std::thread reader([&] {
    try {
      read_obj(path);
      result.set_value("(no InputError)");
    } catch (const InputError& e) {
      result.set_value(e.what());
    }
  });
  *in_time = done.wait_for(std::chrono::seconds(5)) == std::future_status::ready;
  if (!*in_time) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_NONBLOCK);
    if (fd >= 0) ::close(fd);
  }
  reader.join();
  return done.get();
}

TEST_F(ObjIo, FifoIsRefusedWithoutBlocking) {
  const std::string fifo = (dir_ / "mesh.obj").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0) << std::strerror(errno);
  bool in_time = false;
  const std::string message = error_within_five_seconds(fifo, &in_time);
  ASSERT_TRUE(in_time) << "read_obj blocked on a FIFO";
  EXPECT_EQ(message, fifo + ": is a FIFO, not an OBJ file");
}

TEST_F(ObjIo, DeviceIsRefusedWithoutReading) {
  // /dev/zero would never reach a newline; /dev/null would read as an empty file.
  for (const char* device : {"/dev/zero", "/dev/null"}) {
    bool in_time = false;
    const std::string message = error_within_five_seconds(device, &in_time);
    ASSERT_TRUE(in_time) << device;
    EXPECT_EQ(message, std::string(device) + ": is a character device, not an OBJ file");
  }
}

TEST_F(ObjIo, SymlinkToARegularFileIsRead) {
  const std::string target = write_text("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const fs::path link = dir_ / "link.obj";
  fs::create_symlink(target, link);
  EXPECT_EQ(read_obj(link.string()).num_faces(), 1);
}

TEST_F(ObjIo, FileOverTheSizeLimitIsRefusedBeforeReading) {
  const std::string path = write_text("big.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n" + std::string(200, '#'));
  ObjLimits limits;
  limits.max_bytes = 100;
  try {
    read_obj(path, limits);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": the file has 232 bytes, more than the limit of 100");
  }
  limits.max_bytes = 232;
  EXPECT_EQ(read_obj(path, limits).num_faces(), 1);
}

TEST_F(ObjIo, VertexAndFaceLimitsStopAtTheLineThatCrossesThem) {
  const std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3 4\nf 1 2 3\n";
  const std::string path = write_text("quad.obj", text);
  ObjLimits limits;
  limits.max_vertices = 3;
  const auto message_of = [&](const ObjLimits& l) {
    try {
      read_obj(path, l);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(no InputError)");
  };
  EXPECT_EQ(message_of(limits), path + ":4: more than 3 vertices (the limit)");
  limits.max_vertices = 4;
  limits.max_faces = 2;  // the quad gives 2 triangles, line 6 the third
  EXPECT_EQ(message_of(limits),
            path + ":6: more than 2 faces (the limit, after splitting polygons into triangles)");
  limits.max_faces = 3;
  EXPECT_EQ(read_obj(path, limits).num_faces(), 3);
}

TEST_F(ObjIo, OverlongLineNamesItsLineWithoutReadingItAll) {
  expect_error_at("v 0 0 0\nv 1 0 0\n# " + std::string(70000, 'x') + "\nf 1 2 3\n", 3, "line longer than 65536 bytes");
}

TEST_F(ObjIo, ControlCharactersInBadTokensAreEscaped) {
  expect_error_at("v 0 0 0\nv 1 \x01\x1b[2J 0\n", 2, "malformed number \"\\x01\\x1b[2J\"");
  expect_error_at("v 0 0 0\nv 1 " + std::string(500, '9') + "x 0\n", 2, "...\"(501 chars)");
}

TEST_F(ObjIo, BadNumberNamesLine) {
  expect_error_at("v 0 0 0\nv 1 0x 0\n", 2, "malformed number \"0x\"");
  expect_error_at("v 0 0 0\nv 1 +-1 0\n", 2, "malformed number");
  expect_error_at("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 three\n", 4, "malformed vertex index \"three\"");
  expect_error_at("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 /3\n", 4, "malformed vertex index");
}

TEST_F(ObjIo, IndexZeroNamesLine) {
  expect_error_at("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4, "vertex index 0");
}

TEST_F(ObjIo, IndexOutOfRangeNamesLine) {
  // Checked against the final vertex count (5), but reported at the face's line.
  expect_error_at("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\nv 0 0 1\nv 0 0 2\n", 4,
                  "vertex index 7 is out of range (file has 5 vertices)");
}

TEST_F(ObjIo, PositiveIndexBeyondLastVertexNamesLine) {
  expect_error_at("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 3\nf 1 2 4\n", 6, "vertex index 4 is out of range");
}

TEST_F(ObjIo, HugeIndicesNameLine) {
  expect_error_at("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4294967298\n", 4, "out of range");
  expect_error_at("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n", 4, "out of range");
  expect_error_at("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9223372036854775808\n", 4, "before the first vertex");
}

TEST_F(ObjIo, RelativeIndexBeforeFirstVertexNamesLine) {
  expect_error_at("v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n", 3, "before the first vertex");
}

TEST_F(ObjIo, TooFewIndicesNamesLine) {
  expect_error_at("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", 4, "at least 3 vertex indices");
  expect_error_at("v 0 0 0\nv 1 0 0\nv 0 1 0\nf\n", 4, "at least 3 vertex indices");
  expect_error_at("v 0 0\n", 1, "vertex needs 3 coordinates");
}

TEST_F(ObjIo, NonFiniteCoordinateNamesLine) {
  expect_error_at("v 0 0 0\nv nan 0 0\n", 2, "not finite");
  expect_error_at("v 0 0 0\nv 0 -inf 0\n", 2, "not finite");
  expect_error_at("v 0 0 0\nv 0 0 infinity\n", 2, "not finite");
  expect_error_at("v 0 0 0\nv 0 0 1e999\n", 2, "out of range");
}

TEST_F(ObjIo, NoFacesNamesLastLine) {
  expect_error_at("v 0 0 0\nv 1 0 0\nv 0 1 0\n", 3, "no faces");
  expect_error_at("", 1, "no faces");  // empty file
}

TEST_F(ObjIo, GarbageThrowsInputErrorInsteadOfCrashing) {
  std::string garbage;
  for (int i = 0; i < 4096; ++i) garbage += static_cast<char>((i * 7919 + 13) % 256);
  EXPECT_THROW(read_obj(write_text("garbage.obj", garbage)), InputError);
  EXPECT_THROW(read_obj(write_text("garbage2.obj", "f f f f\nv v v v\n")), InputError);
}

TEST_F(ObjIo, WriteToMissingDirectoryThrows) {
  const TriMesh m = make_icosphere(1.0, 0);
  const std::string path = (dir_ / "no_such_dir" / "out.obj").string();
  try {
    write_obj(path, m.V, m.F);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ": cannot write", 0), 0u) << e.what();
  }
}

}  // namespace
}  // namespace pd
