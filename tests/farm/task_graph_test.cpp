#include "farm/task_graph.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace pd::farm {
namespace {

// One task as a line, e.g. "level 1 (5,10] after needs 0:4 0:5", so that whole graphs compare
// readably; the hierarchy task is "hierarchy (0,0]".
std::string describe(const NewTask& t) {
  std::string s = t.kind == protocol::TaskKind::hierarchy ? "hierarchy" : "level " + std::to_string(t.level);
  s += " (" + std::to_string(t.first) + "," + std::to_string(t.last) + "]";
  if (t.after_hierarchy) s += " after";
  if (!t.needs.empty()) {
    s += " needs";
    for (const FrameKey& k : t.needs) s += " " + std::to_string(k.level) + ":" + std::to_string(k.frame);
  }
  if (t.stitch) s += " stitch";
  if (t.guides > 0) s += " guides " + std::to_string(t.guides);
  if (!t.guide_needs.empty()) {
    s += " guided by";
    for (const FrameKey& k : t.guide_needs) s += " " + std::to_string(k.level) + ":" + std::to_string(k.frame);
  }
  return s;
}

std::vector<std::string> describe(const std::vector<NewTask>& tasks) {
  std::vector<std::string> out;
  for (const NewTask& t : tasks) out.push_back(describe(t));
  return out;
}

std::string error_of(const GraphOptions& o) {
  try {
    job_tasks(o);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no invalid_argument thrown)";
}

TEST(TaskGraph, TenFramesThreeLevelsOneSubsetChunkFour) {
  const std::vector<std::string> expected = {
      "hierarchy (0,0]",
      "level 0 (0,4] after",
      "level 0 (4,8] after needs 0:3 0:4",
      "level 0 (8,10] after needs 0:7 0:8",
      "level 1 (0,10] after needs 0:0",
      "level 2 (0,10] after needs 1:0",
  };
  EXPECT_EQ(describe(job_tasks({10, 3, 1, 4, false})), expected);
}

TEST(TaskGraph, TenFramesThreeLevelsTwoSubsetsChunkFour) {
  const std::vector<std::string> expected = {
      "hierarchy (0,0]",
      "level 0 (0,4] after",
      "level 0 (4,8] after needs 0:3 0:4",
      "level 0 (8,10] after needs 0:7 0:8",
      "level 1 (0,5] after needs 0:0",
      "level 1 (5,10] after needs 0:4 0:5",
      "level 2 (0,5] after needs 1:0",
      "level 2 (5,10] after needs 1:4 1:5 1:6",
  };
  EXPECT_EQ(describe(job_tasks({10, 3, 2, 4, false})), expected);
}

TEST(TaskGraph, SubsetBoundariesAreRoundedKNOverK) {
  // 10 / 3 = 3.33 -> 3, 20 / 3 = 6.67 -> 7.
  const std::vector<std::string> expected = {
      "level 1 (0,3] after needs 0:0",
      "level 1 (3,7] after needs 0:2 0:3",
      "level 1 (7,10] after needs 0:6 0:7",
  };
  EXPECT_EQ(describe(refinement_tasks({10, 2, 3, 0, false})), expected);
}

TEST(TaskGraph, PreviewOnlyHasHierarchyAndLevelZeroOnly) {
  const std::vector<std::string> expected = {
      "hierarchy (0,0]",
      "level 0 (0,4] after",
      "level 0 (4,8] after needs 0:3 0:4",
      "level 0 (8,10] after needs 0:7 0:8",
  };
  EXPECT_EQ(describe(job_tasks({10, 3, 2, 4, true})), expected);
}

TEST(TaskGraph, RefinementTasksAreLevelsOneToLIgnoringPreviewOnly) {
  const std::vector<std::string> expected = {
      "level 1 (0,5] after needs 0:0",
      "level 1 (5,10] after needs 0:4 0:5",
      "level 2 (0,5] after needs 1:0",
      "level 2 (5,10] after needs 1:4 1:5 1:6",
  };
  EXPECT_EQ(describe(refinement_tasks({10, 3, 2, 4, true})), expected);
  EXPECT_EQ(describe(refinement_tasks({10, 3, 2, 4, false})), expected);
  EXPECT_TRUE(refinement_tasks({10, 1, 2, 4, false}).empty());  // a single level has nothing to refine
}

TEST(TaskGraph, PreviewOnlyPlusRefinementIsTheWholeJob) {
  const GraphOptions preview{37, 4, 3, 5, true}, whole{37, 4, 3, 5, false};
  std::vector<std::string> combined = describe(job_tasks(preview));
  for (const std::string& s : describe(refinement_tasks(preview))) combined.push_back(s);
  EXPECT_EQ(combined, describe(job_tasks(whole)));
}

TEST(TaskGraph, DefaultPreviewChunkIsFiftyFramesAtMostN) {
  EXPECT_EQ(default_preview_chunk(1), 1);
  EXPECT_EQ(default_preview_chunk(10), 10);
  EXPECT_EQ(default_preview_chunk(50), 50);
  EXPECT_EQ(default_preview_chunk(51), 50);
  EXPECT_EQ(default_preview_chunk(1000), 50);
  // preview_chunk 0 uses it: 120 frames -> (0,50], (50,100], (100,120].
  const std::vector<std::string> expected = {
      "hierarchy (0,0]",
      "level 0 (0,50] after",
      "level 0 (50,100] after needs 0:49 0:50",
      "level 0 (100,120] after needs 0:99 0:100",
  };
  EXPECT_EQ(describe(job_tasks({120, 1, 1, 0, false})), expected);
  EXPECT_THROW(default_preview_chunk(0), std::invalid_argument);
}

TEST(TaskGraph, ChunkLongerThanTheJobIsOneChunk) {
  const std::vector<std::string> expected = {"hierarchy (0,0]", "level 0 (0,7] after"};
  EXPECT_EQ(describe(job_tasks({7, 1, 1, 100, false})), expected);
}

TEST(TaskGraph, MoreSubsetsThanFramesAreClampedToOneFrameEach) {
  const std::vector<std::string> expected = {
      "level 1 (0,1] after needs 0:0",
      "level 1 (1,2] after needs 0:0 0:1",
      "level 1 (2,3] after needs 0:1 0:2",
  };
  EXPECT_EQ(describe(refinement_tasks({3, 2, 8, 0, false})), expected);
}

TEST(TaskGraph, LaterSubsetsOfLevelTwoOnWaitForTheirFeederToStart) {
  // Level 2 (3,6] also needs level 1's frame 4, the first frame of its feeder level 1 (3,6]; level 1
  // does not (level 0's chain is always running).
  const std::vector<std::string> two = {
      "level 1 (0,3] after needs 0:0",
      "level 1 (3,6] after needs 0:2 0:3",
      "level 2 (0,3] after needs 1:0",
      "level 2 (3,6] after needs 1:2 1:3 1:4",
  };
  EXPECT_EQ(describe(refinement_tasks({6, 3, 2, 0, false})), two);
  // Single-frame subsets are fed only frames that are stored at dispatch: no extra frame.
  const std::vector<std::string> single = {
      "level 1 (0,1] after needs 0:0",
      "level 1 (1,2] after needs 0:0 0:1",
      "level 1 (2,3] after needs 0:1 0:2",
      "level 2 (0,1] after needs 1:0",
      "level 2 (1,2] after needs 1:0 1:1",
      "level 2 (2,3] after needs 1:1 1:2",
  };
  EXPECT_EQ(describe(refinement_tasks({3, 3, 3, 0, false})), single);
}

TEST(TaskGraph, FedFramesAreLevelBelowFromMaxAMinusOneToBMinusOne) {
  const std::vector<NewTask> tasks = job_tasks({10, 3, 2, 4, false});
  ASSERT_EQ(tasks.size(), 8u);
  EXPECT_FALSE(fed_frames(tasks[0]).has_value());  // hierarchy
  EXPECT_FALSE(fed_frames(tasks[1]).has_value());  // level 0 (0,4]
  EXPECT_FALSE(fed_frames(tasks[2]).has_value());  // level 0 (4,8]
  const std::optional<FrameRange> first = fed_frames(tasks[4]);  // level 1 (0,5]
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->level, 0);
  EXPECT_EQ(first->first, 0);
  EXPECT_EQ(first->last, 4);
  const std::optional<FrameRange> second = fed_frames(tasks[7]);  // level 2 (5,10]
  ASSERT_TRUE(second.has_value());
  EXPECT_EQ(second->level, 1);
  EXPECT_EQ(second->first, 4);
  EXPECT_EQ(second->last, 9);
}

