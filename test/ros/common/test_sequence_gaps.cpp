// Messages lost before a node saw them, from the gaps in each publisher's header.seq.
#include <gtest/gtest.h>

#include "src/ros/common/sequence_gaps.h"

namespace bsf_vpr {
namespace {

TEST(SequenceGaps, CountsTheNumbersMissingBetweenTwoMessagesOfOnePublisher) {
  SequenceGaps gaps;
  EXPECT_EQ(gaps.Note("/camera", 10), 0u);  // the first says nothing
  EXPECT_EQ(gaps.Note("/camera", 11), 0u);
  EXPECT_EQ(gaps.Note("/camera", 15), 3u);  // 12, 13, 14 lost
  EXPECT_EQ(gaps.Note("/camera", 16), 0u);
  EXPECT_EQ(gaps.lost(), 3u);
}

TEST(SequenceGaps, PublishersAreCountedApart) {
  SequenceGaps gaps;
  gaps.Note("/a", 1);
  gaps.Note("/b", 100);
  EXPECT_EQ(gaps.Note("/a", 2), 0u);
  EXPECT_EQ(gaps.Note("/b", 102), 1u);
  EXPECT_EQ(gaps.lost(), 1u);
}

TEST(SequenceGaps, ANumberThatDoesNotFollowStartsAfreshAndCountsNothing) {
  SequenceGaps gaps;
  gaps.Note("/a", 500);
  EXPECT_EQ(gaps.Note("/a", 0), 0u);  // the publisher restarted
  EXPECT_EQ(gaps.Note("/a", 1), 0u);
  EXPECT_EQ(gaps.Note("/a", 1), 0u);            // a source that leaves seq alone (in-process)
  EXPECT_EQ(gaps.Note("/a", 4000000000u), 0u);  // a jump no queue can lose
  EXPECT_EQ(gaps.lost(), 0u);
}

}  // namespace
}  // namespace bsf_vpr
