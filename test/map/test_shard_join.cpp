// The join of a sharded map's answers with its clock in the test's hands: stamp order,
// timeouts, late answers, a slow shard's return, a stalled shard, a shard that stops
// publishing, forged stamps, overflow; and the check of a shard's distances.
#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "bsf_vpr/map/shard_join.h"

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

  // The descriptor stamped `stamp` reached the combiner.
  std::vector<Join::Release> Hear(int64_t stamp, double now) {
    return join.Hear(stamp, /*query_norm=*/1.0, now);
  }
  std::vector<Join::Release> Answer(int k, int64_t stamp, double now) {
    return join.Answer(k, stamp, std::make_shared<const int>(k), now);
  }
  static std::vector<int64_t> Stamps(const std::vector<Join::Release>& d) {
    std::vector<int64_t> out;
    for (const Join::Release& x : d) out.push_back(x.stamp_ns);
    return out;
  }
  static int Answered(const Join::Release& d) {
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
  f.Hear(10, 0.0);
  EXPECT_TRUE(f.Answer(0, 10, 0.0).empty());
  EXPECT_TRUE(f.Answer(1, 10, 0.01).empty());
  f.Hear(20, 0.02);
  EXPECT_TRUE(f.Answer(0, 20, 0.02).empty());  // the next query waits behind the first
  const auto first = f.Answer(2, 10, 0.03);
  ASSERT_EQ(Fixture::Stamps(first), std::vector<int64_t>{10});
  EXPECT_EQ(Fixture::Answered(first[0]), 3);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(*first[0].answers[static_cast<size_t>(k)], k);
  EXPECT_TRUE(f.Answer(2, 20, 0.04).empty());
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 20, 0.05)), std::vector<int64_t>{20});
  EXPECT_EQ(f.join.pending(), 0u);
}

TEST(ShardJoin, AnswersBeforeTheirDescriptorWaitForIt) {
  // The shards may answer before this node hears the descriptor (its queue is busier):
  // released when it arrives, with its norm.
  Fixture f(2);
  EXPECT_TRUE(f.Answer(0, 10, 0.0).empty());
  EXPECT_TRUE(f.Answer(1, 10, 0.01).empty());
  const auto d = f.join.Hear(10, 2.5, 0.02);
  ASSERT_EQ(Fixture::Stamps(d), std::vector<int64_t>{10});
  EXPECT_EQ(Fixture::Answered(d[0]), 2);
  EXPECT_EQ(d[0].query_norm, 2.5);
}

TEST(ShardJoin, EveryQueryHeardIsDecidedOrCountedAsUnanswered) {
  // A combiner stalled 3 s at 10 Hz (issue 41): the shards answered every query, but what
  // they sent while it was stopped was dropped on the way (their publishers' queues), so
  // 19 of 30 descriptors reach it with no answer at all. Each is counted once its timeout
  // has passed, and none is released twice or forgotten.
  Fixture f(2, /*timeout_s=*/0.5, /*queue=*/10);
  int released = 0;
  double now = 0;
  for (int64_t stamp = 1; stamp <= 30; ++stamp, now += 0.1) {
    released += static_cast<int>(f.Hear(stamp, now).size());
    if (stamp <= 11) {  // answered; the rest lost on the way
      for (int k = 0; k < 2; ++k) released += static_cast<int>(f.Answer(k, stamp, now).size());
    }
    released += static_cast<int>(f.join.Tick(now).size());
  }
  EXPECT_LT(f.join.unanswered(), 19);  // the last ones are not past their timeout yet
  for (int i = 0; i < 10; ++i) released += static_cast<int>(f.join.Tick(now += 0.1).size());
  EXPECT_EQ(released, 11);
  EXPECT_EQ(f.join.unanswered(), 19);
  EXPECT_EQ(released + f.join.unanswered(), 30);
  // Forgotten past the heard window (2 x queue + 16) without a Tick: still counted once.
  Fixture g(1, 0.5, 2);
  for (int64_t stamp = 1; stamp <= 40; ++stamp) g.Hear(stamp, 0.0);
  EXPECT_EQ(g.join.unanswered(), 40 - (2 * 2 + 16));
  g.join.Tick(10.0);
  EXPECT_EQ(g.join.unanswered(), 40);
  // An answer that comes after all (within its pending timeout of its own): taken off.
  Fixture h(1, 0.5, 100);
  h.Hear(5, 0.0);
  h.join.Tick(1.0);
  EXPECT_EQ(h.join.unanswered(), 1);
  EXPECT_EQ(Fixture::Stamps(h.Answer(0, 5, 1.1)), std::vector<int64_t>{5});
  EXPECT_EQ(h.join.unanswered(), 0);
}