TEST(TaskGraph, ProducedFramesAreTheTasksOwnFramesWithFrameZeroForTheFirstTask) {
  const std::vector<NewTask> tasks = job_tasks({10, 3, 2, 4, false});
  ASSERT_EQ(tasks.size(), 8u);
  EXPECT_FALSE(produced_frames(tasks[0]).has_value());  // hierarchy
  const std::optional<FrameRange> start = produced_frames(tasks[1]);  // level 0 (0,4]
  ASSERT_TRUE(start.has_value());
  EXPECT_EQ(start->level, 0);
  EXPECT_EQ(start->first, 0);
  EXPECT_EQ(start->last, 4);
  const std::optional<FrameRange> later = produced_frames(tasks[7]);  // level 2 (5,10]
  ASSERT_TRUE(later.has_value());
  EXPECT_EQ(later->level, 2);
  EXPECT_EQ(later->first, 6);
  EXPECT_EQ(later->last, 10);
  NewTask bad;
  bad.level = 1;
  bad.first = 3;
  bad.last = 3;
  EXPECT_THROW(produced_frames(bad), std::invalid_argument);
}

TEST(TaskGraph, FedFramesRefusesAMalformedLevelTask) {
  NewTask t;
  t.level = 1;
  t.first = 5;
  t.last = 5;
  EXPECT_THROW(fed_frames(t), std::invalid_argument);
  t.last = 6;
  t.first = -1;
  EXPECT_THROW(fed_frames(t), std::invalid_argument);
  t.first = 0;
  t.level = -1;
  EXPECT_THROW(fed_frames(t), std::invalid_argument);
}

