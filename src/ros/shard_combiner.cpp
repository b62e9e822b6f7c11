#include "shard_combiner.h"

#include <algorithm>
#include <numeric>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/ros/names.h"
#include "conversions.h"

namespace bsf_vpr {
namespace {

// An answer this much older than the last query decided is taken for time going back (a
// replay started again), not for a late answer: the combiner starts a new timeline.
constexpr double kTimeJumpTimeouts = 20;

std::string SetList(const ShardInfo* info) {
  if (!info || info->sets.empty()) return "no sets";
  std::string out;
  for (const ShardSet& s : info->sets) out += (out.empty() ? "" : ", ") + s.name;
  return out;
}

bool SameSets(const ShardInfo* a, const ShardInfo* b) {
  if (!a || !b || a->sets.size() != b->sets.size() || a->distance != b->distance) return false;
  for (size_t i = 0; i < a->sets.size(); ++i) {
    if (a->sets[i].name != b->sets[i].name || a->sets[i].fingerprint != b->sets[i].fingerprint) {
      return false;
    }
  }
  return true;
}

}  // namespace

ShardCombiner::ShardCombiner(ros::NodeHandle nh, const std::vector<std::string>& shards,
                             double timeout_s, int queue_size, std::mutex* lock,
                             Callbacks callbacks)
    : nh_(std::move(nh)),
      timeout_(timeout_s),
      queue_size_(static_cast<size_t>(std::max(1, queue_size))),
      lock_(lock),
      callbacks_(std::move(callbacks)) {
  shards_.resize(shards.size());
  for (size_t k = 0; k < shards.size(); ++k) {
    Shard& s = shards_[k];
    s.name = nh_.resolveName(shards[k]);
    const int index = static_cast<int>(k);
    s.info_sub = nh_.subscribe<ShardInfo>(
        s.name + "/" + names::kShardInfoTopic, 1,
        [this, index](const ShardInfo::ConstPtr& m) { OnInfo(index, m); });
    s.distances_sub = nh_.subscribe<ShardDistances>(
        s.name + "/" + names::kShardDistancesTopic, static_cast<uint32_t>(queue_size_),
        [this, index](const ShardDistances::ConstPtr& m) { OnDistances(index, m); });
  }
  // Decides the queries whose missing answers time out (every answer may have arrived).
  timer_ = nh_.createWallTimer(ros::WallDuration(std::max(0.005, timeout_s / 5)),
                               [this](const ros::WallTimerEvent&) {
                                 std::lock_guard<std::mutex> guard(*lock_);
                                 Flush(ros::WallTime::now());
                               });
}

int ShardCombiner::OwnerOf(const std::string& set) const {
  for (size_t k = 0; k < shards_.size(); ++k) {
    if (!shards_[k].info) continue;
    for (const ShardSet& s : shards_[k].info->sets) {
      if (s.name == set) return static_cast<int>(k);
    }
  }
  return -1;
}

const ShardSet* ShardCombiner::SetInfo(const std::string& set) const {
  const int k = OwnerOf(set);
  if (k < 0) return nullptr;
  for (const ShardSet& s : shards_[static_cast<size_t>(k)].info->sets) {
    if (s.name == set) return &s;
  }
  return nullptr;
}

int ShardCombiner::LeastLoaded() const {
  int best = -1;
  size_t fewest = 0;
  for (size_t k = 0; k < shards_.size(); ++k) {
    if (!shards_[k].info || shards_[k].missing) continue;
    size_t places = 0;
    for (const ShardSet& s : shards_[k].info->sets) places += s.place_ids.size();
    if (best < 0 || places < fewest) {
      best = static_cast<int>(k);
      fewest = places;
    }
  }
  return best;
}

void ShardCombiner::OnInfo(int k, const ShardInfo::ConstPtr& msg) {
  std::lock_guard<std::mutex> guard(*lock_);
  Shard& shard = shards_[static_cast<size_t>(k)];
  if (SameSets(shard.info.get(), msg.get())) {
    // Restarted (or republished) with the sets it had: nothing to rebuild.
    shard.info = msg;
    ++shard.info_count;
    if (shard.missing) ROS_INFO("bsf_vpr: shard %s is back", shard.name.c_str());
    MarkAnswering(k);
    return;
  }
  try {
    DistanceMetric metric = ParseDistanceMetric(msg->distance);
    std::vector<ReferenceSet> sets;
    int dimension = 0;
    for (size_t j = 0; j < shards_.size(); ++j) {
      const ShardInfo* info = static_cast<int>(j) == k ? msg.get() : shards_[j].info.get();
      if (!info) continue;
      if (!info->sets.empty() && ParseDistanceMetric(info->distance) != metric) {
        throw std::invalid_argument("it uses " + msg->distance + " distance, shard " +
                                    shards_[j].name + " " + info->distance);
      }
      for (const ShardSet& s : info->sets) {
        for (const ReferenceSet& held : sets) {
          if (held.name == s.name) {
            throw std::invalid_argument("set '" + s.name + "' is held by two shards");
          }
        }
        if (dimension != 0 && s.dimension != dimension) {
          throw std::invalid_argument("set '" + s.name + "' has dimension " +
                                      std::to_string(s.dimension) + ", the map " +
                                      std::to_string(dimension));
        }
        dimension = s.dimension;
        sets.push_back(LayoutFromShardSetMsg(s));
      }
    }
    const std::string why = "shard " + shard.name + " holds " + SetList(msg.get()) +
                            (shard.info ? " (was " + SetList(shard.info.get()) + ")" : "");
    callbacks_.layout(std::move(sets), metric, why);
    shard.info = msg;
    shard.refused.clear();
    ++shard.info_count;
    MarkAnswering(k);
    ROS_INFO("bsf_vpr: %s", why.c_str());
  } catch (const std::exception& e) {
    shard.refused = e.what();
    ROS_ERROR("bsf_vpr: shard %s's sets are refused, the map keeps its previous layout: %s",
              shard.name.c_str(), e.what());
  }
}

void ShardCombiner::MarkAnswering(int k) {
  Shard& shard = shards_[static_cast<size_t>(k)];
  if (shard.missing) {
    ROS_INFO("bsf_vpr: shard %s answers again after %.1f s", shard.name.c_str(),
             (ros::WallTime::now() - shard.missing_since).toSec());
  }
  shard.missing = false;
}

bool ShardCombiner::Expected(int k) const {
  const Shard& shard = shards_[static_cast<size_t>(k)];
  return shard.info && !shard.missing && shard.distances_sub.getNumPublishers() > 0;
}

void ShardCombiner::OnDistances(int k, const ShardDistances::ConstPtr& msg) {
  std::lock_guard<std::mutex> guard(*lock_);
  Shard& shard = shards_[static_cast<size_t>(k)];
  const ros::Time stamp = msg->header.stamp;
  if (stamp.isZero()) {
    callbacks_.reject("a descriptor without a stamp: a sharded map pairs the shards' answers "
                      "by header.stamp (shard " + shard.name + ")");
    return;
  }
  ++shard.answered;
  MarkAnswering(k);
  if (!last_decided_.isZero() && stamp <= last_decided_) {
    if ((last_decided_ - stamp).toSec() < kTimeJumpTimeouts * timeout_.toSec()) {
      ++shard.late;  // its query was decided without it
      return;
    }
    last_decided_ = ros::Time();  // time went back: a new run
  }
  Pending& p = pending_[stamp];
  if (p.answers.empty()) {
    p.header = msg->header;
    p.answers.resize(shards_.size());
    p.first = ros::WallTime::now();
  }
  if (p.answers[static_cast<size_t>(k)]) {
    callbacks_.reject("shard " + shard.name + " answered twice for stamp " +
                      std::to_string(stamp.toSec()) +
                      ": a sharded map tells queries apart by header.stamp");
    return;
  }
  p.answers[static_cast<size_t>(k)] = msg;
  Flush(ros::WallTime::now());
}

bool ShardCombiner::Assemble(const std::vector<const ShardDistances*>& answers, Query* query,
                             std::string* error) const {
  query->distances.clear();
  query->missing_shards.clear();
  query->shard_seconds = 0;
  for (size_t k = 0; k < shards_.size(); ++k) {
    const Shard& shard = shards_[k];
    if (!shard.info) continue;
    const ShardDistances* a = answers.at(k);
    const std::vector<ShardSet>& sets = shard.info->sets;
    if (a && !a->error.empty()) {
      *error = "shard " + shard.name + ": " + a->error;
      return false;
    }
    // An answer for other sets than the layout's (a shard whose new shard_info has not
    // arrived) counts as none.
    bool usable = a && a->set_names.size() == sets.size() &&
                  a->fingerprints.size() == sets.size() && a->counts.size() == sets.size();
    size_t total = 0;
    for (size_t i = 0; usable && i < sets.size(); ++i) {
      usable = a->set_names[i] == sets[i].name && a->fingerprints[i] == sets[i].fingerprint &&
               a->counts[i] == static_cast<int32_t>(sets[i].place_ids.size());
      total += sets[i].place_ids.size();
    }
    usable = usable && a->distances.size() == total;
    if (!usable) {
      if (!sets.empty()) query->missing_shards.push_back(shard.name);
      query->distances.resize(query->distances.size() + sets.size());  // 0 x 0: missing
      continue;
    }
    query->shard_seconds = std::max(query->shard_seconds, a->processing_time);
    size_t offset = 0;
    for (size_t i = 0; i < sets.size(); ++i) {
      const Eigen::Index n = a->counts[i];
      query->distances.emplace_back(
          Eigen::Map<const RowMatrixXf>(a->distances.data() + offset, 1, n));
      offset += static_cast<size_t>(n);
    }
  }
  return true;
}

void ShardCombiner::Flush(ros::WallTime now) {
  while (!pending_.empty()) {
    auto it = pending_.begin();
    Pending& p = it->second;
    bool waiting = false;
    for (size_t k = 0; k < shards_.size(); ++k) {
      if (!p.answers[k] && Expected(static_cast<int>(k))) waiting = true;
    }
    const bool overflow = pending_.size() > queue_size_;
    if (waiting && now - p.first < timeout_ && !overflow) return;
    std::vector<const ShardDistances*> answers(shards_.size(), nullptr);
    for (size_t k = 0; k < shards_.size(); ++k) {
      answers[k] = p.answers[k].get();
      if (!answers[k] && Expected(static_cast<int>(k))) {
        Shard& shard = shards_[k];
        shard.missing = true;
        shard.missing_since = now;
        ++shard.missed;
        ROS_WARN("bsf_vpr: shard %s did not answer within %.2f s: deciding without its sets "
                 "until it answers again",
                 shard.name.c_str(), timeout_.toSec());
      }
    }
    Query query;
    query.header = p.header;
    std::string error;
    last_decided_ = it->first;
    const bool ok = Assemble(answers, &query, &error);
    pending_.erase(it);
    if (!ok) {
      callbacks_.reject(error);
      continue;
    }
    ++decided_;
    if (!query.missing_shards.empty()) ++decided_partial_;
    callbacks_.query(query);
  }
}

std::string ShardCombiner::MissingSummary() const {
  std::string out;
  for (const Shard& shard : shards_) {
    const bool holds = shard.info && !shard.info->sets.empty();
    if (holds && (shard.missing || shard.distances_sub.getNumPublishers() == 0)) {
      out += (out.empty() ? "" : "; ") + shard.name + " (" + SetList(shard.info.get()) + ")";
    }
  }
  return out;
}

void ShardCombiner::Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const {
  status.add("shards", static_cast<int>(shards_.size()));
  status.add("queries decided", decided_);
  status.add("decided without some shard", decided_partial_);
  for (const Shard& shard : shards_) {
    std::string state;
    if (!shard.refused.empty()) {
      state = "sets refused: " + shard.refused + "; ";
    }
    if (!shard.info) {
      state += "no shard_info yet";
    } else if (shard.distances_sub.getNumPublishers() == 0) {
      state += "not publishing (" + SetList(shard.info.get()) + " missing)";
    } else if (shard.missing) {
      state += "missing for " +
               std::to_string(static_cast<int>((ros::WallTime::now() - shard.missing_since)
                                                   .toSec())) +
               " s (" + SetList(shard.info.get()) + ")";
    } else {
      state += "answering: " + SetList(shard.info.get());
    }
    status.addf("shard " + shard.name, "%s; %ld answers, %ld missed, %ld late", state.c_str(),
                static_cast<long>(shard.answered), static_cast<long>(shard.missed),
                static_cast<long>(shard.late));
  }
}

}  // namespace bsf_vpr