TEST(ShardJoin, AnswersRefusedForWantOfTheirDescriptorAreTakenBackWhenItComesLate) {
  // After a stall the answers may be handled before the descriptors queued behind them, for
  // longer than the timeout: refused then (no descriptor had the stamp yet), but the query
  // is released when its descriptor comes, and the refusal is taken back.
  Fixture f(2, 0.5, 100);
  f.Hear(5, 0.0);
  for (int k = 0; k < 2; ++k) f.Answer(k, 5, 0.0);
  for (int k = 0; k < 2; ++k) f.Answer(k, 10, 1.0);
  f.join.Tick(2.0);  // timed out: refused
  EXPECT_EQ(f.join.counts(0).unheard, 1);
  const auto d = f.Hear(10, 2.1);
  ASSERT_EQ(Fixture::Stamps(d), std::vector<int64_t>{10});
  EXPECT_EQ(Fixture::Answered(d[0]), 2);
  EXPECT_EQ(f.join.counts(0).unheard, 0);
  EXPECT_EQ(f.join.counts(1).unheard, 0);
  f.join.Tick(5.0);
  EXPECT_EQ(f.join.unanswered(), 0);
}

TEST(ShardJoin, ASlowShardIsDecidedWithoutAtTheTimeoutAndTakenBackByAnAnswerInTime) {
  Fixture f(2, /*timeout_s=*/0.5);
  f.Hear(10, 0.0);
  f.Answer(0, 10, 0.0);
  EXPECT_TRUE(f.join.Tick(0.49).empty());
  const auto timed_out = f.join.Tick(0.5);
  ASSERT_EQ(Fixture::Stamps(timed_out), std::vector<int64_t>{10});
  EXPECT_EQ(Fixture::Answered(timed_out[0]), 1);
  EXPECT_TRUE(f.join.counts(1).missing);
  EXPECT_EQ(f.join.counts(1).missed, 1);
  // Missing, but still waited for (up to the timeout): its answer in time is taken.
  f.Hear(20, 0.6);
  EXPECT_TRUE(f.Answer(0, 20, 0.6).empty());
  // Its late answer for a released stamp is dropped and counted.
  EXPECT_TRUE(f.Answer(1, 10, 0.7).empty());
  EXPECT_EQ(f.join.counts(1).late, 1);
  const auto back = f.Answer(1, 20, 0.8);
  ASSERT_EQ(Fixture::Stamps(back), std::vector<int64_t>{20});
  EXPECT_EQ(Fixture::Answered(back[0]), 2);
  EXPECT_FALSE(f.join.counts(1).missing);
  ASSERT_FALSE(f.log.empty());
  EXPECT_NE(f.log.front().find("warn 1 did not answer within 0.50 s"), std::string::npos);
  EXPECT_NE(f.log.back().find("info 1 answers again"), std::string::npos);
}

TEST(ShardJoin, AShardStoppedTenSecondsIsBackOnItsFirstAnswerAfterContinuing) {
  // The case measured on a robot: the shard holding most places stopped 10 s at 10 Hz,
  // then continued, answering its backlog (late) and then the queries in time.
  Fixture f(2, /*timeout_s=*/0.5);
  double now = 0;
  int64_t stamp = 0;
  int partial = 0;
  for (int q = 0; q < 100; ++q, now += 0.1) {  // stopped: shard 1 answers nothing
    for (const auto& d : f.Hear(++stamp, now)) partial += Fixture::Answered(d) == 1;
    for (const auto& d : f.Answer(0, stamp, now)) partial += Fixture::Answered(d) == 1;
    for (const auto& d : f.join.Tick(now + 0.05)) partial += Fixture::Answered(d) == 1;
  }
  for (const auto& d : f.join.Tick(now + 1)) partial += Fixture::Answered(d) == 1;
  now += 1;
  EXPECT_EQ(partial, 100);  // every query released, each within the timeout, without it
  EXPECT_EQ(f.join.counts(1).missed, 100);
  EXPECT_EQ(f.log.size(), 1u);  // said once
  // Continued: its backlog of released stamps is late; the next query is whole again.
  for (int64_t s = 90; s <= 100; ++s) EXPECT_TRUE(f.Answer(1, s, now).empty());
  EXPECT_EQ(f.join.counts(1).late, 11);
  f.Hear(++stamp, now);
  EXPECT_TRUE(f.Answer(0, stamp, now).empty());
  const auto whole = f.Answer(1, stamp, now + 0.01);
  ASSERT_EQ(whole.size(), 1u);
  EXPECT_EQ(Fixture::Answered(whole[0]), 2);
  EXPECT_FALSE(f.join.counts(1).missing);
}