// Over a grid of N, K and chunk: every level's tasks are non-empty, contiguous from frame 0 and cover
// frames 1..N exactly once; needs and fed frames follow the rules in task_graph.h.
TEST(TaskGraph, EveryFrameOfEveryLevelIsCoveredExactlyOnceOverAGrid) {
  const int levels = 3;
  int cases = 0;
  for (int n = 1; n <= 25; ++n) {
    for (int k = 1; k <= 30; ++k) {
      for (int chunk = 0; chunk <= 12; ++chunk) {
        const std::vector<NewTask> tasks = job_tasks({n, levels, k, chunk, false});
        ASSERT_FALSE(tasks.empty());
        ASSERT_EQ(tasks[0].kind, protocol::TaskKind::hierarchy);
        EXPECT_FALSE(tasks[0].after_hierarchy);
        std::vector<std::vector<int>> covered(levels, std::vector<int>(n + 1, 0));
        std::vector<int> end(levels, 0), count(levels, 0);
        for (std::size_t i = 1; i < tasks.size(); ++i) {
          const NewTask& t = tasks[i];
          ASSERT_EQ(t.kind, protocol::TaskKind::level);
          ASSERT_TRUE(t.level >= 0 && t.level < levels);
          ASSERT_LT(t.first, t.last);
          EXPECT_TRUE(t.after_hierarchy);
          EXPECT_EQ(t.first, end[t.level]) << "tasks of a level are contiguous, in order";
          end[t.level] = t.last;
          ++count[t.level];
          for (int f = t.first + 1; f <= t.last; ++f) ++covered[t.level][f];
          std::vector<FrameKey> needs;
          if (t.level == 0 && t.first > 0) needs = {{0, t.first - 1}, {0, t.first}};
          if (t.level >= 1) needs = {{t.level - 1, std::max(t.first - 1, 0)}};
          if (t.level >= 1 && t.first > 0) needs.push_back({t.level - 1, t.first});
          if (t.level >= 2 && t.first > 0 && t.last > t.first + 1) needs.push_back({t.level - 1, t.first + 1});
          ASSERT_EQ(t.needs.size(), needs.size());
          for (std::size_t j = 0; j < needs.size(); ++j) {
            EXPECT_EQ(t.needs[j].level, needs[j].level);
            EXPECT_EQ(t.needs[j].frame, needs[j].frame);
          }
          const std::optional<FrameRange> fed = fed_frames(t);
          ASSERT_EQ(fed.has_value(), t.level >= 1);
          if (fed) {
            EXPECT_EQ(fed->level, t.level - 1);
            EXPECT_EQ(fed->first, std::max(t.first - 1, 0));
            EXPECT_EQ(fed->last, t.last - 1);
          }
        }
        const int chunk_used = chunk == 0 ? default_preview_chunk(n) : std::min(chunk, n);
        EXPECT_EQ(count[0], (n + chunk_used - 1) / chunk_used);
        for (int l = 0; l < levels; ++l) {
          EXPECT_EQ(end[l], n);
          if (l >= 1) {
            EXPECT_EQ(count[l], std::min(k, n));
          }
          for (int f = 1; f <= n; ++f) ASSERT_EQ(covered[l][f], 1) << "level " << l << " frame " << f;
        }
        ++cases;
      }
    }
  }
  EXPECT_EQ(cases, 25 * 30 * 13);
}

