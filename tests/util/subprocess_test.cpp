#include "util/subprocess.h"

#include <gtest/gtest.h>

#include <chrono>

namespace pd {
namespace {

using std::chrono::milliseconds;

TEST(Subprocess, CapturesStdoutStderrAndExitCode) {
  const CommandResult r = run_command({"sh", "-c", "echo out; echo err >&2; exit 3"}, milliseconds(5000));
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_FALSE(r.timed_out);
  EXPECT_EQ(r.out, "out\n");
  EXPECT_EQ(r.err, "err\n");
  EXPECT_EQ(r.failure, "sh: exit 3: err");
  const CommandResult ok = run_command({"true"}, milliseconds(5000));
  EXPECT_EQ(ok.exit_code, 0);
  EXPECT_EQ(ok.failure, "");
}

TEST(Subprocess, ACommandPastItsTimeoutIsKilledWithItsChildren) {
  const auto start = std::chrono::steady_clock::now();
  // The child shell's own child (sleep) keeps the pipes open: only a kill of the group ends it.
  const CommandResult r = run_command({"sh", "-c", "sleep 30 & sleep 30"}, milliseconds(300));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_TRUE(r.timed_out);
  EXPECT_EQ(r.exit_code, -1);
  EXPECT_EQ(r.failure, "sh: timed out after 0.3 s");
  EXPECT_LT(seconds, 5.0);
  EXPECT_GE(r.seconds, 0.3);
  EXPECT_LE(r.seconds, seconds);
}

TEST(Subprocess, AMissingProgramIsAFailureNotACrash) {
  const CommandResult r = run_command({"/nonexistent/sbatch"}, milliseconds(1000));
  EXPECT_EQ(r.exit_code, -1);
  EXPECT_EQ(r.failure, "/nonexistent/sbatch: cannot run: No such file or directory");
  EXPECT_NE(run_command({}, milliseconds(100)).failure, "");
}

TEST(Subprocess, OutputIsCutAtTheLimit) {
  const CommandResult r = run_command({"sh", "-c", "head -c 3000000 /dev/zero"}, milliseconds(10000));
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.out.size(), kMaxCommandOutput);
}

TEST(Subprocess, ACheckRefusalIsItsFirstErrorLineOnlyWhenItExitedTwo) {
  CommandResult r;
  r.exit_code = 2;
  r.err = "pd: error: f.h5: /@scene: missing attribute\nmore\n";
  EXPECT_EQ(check_refusal(r, "pd: error: "), "f.h5: /@scene: missing attribute");
  r.exit_code = 139;  // crashed: the caller says how
  EXPECT_EQ(check_refusal(r, "pd: error: "), std::nullopt);
  r.exit_code = 2;
  r.timed_out = true;
  EXPECT_EQ(check_refusal(r, "pd: error: "), std::nullopt);
  r.timed_out = false;
  r.err = "";
  EXPECT_EQ(check_refusal(r, "pd: error: "), std::nullopt);
}

}  // namespace
}  // namespace pd