TEST(ShardJoin, AStalledShardCostsEachQueryTheTimeoutAndNoMore) {
  // A shard that still publishes (its process stopped, not dead) and never answers: each
  // query is released at its own timeout, none is lost, the pending ones stay within the
  // queue.
  Fixture f(2, /*timeout_s=*/0.5, /*queue=*/100);
  std::vector<int64_t> released;
  double now = 0;
  for (int64_t s = 1; s <= 300; ++s, now += 1.0 / 30) {
    const auto check = [&](const std::vector<Join::Release>& releases) {
      for (const auto& d : releases) {
        released.push_back(d.stamp_ns);
        EXPECT_LE(now - (d.stamp_ns - 1) / 30.0, 0.5 + 1.0 / 30 + 1e-9);
      }
    };
    check(f.Hear(s, now));
    check(f.Answer(0, s, now));
    check(f.join.Tick(now));
    EXPECT_LE(f.join.pending(), 16u);
  }
  for (const auto& d : f.join.Tick(now + 1)) released.push_back(d.stamp_ns);
  ASSERT_EQ(released.size(), 300u);
  for (size_t i = 0; i < released.size(); ++i) EXPECT_EQ(released[i], static_cast<int64_t>(i) + 1);
  EXPECT_EQ(f.join.counts(1).missed, 300);
}

TEST(ShardJoin, AForgedStampIsNeverDecidedAndHoldsUpNoQuery) {
  Fixture f(2, /*timeout_s=*/0.5);
  f.Hear(100, 0.0);
  // 1 ns off a real stamp, from one shard: waits only while its descriptor could still
  // come, then refused; the real queries around it are released whole as soon as complete.
  EXPECT_TRUE(f.Answer(0, 101, 0.0).empty());
  EXPECT_TRUE(f.Answer(0, 100, 0.01).empty());
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 100, 0.02)), std::vector<int64_t>{100});
  f.Hear(200, 0.1);  // the next descriptor: 101 cannot be on its way any more
  EXPECT_EQ(f.join.counts(0).unheard, 1);
  f.Answer(0, 200, 0.1);
  const auto next = f.Answer(1, 200, 0.11);
  ASSERT_EQ(Fixture::Stamps(next), std::vector<int64_t>{200});
  EXPECT_EQ(Fixture::Answered(next[0]), 2);
  // Days ahead: refused at the timeout, and the queries after it are not late.
  const int64_t days = 11LL * 86400 * 1000000000LL;
  EXPECT_TRUE(f.Answer(1, days, 0.2).empty());
  f.Hear(300, 0.3);
  f.Answer(0, 300, 0.3);
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 300, 0.31)), std::vector<int64_t>{300});
  EXPECT_TRUE(f.join.Tick(0.71).empty());
  EXPECT_EQ(f.join.counts(1).unheard, 1);
  EXPECT_EQ(f.join.pending(), 0u);
  f.Hear(400, 0.8);
  f.Answer(0, 400, 0.8);
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 400, 0.81)), std::vector<int64_t>{400});
  // An old stamp no descriptor had: refused at once, not counted late.
  EXPECT_TRUE(f.Answer(0, 150, 0.9).empty());
  EXPECT_EQ(f.join.counts(0).unheard, 2);
  EXPECT_EQ(f.join.counts(0).late, 0);
  EXPECT_FALSE(f.join.counts(0).missing);
  EXPECT_FALSE(f.join.counts(1).missing);
  // 300 forged answers at once, among real queries: not one released.
  std::vector<int64_t> released;
  for (int i = 0; i < 300; ++i) {
    const double now = 1.0 + i * 0.001;
    for (const auto& d : f.Answer(i % 2, 1000 + 2 * i + 1, now)) released.push_back(d.stamp_ns);
    if (i % 10 == 0) {
      f.Hear(1000 + 2 * i, now);
      for (const auto& d : f.Answer(0, 1000 + 2 * i, now)) released.push_back(d.stamp_ns);
      for (const auto& d : f.Answer(1, 1000 + 2 * i, now)) released.push_back(d.stamp_ns);
    }
  }
  for (const auto& d : f.join.Tick(10)) released.push_back(d.stamp_ns);
  ASSERT_EQ(released.size(), 30u);
  for (size_t i = 0; i < released.size(); ++i) EXPECT_EQ(released[i] % 20, 0) << released[i];
}

TEST(ShardJoin, AFloodOfForgedStampsPushesNoRealQueryOutUndecided) {
  Fixture f(2, /*timeout_s=*/0.5, /*queue=*/3);
  f.Hear(10, 0.0);
  f.Answer(0, 10, 0.0);  // waits for shard 1
  for (int64_t s = 1; s <= 20; ++s) EXPECT_TRUE(f.Answer(1, 1000000 + s, 0.01).empty());
  EXPECT_EQ(f.join.counts(1).unheard, 18);  // what did not fit beside the real query
  const auto d = f.Answer(1, 10, 0.1);
  ASSERT_EQ(Fixture::Stamps(d), std::vector<int64_t>{10});
  EXPECT_EQ(Fixture::Answered(d[0]), 2);
  EXPECT_FALSE(f.join.counts(1).missing);
}