TEST(TaskGraph, EachSeamOfEachRefinementLevelGetsAStitchTaskGuidedByTheLaterSubsetsFirstFrames) {
  GraphOptions o{20, 3, 2, 20, false};
  o.stitch = 4;
  const std::vector<std::string> expected = {
      "hierarchy (0,0]",
      "level 0 (0,20] after",
      "level 1 (0,10] after needs 0:0",
      "level 1 (10,20] after needs 0:9 0:10 guides 3",
      "level 1 (10,13] after needs 0:9 0:10 1:9 1:10 stitch guided by 1:11",
      "level 2 (0,10] after needs 1:0",
      "level 2 (10,20] after needs 1:9 1:10 1:11 guides 3",
      "level 2 (10,13] after needs 1:9 1:10 1:11 2:9 2:10 stitch guided by 2:11",
  };
  EXPECT_EQ(describe(job_tasks(o)), expected);
  // The later subset stores 14..20; its 11..13 are guide frames, which the stitch task stores instead.
  const std::vector<NewTask> tasks = job_tasks(o);
  EXPECT_EQ(produced_frames(tasks[3])->first, 14);
  EXPECT_EQ(guide_frames(tasks[3])->first, 11);
  EXPECT_EQ(guide_frames(tasks[3])->last, 13);
  EXPECT_EQ(produced_frames(tasks[4])->first, 11);
  EXPECT_EQ(produced_frames(tasks[4])->last, 13);
  EXPECT_FALSE(guide_frames(tasks[4]).has_value());
  EXPECT_FALSE(guide_frames(tasks[2]).has_value());
}

