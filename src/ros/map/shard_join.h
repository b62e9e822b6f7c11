// The join of a sharded map's answers (docs/sharding.md, docs/architecture.md): each shard
// answers every query, told apart by its stamp; the join pairs the answers of one stamp
// and hands the queries on in stamp order, each once, once every shard expected has
// answered or `timeout_s` after the first answer.
//
// A shard is expected while the owner says it can answer (it has published its sets and
// still publishes: `can_answer`) and it has not missed a query. One that misses a query is
// not waited for: its answers are missing from the queries that follow, and it is expected
// again as soon as it answers a query in time. A query whose stamp is at or before the last
// one decided is late: one shard's late answer is dropped (its query was decided without
// it); when every expected shard's answer comes for such a stamp, it is a query that came
// late on the wire from all of them (a bag replayed again, descriptors published out of
// stamp order), decided as a single node would, and the stamps start afresh from it.
//
// Free of ROS: time comes from the caller (seconds on any monotonic clock), the answers are
// any copyable pointer (AnswerPtr, null meaning none), what happens to a shard is told
// through `log` (a sentence that follows the shard's name).
// Not thread-safe: the owner serialises calls.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace bsf_vpr {

template <class AnswerPtr>
class ShardJoin {
 public:
  // kWarnRepeated: a warning that may come with every query (the owner throttles it).
  enum class Level { kInfo, kWarn, kWarnRepeated };
  struct Decision {
    int64_t stamp_ns = 0;
    std::vector<AnswerPtr> answers;  // one per shard, null where none came
  };
  struct ShardCounts {
    int64_t answered = 0, missed = 0, late = 0;
    bool missing = false;  // missed a query: not waited for until it answers in time
    double missing_since_s = 0;
  };

  // `can_answer(k)`: shard k has published its sets and publishes answers now.
  ShardJoin(int num_shards, double timeout_s, size_t queue_size,
            std::function<bool(int)> can_answer,
            std::function<void(Level, int shard, const std::string&)> log)
      : shards_(static_cast<size_t>(num_shards)),
        timeout_s_(timeout_s),
        queue_size_(std::max<size_t>(1, queue_size)),
        can_answer_(std::move(can_answer)),
        log_(std::move(log)) {}

  // Shard k's answer for the query stamped `stamp_ns` (not zero), at `now_s`; the queries
  // now decided, in stamp order.
  std::vector<Decision> Answer(int k, int64_t stamp_ns, AnswerPtr answer, double now_s) {
    ShardCounts& shard = shards_.at(static_cast<size_t>(k));
    ++shard.answered;
    const bool old = decided_any_ && stamp_ns <= last_decided_;
    Pending& p = (old ? past_ : pending_)[stamp_ns];
    if (p.answers.empty()) {
      p.answers.resize(shards_.size());
      p.first_s = now_s;
    }
    if (p.answers[static_cast<size_t>(k)]) {
      log_(Level::kWarnRepeated, k,
           "answered twice for stamp " + std::to_string(stamp_ns * 1e-9) +
               ": a sharded map tells queries apart by header.stamp (the second answer is "
               "dropped)");
      return {};
    }
    p.answers[static_cast<size_t>(k)] = std::move(answer);
    std::vector<Decision> out;
    if (!old) {
      MarkAnswering(k, now_s);  // on time: waited for again (a late answer does not)
      Flush(now_s, &out);
      return out;
    }
    ++shard.late;
    bool complete = true;
    for (size_t j = 0; j < shards_.size(); ++j) {
      if (!p.answers[j] && Expected(static_cast<int>(j))) complete = false;
    }
    if (complete) {
      for (size_t j = 0; j < shards_.size(); ++j) {
        if (p.answers[j]) --shards_[j].late;
      }
      pending_.insert(past_.extract(stamp_ns));
      decided_any_ = false;
      Flush(now_s, &out);
    }
    while (past_.size() > queue_size_) past_.erase(past_.begin());
    return out;
  }

  // The queries whose missing answers have timed out by `now_s`, in stamp order.
  std::vector<Decision> Tick(double now_s) {
    std::vector<Decision> out;
    Flush(now_s, &out);
    return out;
  }

  int num_shards() const { return static_cast<int>(shards_.size()); }
  const ShardCounts& counts(int k) const { return shards_.at(static_cast<size_t>(k)); }
  // Whether a query waits for shard k's answer now.
  bool Expected(int k) const {
    return !shards_.at(static_cast<size_t>(k)).missing && can_answer_(k);
  }
  size_t pending() const { return pending_.size(); }

 private:
  struct Pending {
    std::vector<AnswerPtr> answers;  // one per shard
    double first_s = 0;              // when the first answer came
  };

  void MarkAnswering(int k, double now_s) {
    ShardCounts& shard = shards_[static_cast<size_t>(k)];
    if (shard.missing) {
      char seconds[32];
      std::snprintf(seconds, sizeof(seconds), "%.1f", now_s - shard.missing_since_s);
      log_(Level::kInfo, k, std::string("answers again after ") + seconds + " s");
    }
    shard.missing = false;
  }

  void Flush(double now_s, std::vector<Decision>* out) {
    while (!pending_.empty()) {
      auto it = pending_.begin();
      Pending& p = it->second;
      bool waiting = false;
      for (size_t k = 0; k < shards_.size(); ++k) {
        if (!p.answers[k] && Expected(static_cast<int>(k))) waiting = true;
      }
      const bool overflow = pending_.size() > queue_size_;
      if (waiting && now_s - p.first_s < timeout_s_ && !overflow) return;
      for (size_t k = 0; k < shards_.size(); ++k) {
        if (!p.answers[k] && Expected(static_cast<int>(k))) {
          ShardCounts& shard = shards_[k];
          shard.missing = true;
          shard.missing_since_s = now_s;
          ++shard.missed;
          char seconds[32];
          std::snprintf(seconds, sizeof(seconds), "%.2f", timeout_s_);
          log_(Level::kWarn, static_cast<int>(k),
               std::string("did not answer within ") + seconds +
                   " s: deciding without its sets until it answers again");
        }
      }
      last_decided_ = it->first;
      decided_any_ = true;
      out->push_back(Decision{it->first, std::move(p.answers)});
      pending_.erase(it);
    }
  }

  std::vector<ShardCounts> shards_;
  double timeout_s_;
  size_t queue_size_;
  std::function<bool(int)> can_answer_;
  std::function<void(Level, int shard, const std::string&)> log_;
  std::map<int64_t, Pending> pending_;
  // Answers for stamps at or before last_decided_: late ones, or (when every shard's comes)
  // a query that came late on the wire from every shard.
  std::map<int64_t, Pending> past_;
  int64_t last_decided_ = 0;
  bool decided_any_ = false;
};

}  // namespace bsf_vpr
