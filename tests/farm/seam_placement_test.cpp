// place_seams (farm/seam_placement.h): a seam leaves an impact for the calmest frame of its window, a
// calm shot keeps the even split, a contact change is avoided, the window and the order are kept;
// and job_tasks cuts the refinement levels at given seams (farm/task_graph.h).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "farm/seam_placement.h"
#include "farm/task_graph.h"

namespace pd::farm {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Frames 0..n with motion 1 everywhere it is defined.
PreviewProfile calm(int n) {
  PreviewProfile p;
  p.motion.assign(static_cast<std::size_t>(n + 1), 1.0);
  p.motion.front() = p.motion.back() = kNaN;
  return p;
}

TEST(SeamPlacement, ACalmShotKeepsTheEvenSplitAndSaysSo) {
  const std::vector<PlacedSeam> s = place_seams(calm(200), 4);
  ASSERT_EQ(s.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(s[k].frame, 50 * (k + 1));
    EXPECT_EQ(s[k].even, 50 * (k + 1));
    EXPECT_EQ(s[k].activity, 1.0);
    EXPECT_FALSE(s[k].contact_change);
    EXPECT_NE(s[k].reason.find("the even split"), std::string::npos) << s[k].reason;
  }
}

TEST(SeamPlacement, ASeamOnAnImpactMovesToTheNearestOrdinaryFrameOutsideIt) {
  // 200 frames, K = 2: even split 100, window [75, 125]. An impact at frames 95..104 (motion 20x),
  // and a quieter stretch at 110..120 (motion 0.5): the seam's frames s - 1..s + 2 must avoid the
  // impact: 92 or 106, and 106 is nearer; the quieter stretch farther on does not draw it (a seam
  // moved farther than it must unbalances the subsets).
  PreviewProfile p = calm(200);
  for (int t = 95; t <= 104; ++t) p.motion[t] = 20.0;
  for (int t = 110; t <= 120; ++t) p.motion[t] = 0.5;
  const std::vector<PlacedSeam> s = place_seams(p, 2);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].even, 100);
  EXPECT_EQ(s[0].frame, 106);
  EXPECT_EQ(s[0].activity, 1.0);
  // With no ordinary frame in the window (the impact covers it), the lowest score: the quietest.
  for (int t = 70; t <= 130; ++t) p.motion[t] = t >= 110 && t <= 120 ? 1.8 : 20.0;
  EXPECT_EQ(place_seams(p, 2)[0].frame, 111);
  EXPECT_NE(s[0].reason.find("moved from the even split 100 (motion 20.00x"), std::string::npos) << s[0].reason;
}

TEST(SeamPlacement, AContactThatStartsIsAvoidedEvenWhereTheMotionIsCalm) {
  // Contact pairs 0 before frame 100, 40 from frame 100 on (a landing), motion flat: every s in
  // 98..101 sees the change (its frames s - 2..s + 2 hold 99 and 100); of the calm 97 and 102, 102
  // is nearer the even split.
  PreviewProfile p = calm(200);
  p.contact_pairs.assign(201, 0.0);
  for (int t = 100; t <= 200; ++t) p.contact_pairs[t] = 40.0;
  const std::vector<PlacedSeam> s = place_seams(p, 2);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].frame, 102);
  EXPECT_FALSE(s[0].contact_change);
  EXPECT_NE(s[0].reason.find("a contact change"), std::string::npos) << s[0].reason;
  // Steady contact (a resting cube's counts wobbling within 2x) is no change.
  for (int t = 100; t <= 200; ++t) p.contact_pairs[t] = t % 2 ? 30.0 : 40.0;
  for (int t = 0; t < 100; ++t) p.contact_pairs[t] = 35.0;
  EXPECT_EQ(place_seams(p, 2)[0].frame, 100);
}

