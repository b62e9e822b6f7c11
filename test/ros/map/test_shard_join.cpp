// The join of a sharded map's answers with its clock in the test's hands: stamp order,
// timeouts, late answers, a shard's return, a shard that stops publishing, overflow.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "src/ros/map/shard_join.h"

namespace bsf_vpr {
namespace {

using AnswerPtr = std::shared_ptr<const int>;  // a shard's answer: here the shard's number
using Join = ShardJoin<AnswerPtr>;

struct Fixture {
  explicit Fixture(int shards, double timeout_s = 0.5, size_t queue = 100)
      : can_answer(static_cast<size_t>(shards), true),
        join(
            shards, timeout_s, queue, [this](int k) { return can_answer[static_cast<size_t>(k)]; },
            [this](Join::Level level, int k, const std::string& what) {
              log.push_back(std::string(level == Join::Level::kWarn ? "warn " : "info ") +
                            std::to_string(k) + " " + what);
            }) {}

  std::vector<Join::Decision> Answer(int k, int64_t stamp, double now) {
    return join.Answer(k, stamp, std::make_shared<const int>(k), now);
  }
  static std::vector<int64_t> Stamps(const std::vector<Join::Decision>& d) {
    std::vector<int64_t> out;
    for (const Join::Decision& x : d) out.push_back(x.stamp_ns);
    return out;
  }
  static int Answered(const Join::Decision& d) {
    int n = 0;
    for (const AnswerPtr& a : d.answers) n += a != nullptr;
    return n;
  }

  std::vector<bool> can_answer;
  std::vector<std::string> log;
  Join join;
};

TEST(ShardJoin, DecidesAQueryOnceEveryShardAnsweredInStampOrder) {
  Fixture f(3);
  EXPECT_TRUE(f.Answer(0, 10, 0.0).empty());
  EXPECT_TRUE(f.Answer(1, 10, 0.01).empty());
  EXPECT_TRUE(f.Answer(0, 20, 0.02).empty());  // the next query waits behind the first
  const auto first = f.Answer(2, 10, 0.03);
  ASSERT_EQ(Fixture::Stamps(first), std::vector<int64_t>{10});
  EXPECT_EQ(Fixture::Answered(first[0]), 3);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(*first[0].answers[static_cast<size_t>(k)], k);
  EXPECT_TRUE(f.Answer(2, 20, 0.04).empty());
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 20, 0.05)), std::vector<int64_t>{20});
  EXPECT_EQ(f.join.pending(), 0u);
}

TEST(ShardJoin, ASlowShardIsDecidedWithoutAtTheTimeoutAndTakenBackWhenOnTime) {
  Fixture f(2, /*timeout_s=*/0.5);
  f.Answer(0, 10, 0.0);
  EXPECT_TRUE(f.join.Tick(0.49).empty());
  const auto timed_out = f.join.Tick(0.5);
  ASSERT_EQ(Fixture::Stamps(timed_out), std::vector<int64_t>{10});
  EXPECT_EQ(Fixture::Answered(timed_out[0]), 1);
  EXPECT_TRUE(f.join.counts(1).missing);
  EXPECT_EQ(f.join.counts(1).missed, 1);
  // Missing: not waited for, so the next query is decided at shard 0's answer.
  EXPECT_EQ(Fixture::Stamps(f.Answer(0, 20, 0.6)), std::vector<int64_t>{20});
  // Its late answer for a decided stamp is dropped and counted; it does not bring it back.
  EXPECT_TRUE(f.Answer(1, 10, 0.7).empty());
  EXPECT_EQ(f.join.counts(1).late, 1);
  EXPECT_TRUE(f.join.counts(1).missing);
  // An answer in time (a stamp not decided yet) does: the query after waits for it again.
  EXPECT_TRUE(f.Answer(1, 30, 0.8).empty());
  EXPECT_FALSE(f.join.counts(1).missing);
  EXPECT_EQ(Fixture::Stamps(f.Answer(0, 30, 0.81)), std::vector<int64_t>{30});
  EXPECT_TRUE(f.Answer(0, 40, 0.9).empty());  // waits for shard 1 again
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 40, 0.91)), std::vector<int64_t>{40});
  ASSERT_FALSE(f.log.empty());
  EXPECT_NE(f.log.front().find("warn 1 did not answer within 0.50 s"), std::string::npos);
  EXPECT_NE(f.log.back().find("info 1 answers again"), std::string::npos);
}

TEST(ShardJoin, AShardThatCannotAnswerIsNotWaitedFor) {
  Fixture f(2);
  f.can_answer[1] = false;  // no shard_info yet, or its process ended
  EXPECT_EQ(Fixture::Stamps(f.Answer(0, 10, 0.0)), std::vector<int64_t>{10});
  EXPECT_EQ(f.join.counts(1).missed, 0);  // not expected: nothing missed
  f.can_answer[1] = true;                 // a respawn (its layout is the owner's business)
  EXPECT_TRUE(f.Answer(0, 20, 0.1).empty());
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 20, 0.11)), std::vector<int64_t>{20});
}

TEST(ShardJoin, AQueryLateFromEveryShardIsDecidedAndTheStampsStartAfresh) {
  Fixture f(2);
  f.Answer(0, 100, 0.0);
  f.Answer(1, 100, 0.0);
  // A bag replayed again: stamps go back, every shard answers them.
  EXPECT_TRUE(f.Answer(0, 50, 1.0).empty());
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 50, 1.01)), std::vector<int64_t>{50});
  EXPECT_EQ(f.join.counts(0).late, 0);  // not counted as late once decided
  EXPECT_TRUE(f.Answer(0, 60, 1.1).empty());
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 60, 1.11)), std::vector<int64_t>{60});
}

TEST(ShardJoin, ASecondAnswerForOneStampIsDropped) {
  Fixture f(2);
  f.Answer(0, 10, 0.0);
  EXPECT_TRUE(f.Answer(0, 10, 0.01).empty());
  EXPECT_NE(f.log.back().find("answered twice"), std::string::npos);
  const auto d = f.Answer(1, 10, 0.02);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(Fixture::Answered(d[0]), 2);
}

TEST(ShardJoin, MoreQueriesPendingThanTheQueueHoldsDecidesWithoutTheLaggingShard) {
  Fixture f(2, /*timeout_s=*/10, /*queue=*/3);
  for (int64_t s = 1; s <= 3; ++s) EXPECT_TRUE(f.Answer(0, s, 0.0).empty());
  // The fourth pending query overflows the queue: the oldest is decided without shard 1,
  // which is then missing, so the others are not held for it either.
  const auto d = f.Answer(0, 4, 0.0);
  EXPECT_EQ(Fixture::Stamps(d), (std::vector<int64_t>{1, 2, 3, 4}));
  EXPECT_TRUE(f.join.counts(1).missing);
  EXPECT_EQ(f.join.counts(1).missed, 1);
  EXPECT_EQ(f.join.pending(), 0u);
}

}  // namespace
}  // namespace bsf_vpr
