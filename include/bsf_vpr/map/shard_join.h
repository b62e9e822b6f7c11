// The join of a sharded map's answers (docs/sharding.md, docs/architecture.md): each shard
// answers every query, told apart by its stamp; the join pairs the answers of one stamp
// and hands the queries on in stamp order, each once, once every shard expected has
// answered or `timeout_s` after the first answer.
//
// A shard is expected while the owner says it can answer (it has published its sets and
// still publishes: `can_answer`), whether or not it missed the last queries: a shard that
// was slow (stopped a while, overloaded) is taken back by its first answer within the
// timeout, however long it was missing. A query whose stamp is at or before the last one
// released is late: one shard's late answer is dropped (its query was released without it);
// when every expected shard's answer comes for such a stamp, it is a query that came late
// on the wire from all of them (a bag replayed again, descriptors published out of stamp
// order), released to be decided as a single node would decide it, and the stamps start afresh from it.
//
// Every query heard is released or counted: one that no shard answered within `timeout_s` of
// being heard (the shards' answers lost on the way, e.g. dropped from a publisher's queue
// while this node was stalled) is counted as unanswered (unanswered()), and taken off that
// count if its answers still come and it is released after all.
//
// Only stamps the owner heard (Hear: a descriptor with that stamp reached this node) are
// released. An answer for a stamp no descriptor had (a forged or corrupted stamp, 1 ns off
// or days ahead) is refused and counted, never released, and holds up no query: it waits
// for its descriptor only while that can still be in flight (no later descriptor heard,
// and less than the timeout).
//
// Free of ROS: time comes from the caller (seconds on any monotonic clock), the answers are
// any copyable pointer (AnswerPtr, null meaning none), what happens to a shard is told
// through `log` (a sentence that follows the shard's name).
// Not thread-safe: the owner serialises calls.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace bsf_vpr {

// Why shard distances `d` (n of them, to one set) cannot be a shard's exact distances of a
// query whose L2 norm is `query_norm` to rows whose largest L2 norm is `max_row_norm`, or ""
// if they can: every distance is finite and non-negative, a cosine distance (1 - cos) is at
// most 2, and a Euclidean one at most query_norm + max_row_norm (the triangle inequality),
// each with a margin for rounding. A shard's fault (a NaN from a broken kernel, a corrupted
// message) then makes that shard missing for the query instead of dropping it.
inline std::string ShardDistancesProblem(const float* d, size_t n, bool cosine, double query_norm,
                                         double max_row_norm) {
  // Float32 rounding of a distance computed as in distance_formula (relative 1e-6 a term,
  // over D terms in float): 1e-3 relative is far beyond it and far below a fault's value.
  const double bound = cosine ? 2.0 * (1 + 1e-3) : (query_norm + max_row_norm) * (1 + 1e-3) + 1e-6;
  for (size_t i = 0; i < n; ++i) {
    const double v = d[i];
    if (std::isfinite(v) && v >= 0 && v <= bound) continue;
    char what[160];
    std::snprintf(what, sizeof(what), "distance %zu of %zu is %g: %s", i, n, v,
                  !std::isfinite(v) ? "not finite"
                  : v < 0           ? "negative"
                  : cosine          ? "a cosine distance is at most 2"
                                    : "above the query's norm plus the set's largest row norm");
    return what;
  }
  return "";
}

template <class AnswerPtr>
class ShardJoin {
 public:
  // kWarnRepeated: a warning that may come with every query (the owner throttles it).
  enum class Level { kInfo, kWarn, kWarnRepeated };
  struct Release {
    int64_t stamp_ns = 0;
    double query_norm = 0;           // as heard (Hear)
    std::vector<AnswerPtr> answers;  // one per shard, null where none came
  };
  struct ShardCounts {
    int64_t answered = 0, missed = 0, late = 0;
    int64_t unheard = 0;   // answers for a stamp no descriptor had: refused
    bool missing = false;  // missed the last query it was expected for
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