TEST(SeamPlacement, SeamsStayInTheirWindowsInOrderAndAtLeastTwoFramesApart) {
  // K = 5 of 40 frames: even splits 8, 16, 24, 32, w = 2. A spike on frames b + 1 and b + 2 of every
  // even split b: only s = b - 2 keeps its frames s - 1..s + 2 off it.
  PreviewProfile p = calm(40);
  for (int b : {8, 16, 24, 32}) p.motion[b + 1] = p.motion[b + 2] = 50.0;
  const std::vector<PlacedSeam> s = place_seams(p, 5);
  ASSERT_EQ(s.size(), 4u);
  int previous = 0;
  for (const PlacedSeam& seam : s) {
    EXPECT_EQ(seam.frame, seam.even - 2) << seam.reason;
    EXPECT_GE(seam.frame, previous + 2);
    previous = seam.frame;
  }
  // Windows of one frame either way (K = 10 of 40, w = 1): a seam never leaves its window.
  for (int t = 1; t < 40; ++t) p.motion[t] = t % 3 ? 1.0 : 9.0;
  for (const PlacedSeam& seam : place_seams(p, 10)) EXPECT_LE(std::abs(seam.frame - seam.even), 1) << seam.reason;
  // A subset too short for a window keeps the even split: 3 frames, K = 3.
  const std::vector<PlacedSeam> tiny = place_seams(calm(3), 3);
  ASSERT_EQ(tiny.size(), 2u);
  EXPECT_EQ(tiny[0].frame, 1);
  EXPECT_EQ(tiny[1].frame, 2);
}

TEST(SeamPlacement, ThePreviewProfileIsEachFramesLargestSecondDifferenceAndItsContactPairs) {
  // Two vertices; vertex 1 moves x = t^2 (second difference 2 every frame), vertex 0 rests but jumps
  // 5 m at frame 3 (second differences 5, -10, 5 at frames 2, 3, 4).
  const auto frame = [](int t) {
    Positions x = Positions::Zero(2, 3);
    x(0, 1) = t == 3 ? 5.0 : 0.0;
    x(1, 0) = double(t) * t;
    return x;
  };
  const PreviewProfile p = preview_profile(6, frame, [](int t) { return t < 3 ? 0.0 : 7.0; });
  ASSERT_EQ(p.motion.size(), 7u);
  EXPECT_TRUE(std::isnan(p.motion[0]));
  EXPECT_TRUE(std::isnan(p.motion[6]));
  const std::vector<double> want = {2.0, 5.0, 10.0, 5.0, 2.0};
  for (int t = 1; t <= 5; ++t) EXPECT_DOUBLE_EQ(p.motion[t], want[t - 1]) << t;
  EXPECT_EQ(p.contact_pairs[2], 0.0);
  EXPECT_EQ(p.contact_pairs[3], 7.0);
  const auto uneven = [](int t) { return Positions::Zero(t == 4 ? 3 : 2, 3).eval(); };
  EXPECT_THROW(preview_profile(6, uneven, [](int) { return 0.0; }), std::invalid_argument);
}

TEST(SeamPlacement, BadInputThrowsNamingTheField) {
  EXPECT_THROW(place_seams(calm(10), 0), std::invalid_argument);
  PreviewProfile one;
  one.motion = {kNaN};
  EXPECT_THROW(place_seams(one, 2), std::invalid_argument);
  PreviewProfile p = calm(10);
  p.contact_pairs = {0.0, 1.0};
  try {
    place_seams(p, 2);
    ADD_FAILURE() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("contact_pairs"), std::string::npos) << e.what();
  }
}

TEST(SeamPlacement, JobTasksCutEveryRefinementLevelAtTheGivenSeams) {
  GraphOptions o;
  o.frames = 100;
  o.levels = 3;
  o.subsets = 3;
  const std::vector<NewTask> tasks = job_tasks(o, {30, 71});
  std::vector<std::pair<int, int>> level1, level2;
  for (const NewTask& t : tasks) {
    if (t.kind != protocol::TaskKind::level || t.level == 0) continue;
    (t.level == 1 ? level1 : level2).push_back({t.first, t.last});
  }
  const std::vector<std::pair<int, int>> want = {{0, 30}, {30, 71}, {71, 100}};
  EXPECT_EQ(level1, want);
  EXPECT_EQ(level2, want);
  EXPECT_THROW(job_tasks(o, {30}), std::invalid_argument);       // 1 seam for 3 subsets
  EXPECT_THROW(job_tasks(o, {71, 30}), std::invalid_argument);   // not increasing
  EXPECT_THROW(job_tasks(o, {30, 100}), std::invalid_argument);  // not inside (0, N)
  EXPECT_EQ(refinement_tasks(o, {30, 71}).size(), 6u);
  // K above N is clamped to N, as without seams: 4 frames, K = 9, seams 1, 2, 3 (what place_seams gives).
  GraphOptions short_job = o;
  short_job.frames = 4;
  short_job.subsets = 9;
  EXPECT_EQ(refinement_tasks(short_job, {1, 2, 3}).size(), 8u);
  EXPECT_EQ(place_seams(calm(4), 9).size(), 3u);
}

}  // namespace
}  // namespace pd::farm
