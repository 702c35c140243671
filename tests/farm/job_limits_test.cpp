#include "farm/job_limits.h"

#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "support/input_error_of.h"

namespace pd::farm {
namespace {

constexpr double kPlenty = std::numeric_limits<double>::infinity();

// The bound is job_tasks' count exactly without stitches, and never below it with them, over a grid
// of frames, levels, subsets, chunks and preview_only (both kinds of request).
TEST(JobLimits, TheTaskBoundIsTheGraphsCountWithoutStitchesAndNeverBelowIt) {
  int compared = 0;
  for (int frames : {1, 2, 7, 50, 101, 600})
    for (int levels : {1, 2, 4})
      for (int subsets : {1, 2, 3, 8, 1000})
        for (int chunk : {0, 1, 7})
          for (int stitch : {0, 10})
            for (bool preview_only : {false, true}) {
              GraphOptions o{frames, levels, subsets, chunk, preview_only, stitch};
              const int64_t all = static_cast<int64_t>(job_tasks(o).size());
              const int64_t refinement = static_cast<int64_t>(refinement_tasks(o).size());
              if (stitch == 0) {
                EXPECT_EQ(job_task_bound(o), all) << frames << " " << levels << " " << subsets << " " << chunk;
                EXPECT_EQ(job_task_bound(o, true), refinement);
              } else {
                EXPECT_GE(job_task_bound(o), all);
                EXPECT_GE(job_task_bound(o, true), refinement);
              }
              ++compared;
            }
  EXPECT_EQ(compared, 6 * 3 * 5 * 3 * 2 * 2);
}

// The requests (each field within pd's own range), refused by name before anything is made.
TEST(JobLimits, AbsurdCombinationsAreRefusedNamingTheFieldsAndTheFigures) {
  GraphOptions o{10'000'000, 20, 10'000'000, 0, false, 10};
  EXPECT_EQ(test::input_error_of([&] { check_job_size("submit", o, false, 613, 4.0, kPlenty); }),
            "submit: 10000000 frames, 20 levels, 10000000 subsets and preview chunks of 50 frames would need "
            "380199982 tasks; the limit is 20000 (fewer --subsets, a longer --preview-chunk)");
  o = GraphOptions{10'000'000, 1, 1, 1, false, 0};
  EXPECT_EQ(test::input_error_of([&] { check_job_size("submit", o, false, 613, 4.0, kPlenty); }),
            "submit: 10000000 frames, 1 levels, 1 subsets and preview chunks of 1 frames would need 10000001 tasks; "
            "the limit is 20000 (fewer --subsets, a longer --preview-chunk)");
  o = GraphOptions{200, 2147483647, 1, 0, false, 0};
  EXPECT_EQ(test::input_error_of([&] { check_job_size("submit", o, false, 613, 4.0, kPlenty); }),
            "submit: levels: must be 1 to 20, got 2147483647");
  o = GraphOptions{0, 2, 1, 0, false, 0};
  EXPECT_EQ(test::input_error_of([&] { check_job_size("submit", o, false, 613, 4.0, kPlenty); }),
            "submit: frames: must be 1 to 10000000, got 0");
  // Storage: 100 000 frames of a 1 M-vertex sheet over 4 levels, against 100 GiB free.
  o = GraphOptions{100'000, 4, 2, 0, false, 10};
  EXPECT_EQ(test::input_error_of([&] { check_job_size("submit", o, false, 1'000'000, 4.0, 100.0 * (1 << 30)); }),
            "submit: 100000 frames of 4 levels (1000000 vertices on the finest) would need 5937.2 GiB of frame "
            "storage; the farm folder has 100.0 GiB free (fewer --frames or --levels, or free space)");
  // A production shot passes: flag-large-10s, 1 000 frames, K = 64 on 4 levels.
  o = GraphOptions{1000, 4, 64, 0, false, 10};
  EXPECT_NO_THROW(check_job_size("submit", o, false, 6161, 4.0, 10.0 * (1 << 30)));
  EXPECT_EQ(job_task_bound(o), 1 + 20 + 3 * (64 + 63));
  // A refine counts its refinement tasks only.
  o = GraphOptions{100'000, 4, 10'000, 0, false, 0};
  EXPECT_EQ(test::input_error_of([&] { check_job_size("refine", o, true, 0, 4.0, kPlenty); }),
            "refine: 100000 frames, 4 levels, 10000 subsets and preview chunks of 50 frames would need 30000 "
            "tasks; the limit is 20000 (fewer --subsets, a longer --preview-chunk)");
}

TEST(JobLimits, FrameBytesCountEveryLevelTwice) {
  // 100 finest vertices, ratio 4, 3 levels: 100 + 25 + 6.25 vertices, 11 frames, 24 bytes, twice.
  EXPECT_DOUBLE_EQ(job_frame_bytes(10, 3, 100, 4.0), 2.0 * 24.0 * 131.25 * 11.0);
  EXPECT_GT(free_bytes_at("/"), 0.0);
  EXPECT_EQ(free_bytes_at("/no/such/folder/at/all"), std::numeric_limits<double>::infinity());
}

}  // namespace
}  // namespace pd::farm