  // A descriptor stamped `stamp_ns` (not zero) reached the owner at `now_s`; `query_norm` is
  // its L2 norm, handed back when its query is released. The queries now released (handed
  // on to be decided), in stamp order.
  std::vector<Release> Hear(int64_t stamp_ns, double query_norm, double now_s) {
    // A stamp heard again (a replay) stays heard, and is a query of its own.
    heard_[stamp_ns] = Heard{query_norm, now_s, false, false};
    heard_order_.push_back(stamp_ns);
    latest_heard_ = stamp_ns;
    heard_any_ = true;
    // Enough to pair every pending query (at most queue_size) twice over; by the order
    // heard, so that a replay's earlier stamps are not the ones forgotten.
    while (heard_order_.size() > 2 * queue_size_ + 16) {
      const int64_t oldest = heard_order_.front();
      heard_order_.pop_front();
      if (std::find(heard_order_.begin(), heard_order_.end(), oldest) == heard_order_.end()) {
        const auto it = heard_.find(oldest);
        // Forgotten unreleased: it can never be released now.
        if (!it->second.released && !it->second.unanswered && !pending_.count(oldest)) {
          ++unanswered_;
        }
        heard_.erase(it);
      }
    }
    TakeBackRefused(stamp_ns, now_s);
    std::vector<Release> out;
    Flush(now_s, &out);
    CountUnanswered(now_s);
    return out;
  }

  // Shard k's answer for the query stamped `stamp_ns` (not zero), at `now_s`; the queries
  // now released, in stamp order.
  std::vector<Release> Answer(int k, int64_t stamp_ns, AnswerPtr answer, double now_s) {
    ShardCounts& shard = shards_.at(static_cast<size_t>(k));
    ++shard.answered;
    const bool old = released_any_ && stamp_ns <= last_released_;
    if (old && !heard_.count(stamp_ns)) {
      RefuseUnheard(k, stamp_ns);  // not a late answer: no query had this stamp
      return {};
    }
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
    std::vector<Release> out;
    if (!old) {
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
      released_any_ = false;
      Flush(now_s, &out);
    }
    while (past_.size() > queue_size_) past_.erase(past_.begin());
    return out;
  }

  // The queries whose missing answers have timed out by `now_s`, in stamp order.
  std::vector<Release> Tick(double now_s) {
    std::vector<Release> out;
    Flush(now_s, &out);
    CountUnanswered(now_s);
    return out;
  }

  int num_shards() const { return static_cast<int>(shards_.size()); }
  const ShardCounts& counts(int k) const { return shards_.at(static_cast<size_t>(k)); }
  // Whether a query waits for shard k's answer now (up to the timeout).
  bool Expected(int k) const { return can_answer_(k); }
  size_t pending() const { return pending_.size(); }
  // Queries heard that no shard answered within the timeout (and not released since).
  int64_t unanswered() const { return unanswered_; }

 private:
  struct Pending {
    std::vector<AnswerPtr> answers;  // one per shard
    double first_s = 0;              // when the first answer came
  };
  struct Heard {
    double query_norm = 0;
    double heard_s = 0;       // when its descriptor reached the owner
    bool released = false;     // handed on
    bool unanswered = false;  // counted in unanswered_
  };

  // Counts the heard queries that no shard answered within the timeout.
  void CountUnanswered(double now_s) {
    for (auto& [stamp, heard] : heard_) {
      if (heard.released || heard.unanswered || now_s - heard.heard_s < timeout_s_) continue;
      if (pending_.count(stamp)) continue;  // answered: released at its own timeout
      heard.unanswered = true;
      ++unanswered_;
    }
  }

  void RefuseUnheard(int k, int64_t stamp_ns) {
    ++shards_[static_cast<size_t>(k)].unheard;
    log_(Level::kWarnRepeated, k,
         "answered for stamp " + std::to_string(stamp_ns * 1e-9) +
             ", which no descriptor this node heard had (a forged or corrupted stamp, or this "
             "node and the shard listen to different descriptors): refused");
  }

  // Refuses every answer of the pending stamp at `it` (no descriptor had it); the next entry.
  // The refused answers are kept a while (the last queue_size stamps): a descriptor held up
  // longer than the timeout (this node stalled, its descriptors queued behind the answers)
  // still finds them when it is heard, and its query is released after all.
  typename std::map<int64_t, Pending>::iterator RefusePending(
      typename std::map<int64_t, Pending>::iterator it) {
    for (size_t k = 0; k < shards_.size(); ++k) {
      if (it->second.answers[k]) RefuseUnheard(static_cast<int>(k), it->first);
    }
    refused_[it->first] = std::move(it->second);
    while (refused_.size() > queue_size_) refused_.erase(refused_.begin());
    return pending_.erase(it);
  }

