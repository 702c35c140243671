// read_pc2: the header checks, the size check before any allocation, and non-finite coordinates.
#include "geometry/pc2_io.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include <gtest/gtest.h>

#include "support/input_error_of.h"
#include "support/pc2_bytes.h"
#include "support/test_paths.h"

namespace pd {
namespace {

std::vector<Positions> two_samples() {
  Positions a(2, 3), b(2, 3);
  a << 0, 1, 2, 3, 4, 5;
  b << 0.5, 1.5, 2.5, -3, -4, -5;
  return {a, b};
}

std::string write(const std::string& dir, const std::string& name, const std::string& bytes) {
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

TEST(Pc2Io, ReadsEverySampleAndTheHeaderFields) {
  const std::string dir = test::scratch_dir("pc2");
  const std::string path = write(dir, "ok.pc2", test::pc2_bytes(two_samples(), 12.0f, 0.5f));
  const Pc2Cache c = read_pc2(path);
  EXPECT_EQ(c.start_frame, 12.0f);
  EXPECT_EQ(c.sample_rate, 0.5f);
  ASSERT_EQ(c.samples.size(), 2u);
  EXPECT_EQ(c.samples[0], two_samples()[0]);
  EXPECT_EQ(c.samples[1], two_samples()[1]);
}

TEST(Pc2Io, BadHeadersAndSizesNameTheFileAndTheField) {
  const std::string dir = test::scratch_dir("pc2-bad");
  const auto error = [&](const std::string& name, const std::string& bytes) {
    return test::input_error_of([&] { read_pc2(write(dir, name, bytes)); });
  };
  std::string wrong_magic = test::pc2_bytes(two_samples());
  wrong_magic[0] = 'Q';
  EXPECT_NE(error("magic.pc2", wrong_magic).find("magic.pc2: signature"), std::string::npos);
  EXPECT_NE(error("version.pc2", test::pc2_bytes(two_samples(), 0, 1, 2)).find("version.pc2: file version: 2"),
            std::string::npos);
  EXPECT_NE(error("points.pc2", test::pc2_bytes({}, 0, 1, 1, 0, 0)).find("points.pc2: number of points: 0"),
            std::string::npos);
  EXPECT_NE(error("neg.pc2", test::pc2_bytes(two_samples(), 0, 1, 1, 2, 0xFFFFFFFFL)).find("number of samples: -1"),
            std::string::npos);
  EXPECT_NE(error("rate.pc2", test::pc2_bytes(two_samples(), 0, 0.0f)).find("rate.pc2: sample rate"),
            std::string::npos);
  // A header that promises 2^31 - 1 points of one sample: refused by the size check, nothing allocated.
  EXPECT_NE(error("huge.pc2", test::pc2_bytes(two_samples(), 0, 1, 1, 0x7FFFFFFFL, 1)).find("huge.pc2: the file has 80 "
                                                                                          "bytes; its header"),
            std::string::npos);
  EXPECT_NE(error("short.pc2", "POINTCACHE2").find("less than a PC2 header"), std::string::npos);
  EXPECT_NE(test::input_error_of([&] { read_pc2(dir); }).find("is a directory, not a PC2 file"), std::string::npos);
  EXPECT_NE(test::input_error_of([&] { read_pc2(dir + "/missing.pc2"); }).find("missing.pc2: cannot open"),
            std::string::npos);
}

TEST(Pc2Io, ANonFiniteCoordinateNamesItsSamplePointAxisAndByte) {
  std::vector<Positions> s = two_samples();
  s[1](1, 1) = std::numeric_limits<double>::quiet_NaN();
  const std::string dir = test::scratch_dir("pc2-nan");
  const std::string message = test::input_error_of([&] { read_pc2(write(dir, "nan.pc2", test::pc2_bytes(s))); });
  // byte 32 + 24 (sample 0) + 12 (point 0) + 4 (y)
  EXPECT_NE(message.find("nan.pc2: sample 1, point 1, y (byte 72): not finite"), std::string::npos) << message;
}

}  // namespace
}  // namespace pd
