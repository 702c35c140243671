#include "scheduler/refusal_rows.h"

#include <gtest/gtest.h>

#include <string>

namespace pd::scheduler {
namespace {

TEST(RefusalRows, APeerGetsTwentyRowsAWindowAndTheRestIsCountedWhenTheWindowEnds) {
  RefusalRows rows;
  int admitted = 0;
  for (int k = 0; k < 1000; ++k) admitted += rows.admit("peer-a", 10.0 + 0.01 * k) ? 1 : 0;
  for (int k = 0; k < 5; ++k) admitted += rows.admit("peer-b", 12.0) ? 1 : 0;
  EXPECT_EQ(admitted, RefusalRows::kRowsPerPeer + 5);
  EXPECT_TRUE(rows.closed(69.9).empty());  // peer-a's window started at 10 s
  const auto ended = rows.closed(70.0);
  ASSERT_EQ(ended.size(), 1u);
  EXPECT_EQ(ended[0].identity, "peer-a");
  EXPECT_EQ(ended[0].refusals, 1000 - RefusalRows::kRowsPerPeer);
  EXPECT_EQ(rows.tracked(), 1u);  // peer-b, nothing counted yet
  EXPECT_TRUE(rows.closed(72.0).empty());  // peer-b's window ended with nothing counted: forgotten
  EXPECT_EQ(rows.tracked(), 0u);
  EXPECT_TRUE(rows.admit("peer-a", 80.0));  // a new window
}

TEST(RefusalRows, PeersBeyondTheTrackedNumberShareOneCountedEntry) {
  RefusalRows rows;
  for (std::size_t k = 0; k < RefusalRows::kMaxPeers; ++k) EXPECT_TRUE(rows.admit("p" + std::to_string(k), 0.0));
  EXPECT_FALSE(rows.admit("one more", 1.0));
  EXPECT_FALSE(rows.admit("and another", 1.0));
  EXPECT_EQ(rows.tracked(), RefusalRows::kMaxPeers + 1);
  const auto ended = rows.closed(100.0);
  ASSERT_EQ(ended.size(), 1u);
  EXPECT_EQ(ended[0].identity, RefusalRows::kOtherPeers);
  EXPECT_EQ(ended[0].refusals, 2);
  EXPECT_EQ(rows.tracked(), 0u);
}

}  // namespace
}  // namespace pd::scheduler