TEST(ShardJoin, AShardThatCannotAnswerIsNotWaitedFor) {
  Fixture f(2);
  f.can_answer[1] = false;  // no shard_info yet, or its process ended
  f.Hear(10, 0.0);
  EXPECT_EQ(Fixture::Stamps(f.Answer(0, 10, 0.0)), std::vector<int64_t>{10});
  EXPECT_EQ(f.join.counts(1).missed, 0);  // not expected: nothing missed
  f.can_answer[1] = true;                 // a respawn (its layout is the owner's business)
  f.Hear(20, 0.1);
  EXPECT_TRUE(f.Answer(0, 20, 0.1).empty());
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 20, 0.11)), std::vector<int64_t>{20});
}

TEST(ShardJoin, AQueryLateFromEveryShardIsDecidedAndTheStampsStartAfresh) {
  Fixture f(2);
  f.Hear(50, 0.0);
  f.Hear(60, 0.0);
  f.Hear(100, 0.0);
  f.Answer(0, 100, 0.0);
  f.Answer(1, 100, 0.0);
  // A bag replayed again: stamps go back, every shard answers them.
  f.Hear(50, 1.0);
  EXPECT_TRUE(f.Answer(0, 50, 1.0).empty());
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 50, 1.01)), std::vector<int64_t>{50});
  EXPECT_EQ(f.join.counts(0).late, 0);  // not counted as late once released
  f.Hear(60, 1.1);
  EXPECT_TRUE(f.Answer(0, 60, 1.1).empty());
  EXPECT_EQ(Fixture::Stamps(f.Answer(1, 60, 1.11)), std::vector<int64_t>{60});
}

TEST(ShardJoin, ASecondAnswerForOneStampIsDropped) {
  Fixture f(2);
  f.Hear(10, 0.0);
  f.Answer(0, 10, 0.0);
  EXPECT_TRUE(f.Answer(0, 10, 0.01).empty());
  EXPECT_NE(f.log.back().find("answered twice"), std::string::npos);
  const auto d = f.Answer(1, 10, 0.02);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(Fixture::Answered(d[0]), 2);
}

TEST(ShardJoin, MoreQueriesPendingThanTheQueueHoldsDecidesWithoutTheLaggingShard) {
  Fixture f(2, /*timeout_s=*/10, /*queue=*/3);
  for (int64_t s = 1; s <= 4; ++s) f.Hear(s, 0.0);
  for (int64_t s = 1; s <= 3; ++s) EXPECT_TRUE(f.Answer(0, s, 0.0).empty());
  // The fourth pending query overflows the queue: the oldest is released without shard 1.
  EXPECT_EQ(Fixture::Stamps(f.Answer(0, 4, 0.0)), std::vector<int64_t>{1});
  EXPECT_TRUE(f.join.counts(1).missing);
  EXPECT_EQ(f.join.counts(1).missed, 1);
  EXPECT_EQ(f.join.pending(), 3u);
}

TEST(ShardDistancesProblem, RefusesWhatNoExactDistanceCanBe) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<float> good = {0.0f, 0.5f, 1.99f};
  EXPECT_EQ(ShardDistancesProblem(good.data(), good.size(), /*cosine=*/true, 1, 1), "");
  EXPECT_EQ(ShardDistancesProblem(good.data(), good.size(), /*cosine=*/false, 1, 1), "");
  for (const float bad : {nan, inf, -inf, -0.1f, 3e38f}) {
    const std::vector<float> d = {0.5f, bad};
    EXPECT_NE(ShardDistancesProblem(d.data(), d.size(), true, 1, 1).find("distance 1 of 2"),
              std::string::npos)
        << bad;
    EXPECT_NE(ShardDistancesProblem(d.data(), d.size(), false, 1, 1), "") << bad;
  }
  const std::vector<float> cosine_3 = {3.0f};
  EXPECT_NE(ShardDistancesProblem(cosine_3.data(), 1, true, 1, 1).find("at most 2"),
            std::string::npos);
  EXPECT_EQ(ShardDistancesProblem(cosine_3.data(), 1, false, 1.5, 1.5), "");  // |q| + |r| = 3
  const std::vector<float> far = {3.1f};
  EXPECT_NE(ShardDistancesProblem(far.data(), 1, false, 1.5, 1.5).find("largest row norm"),
            std::string::npos);
}

}  // namespace
}  // namespace bsf_vpr
