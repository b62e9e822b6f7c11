#include "src/ros/map/shard_combiner.h"

#include <algorithm>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/ros/names.h"
#include "src/ros/common/conversions.h"

namespace bsf_vpr {
namespace {

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
    s.info_sub =
        nh_.subscribe<ShardInfo>(s.name + "/" + names::kShardInfoTopic, 1,
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

std::vector<std::string> ShardCombiner::RefusedNewSets(int k) const {
  const Shard& shard = shards_.at(static_cast<size_t>(k));
  std::vector<std::string> out;
  if (!shard.refused_info) return out;
  for (const ShardSet& s : shard.refused_info->sets) {
    bool held = false;
    if (shard.info) {
      for (const ShardSet& t : shard.info->sets) held = held || t.name == s.name;
    }
    if (!held) out.push_back(s.name);
  }
  return out;
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
  // What the shard holds now supersedes a layout of it refused before (a load that was
  // refused and unloaded again, a restart).
  shard.refused.clear();
  shard.refused_info.reset();
  if (SameSets(shard.info.get(), msg.get())) {
    // Restarted (or republished) with the sets it had: nothing to rebuild.
    shard.info = msg;
    ++shard.info_count;
    shard.change_expected = false;
    if (shard.missing) ROS_INFO("bsf_vpr: shard %s is back", shard.name.c_str());
    return;
  }
  if (!TakeInfo(k, msg)) return;
  // Another shard's layout refused earlier may fit now (the clash it had may be gone).
  for (size_t j = 0; j < shards_.size(); ++j) {
    if (static_cast<int>(j) != k && shards_[j].refused_info) {
      TakeInfo(static_cast<int>(j), shards_[j].refused_info);
    }
  }
}

void ShardCombiner::ExpectChange(int k) {
  shards_.at(static_cast<size_t>(k)).change_expected = true;
}

std::vector<ReferenceSet> ShardCombiner::LayoutWith(int k, const ShardInfo& info,
                                                    DistanceMetric* metric) const {
  // Every shard's info, shard k's replaced by `info`.
  std::vector<const ShardInfo*> infos;
  for (size_t j = 0; j < shards_.size(); ++j) {
    infos.push_back(static_cast<int>(j) == k ? &info : shards_[j].info.get());
  }
  // The distance of the map: that of the shards holding sets (one without sets has its
  // configured or default distance, which does not matter).
  std::string distance;
  std::vector<ReferenceSet> sets;
  int dimension = 0;
  for (size_t j = 0; j < infos.size(); ++j) {
    if (!infos[j] || infos[j]->sets.empty()) continue;
    if (distance.empty()) distance = infos[j]->distance;
    if (infos[j]->distance != distance) {
      throw std::invalid_argument("the shards' sets are meant for different distances (" +
                                  distance + ", and " + infos[j]->distance + " on shard " +
                                  shards_[j].name + ")");
    }
    for (const ShardSet& s : infos[j]->sets) {
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
  *metric = ParseDistanceMetric(distance.empty() ? info.distance : distance);
  return sets;
}

bool ShardCombiner::TakeInfo(int k, const ShardInfo::ConstPtr& msg) {
  Shard& shard = shards_[static_cast<size_t>(k)];
  try {
    DistanceMetric metric;
    std::vector<ReferenceSet> sets = LayoutWith(k, *msg, &metric);
    const std::string why = "shard " + shard.name + " holds " + SetList(msg.get()) +
                            (shard.info ? " (was " + SetList(shard.info.get()) + ")" : "");
    callbacks_.layout(std::move(sets), metric, why);  // logs it; throws to refuse
    // Sets gone without a load or unload routed here: the shard restarted with its
    // configured sets only (sets loaded at run time live as long as its process), or
    // someone called the shard's own services. Said loudly: the map shrank.
    std::string lost;
    if (shard.info && !shard.change_expected) {
      for (const ShardSet& held : shard.info->sets) {
        bool kept = false;
        for (const ShardSet& now : msg->sets) kept = kept || now.name == held.name;
        if (!kept) lost += (lost.empty() ? "" : ", ") + held.name;
      }
    }
    if (!lost.empty()) {
      ROS_WARN(
          "bsf_vpr: shard %s no longer holds %s (restarted? sets loaded at run time are "
          "not reloaded: list them in the shard's reference_sets)",
          shard.name.c_str(), lost.c_str());
    }
    shard.lost = lost;
    shard.change_expected = false;
    shard.info = msg;
    shard.refused.clear();
    shard.refused_info.reset();
    ++shard.info_count;
    ++layouts_;
    return true;
  } catch (const std::exception& e) {
    if (shard.refused != e.what()) {
      ROS_ERROR("bsf_vpr: shard %s's sets are refused, the map keeps its previous layout: %s",
                shard.name.c_str(), e.what());
    }
    shard.refused = e.what();
    shard.refused_info = msg;
    ++shard.refusals;
    return false;
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
    // Every shard answers it: said once, by the first shard that answers queries.
    for (int j = 0; j < k; ++j) {
      if (Expected(j)) return;
    }
    callbacks_.reject(
        "a descriptor without a stamp: a sharded map pairs the shards' answers "
        "by header.stamp (shard " +
        shard.name + ")");
    return;
  }
  ++shard.answered;
  const bool old = !last_decided_.isZero() && stamp <= last_decided_;
  Pending& p = (old ? past_ : pending_)[stamp];
  if (p.answers.empty()) {
    p.header = msg->header;
    p.answers.resize(shards_.size());
    p.first = ros::WallTime::now();
  }
  if (p.answers[static_cast<size_t>(k)]) {
    ROS_WARN_THROTTLE(5.0,
                      "bsf_vpr: shard %s answered twice for stamp %.3f: a sharded map tells "
                      "queries apart by header.stamp (the second answer is dropped)",
                      shard.name.c_str(), stamp.toSec());
    return;
  }
  p.answers[static_cast<size_t>(k)] = msg;
  if (!old) {
    MarkAnswering(k);  // on time: waited for again (a late answer does not bring it back)
    Flush(ros::WallTime::now());
    return;
  }
  // A stamp at or before the last decided query. One shard's answer is late (a lagging
  // shard: dropped, its query was decided without it); every shard's answer is a query
  // that came after the others in time but later on the wire (time went back: a bag
  // replayed again, or descriptors published out of stamp order): decided, as a single
  // node would, and the stamps start afresh from it.
  ++shard.late;
  bool complete = true;
  for (size_t j = 0; j < shards_.size(); ++j) {
    if (!p.answers[j] && Expected(static_cast<int>(j))) complete = false;
  }
  if (complete) {
    for (size_t j = 0; j < shards_.size(); ++j) {
      if (p.answers[j]) --shards_[j].late;
    }
    pending_.insert(past_.extract(stamp));
    last_decided_ = ros::Time();
    Flush(ros::WallTime::now());
  }
  while (past_.size() > queue_size_) past_.erase(past_.begin());
}

bool ShardCombiner::Assemble(const std::vector<const ShardDistances*>& answers, Query* query,
                             std::string* error) const {
  query->distances.clear();
  query->missing_shards.clear();
  query->shard_seconds = 0;
  std::string refusals;  // of the shards that refused the descriptor
  bool any = false;      // a shard's distances are in
  for (size_t k = 0; k < shards_.size(); ++k) {
    const Shard& shard = shards_[k];
    if (!shard.info) {
      query->missing_shards.push_back(shard.name);  // no sets known yet
      continue;
    }
    const ShardDistances* a = answers.at(k);
    const std::vector<ShardSet>& sets = shard.info->sets;
    if (a && !a->error.empty() && !sets.empty()) {
      refusals += (refusals.empty() ? "" : "; ") + ("shard " + shard.name + ": " + a->error);
    }
    // An answer for other sets than the layout's (a shard whose new shard_info has not
    // arrived, or was refused), a refusal, or a malformed one counts as none.
    bool usable = a && a->error.empty() && a->set_names.size() == sets.size() &&
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
    any = any || !sets.empty();
    query->shard_seconds = std::max(query->shard_seconds, a->processing_time);
    size_t offset = 0;
    for (size_t i = 0; i < sets.size(); ++i) {
      const Eigen::Index n = a->counts[i];
      query->distances.emplace_back(
          Eigen::Map<const RowMatrixXf>(a->distances.data() + offset, 1, n));
      offset += static_cast<size_t>(n);
    }
  }
  // A descriptor every shard with distances refused is refused (its dimension, a NaN: the
  // same reason on each); one shard's refusal alone makes that shard missing.
  if (!any && !refusals.empty()) {
    *error = refusals;
    return false;
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
        ROS_WARN(
            "bsf_vpr: shard %s did not answer within %.2f s: deciding without its sets "
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
    std::string why;
    if (!shard.info) {
      why = "no shard_info yet";
    } else if (!shard.refused.empty()) {
      why = "its sets refused: " + shard.refused;
    } else if (!shard.info->sets.empty() &&
               (shard.missing || shard.distances_sub.getNumPublishers() == 0)) {
      why = SetList(shard.info.get());
    }
    if (!why.empty()) out += (out.empty() ? "" : "; ") + shard.name + " (" + why + ")";
  }
  return out;
}

void ShardCombiner::Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) const {
  status.add("shards", static_cast<int>(shards_.size()));
  status.add("map layouts taken", layouts_);
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
      state +=
          "missing for " +
          std::to_string(static_cast<int>((ros::WallTime::now() - shard.missing_since).toSec())) +
          " s (" + SetList(shard.info.get()) + ")";
    } else {
      state += "answering: " + SetList(shard.info.get());
    }
    if (!shard.lost.empty()) state += "; lost at its last change: " + shard.lost;
    status.addf("shard " + shard.name, "%s; %ld answers, %ld missed, %ld late", state.c_str(),
                static_cast<long>(shard.answered), static_cast<long>(shard.missed),
                static_cast<long>(shard.late));
  }
}

}  // namespace bsf_vpr