  // The descriptor of refused answers came after all: they were a query's, not forged.
  void TakeBackRefused(int64_t stamp_ns, double now_s) {
    const auto it = refused_.find(stamp_ns);
    if (it == refused_.end()) return;
    if (!(released_any_ && stamp_ns <= last_released_) && !pending_.count(stamp_ns)) {
      for (size_t k = 0; k < shards_.size(); ++k) {
        if (it->second.answers[k]) --shards_[k].unheard;
      }
      it->second.first_s = now_s;
      pending_[stamp_ns] = std::move(it->second);
    }
    refused_.erase(it);
  }

  void MarkAnswering(int k, double now_s) {
    ShardCounts& shard = shards_[static_cast<size_t>(k)];
    if (shard.missing) {
      char seconds[32];
      std::snprintf(seconds, sizeof(seconds), "%.1f", now_s - shard.missing_since_s);
      log_(Level::kInfo, k, std::string("answers again after ") + seconds + " s");
    }
    shard.missing = false;
  }

  void Flush(double now_s, std::vector<Release>* out) {
    while (!pending_.empty()) {
      // Full: answers for stamps not heard go first, the furthest ahead first (a flood of
      // forged stamps must not push real queries out undecided).
      for (auto back = pending_.end(); pending_.size() > queue_size_ && back != pending_.begin();) {
        --back;
        if (heard_.count(back->first)) continue;
        back = RefusePending(back);
      }
      auto it = pending_.begin();
      Pending& p = it->second;
      const bool overflow = pending_.size() > queue_size_;
      const bool timed_out = now_s - p.first_s >= timeout_s_;
      const auto heard = heard_.find(it->first);
      if (heard == heard_.end()) {
        // Its descriptor may still be on its way to this node, unless a later one came
        // first (descriptors arrive in the order published).
        const bool in_flight = !heard_any_ || latest_heard_ < it->first;
        if (in_flight && !timed_out && !overflow) return;
        RefusePending(it);
        continue;
      }
      bool waiting = false;
      for (size_t k = 0; k < shards_.size(); ++k) {
        if (!p.answers[k] && Expected(static_cast<int>(k))) waiting = true;
      }
      if (waiting && !timed_out && !overflow) return;
      for (size_t k = 0; k < shards_.size(); ++k) {
        if (p.answers[k]) {
          MarkAnswering(static_cast<int>(k), now_s);
        } else if (Expected(static_cast<int>(k))) {
          ShardCounts& shard = shards_[k];
          ++shard.missed;
          if (shard.missing) continue;  // said when it went missing
          shard.missing = true;
          shard.missing_since_s = now_s;
          char seconds[32];
          std::snprintf(seconds, sizeof(seconds), "%.2f", timeout_s_);
          log_(Level::kWarn, static_cast<int>(k),
               std::string("did not answer within ") + seconds +
                   " s: deciding without its sets, waiting for it up to that long a query, "
                   "until it answers again");
        }
      }
      last_released_ = it->first;
      released_any_ = true;
      heard->second.released = true;
      if (heard->second.unanswered) {
        heard->second.unanswered = false;  // its answers came after all
        --unanswered_;
      }
      out->push_back(Release{it->first, heard->second.query_norm, std::move(p.answers)});
      pending_.erase(it);
    }
  }

  std::vector<ShardCounts> shards_;
  double timeout_s_;
  size_t queue_size_;
  std::function<bool(int)> can_answer_;
  std::function<void(Level, int shard, const std::string&)> log_;
  std::map<int64_t, Pending> pending_;
  // Answers for stamps at or before last_released_: late ones, or (when every shard's comes)
  // a query that came late on the wire from every shard.
  std::map<int64_t, Pending> past_;
  // Answers refused for a stamp no descriptor had yet (the last queue_size): TakeBackRefused.
  std::map<int64_t, Pending> refused_;
  int64_t last_released_ = 0;
  bool released_any_ = false;
  // The stamps heard (with their query's norm), the last 2 x queue_size + 16 in the order
  // heard, and the latest.
  std::map<int64_t, Heard> heard_;
  std::deque<int64_t> heard_order_;
  int64_t latest_heard_ = 0;
  bool heard_any_ = false;
  int64_t unanswered_ = 0;
};

}  // namespace bsf_vpr