TEST(TaskGraph, AStitchIsClampedToItsLaterSubsetAndLeftOutBelowTwoFrames) {
  // Later subset (8, 10]: w = min(4, 1) = 1 < 2: no stitch, no guides.
  GraphOptions o{10, 2, 2, 10, false};
  o.stitch = 4;
  EXPECT_EQ(describe(job_tasks(o, {8})).back(), "level 1 (8,10] after needs 0:7 0:8");
  // Later subset (6, 10]: w = 3, the stitch (6, 8] guided by 7 and 8 (ready once 7 is stored); the
  // subset keeps frames 9 and 10.
  EXPECT_EQ(describe(job_tasks(o, {6})).back(), "level 1 (6,8] after needs 0:5 0:6 1:5 1:6 stitch guided by 1:7");
  EXPECT_FALSE(stitch_task(1, 5, 10, 1).has_value());
  EXPECT_FALSE(stitch_task(1, 5, 10, 0).has_value());
  EXPECT_EQ(stitch_task(2, 5, 30, 16)->last, 20);
  EXPECT_EQ(stitch_task(2, 5, 15, 16)->last, 13);
}

TEST(TaskGraph, WithStitchesEveryFrameIsStoredOnceAndEveryGuideFrameFeedsOneStitch) {
  const int levels = 3;
  int cases = 0;
  for (int n = 1; n <= 25; ++n) {
    for (int k = 1; k <= 8; ++k) {
      for (int w = 0; w <= 6; ++w) {
        GraphOptions o{n, levels, k, 0, false};
        o.stitch = w;
        std::vector<std::vector<int>> stored(levels, std::vector<int>(n + 1, 0)), guides = stored, guided = stored;
        for (const NewTask& t : job_tasks(o)) {
          if (const std::optional<FrameRange> own = produced_frames(t))
            for (int f = own->first; f <= own->last; ++f) ++stored[t.level][f];
          if (const std::optional<FrameRange> g = guide_frames(t))
            for (int f = g->first; f <= g->last; ++f) ++guides[t.level][f];
          EXPECT_EQ(t.stitch, !t.guide_needs.empty());
          if (t.stitch) {
            // Ready once its first guide frame is stored; guided toward first + 1 .. last (fed).
            ASSERT_EQ(t.guide_needs.size(), 1u);
            EXPECT_EQ(t.guide_needs[0].level, t.level);
            EXPECT_EQ(t.guide_needs[0].frame, t.first + 1);
            for (int f = t.first + 1; f <= t.last; ++f) ++guided[t.level][f];
            EXPECT_LE(t.last - t.first + 1, w);
            // Its own frames s - 1 and s are never another stitch's (no chain of stitches).
            for (const NewTask& u : job_tasks(o)) {
              if (u.stitch && u.level == t.level && u.first < t.first) {
                EXPECT_LT(u.last, t.first - 1);
              }
            }
          }
        }
        for (int l = 0; l < levels; ++l)
          for (int f = 0; f <= n; ++f) {
            ASSERT_EQ(stored[l][f], 1) << "n " << n << " k " << k << " w " << w << " level " << l << " frame " << f;
            ASSERT_EQ(guides[l][f], guided[l][f]) << "level " << l << " frame " << f;
            ASSERT_LE(guides[l][f], 1);
          }
        ++cases;
      }
    }
  }
  EXPECT_EQ(cases, 25 * 8 * 7);
}

TEST(TaskGraph, BadOptionsAreRefusedNamingTheField) {
  EXPECT_EQ(error_of({0, 3, 1, 0, false}), "task graph: frames must be >= 1, got 0");
  EXPECT_EQ(error_of({10, 0, 1, 0, false}), "task graph: levels must be >= 1, got 0");
  EXPECT_EQ(error_of({10, 3, 0, 0, false}), "task graph: subsets must be >= 1, got 0");
  EXPECT_EQ(error_of({10, 3, 1, -2, false}), "task graph: preview_chunk must be >= 0, got -2");
  EXPECT_THROW(refinement_tasks({10, 3, -1, 0, false}), std::invalid_argument);
  GraphOptions negative_stitch{10, 3, 2, 0, false};
  negative_stitch.stitch = -1;
  EXPECT_EQ(error_of(negative_stitch), "task graph: stitch must be >= 0, got -1");
}

}  // namespace
}  // namespace pd::farm
