#include "src/ros/map/sharded_map.h"

#include <bsf_vpr/GetShardDistances.h>
#include <bsf_vpr/GetShardInfo.h>
#include <bsf_vpr/UnloadReferenceSet.h>
#include <ros/callback_queue.h>

#include <algorithm>
#include <boost/make_shared.hpp>
#include <chrono>
#include <cmath>
#include <thread>

#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "bsf_vpr/map/set_loading.h"
#include "bsf_vpr/ros/names.h"
#include "src/ros/common/conversions.h"
#include "src/ros/map/sharded_map_parts.h"

namespace bsf_vpr {
namespace {

using namespace sharded;

// Runs a function on a callback queue.
class FunctionCallback : public ros::CallbackInterface {
 public:
  explicit FunctionCallback(std::function<void()> f) : f_(std::move(f)) {}
  CallResult call() override {
    f_();
    return Success;
  }

 private:
  std::function<void()> f_;
};

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

ShardedMap::ShardedMap(ros::NodeHandle nh, ShardedMapOptions options)
    : nh_(std::move(nh)),
      options_(std::move(options)),
      shards_(options_.sharding.shards.size()),
      join_(
          static_cast<int>(options_.sharding.shards.size()), options_.sharding.shard_timeout,
          static_cast<size_t>(std::max(1, options_.queue_size)),
          // The join calls these from its own calls, which run under mutex_ (join_ is
          // guarded by it).
          [this](int k) {
            mutex_.AssertHeld();
            return CanAnswer(k);
          },
          [this](Join::Level level, int k, const std::string& what) {
            mutex_.AssertHeld();
            const std::string& name = shards_[static_cast<size_t>(k)].name;
            if (level == Join::Level::kWarn) {
              ROS_WARN("bsf_vpr: shard %s %s", name.c_str(), what.c_str());
            } else if (level == Join::Level::kWarnRepeated) {
              ROS_WARN_THROTTLE(5.0, "bsf_vpr: shard %s %s", name.c_str(), what.c_str());
            } else {
              ROS_INFO("bsf_vpr: shard %s %s", name.c_str(), what.c_str());
            }
          }),
      layout_(std::make_shared<NumberedLayout>(PlaceLayout(), 0)),
      metric_(options_.metric.value_or(DistanceMetric::kEuclidean)) {
  for (size_t k = 0; k < shards_.size(); ++k) shards_[k].name = nh_.resolveName(options_.sharding.shards[k]);
}

void ShardedMap::Start(Callbacks callbacks) {
  callbacks_ = std::move(callbacks);
  MutexLock lock(&mutex_);  // the subscriptions' callbacks take it
  for (size_t k = 0; k < shards_.size(); ++k) {
    Shard& s = shards_[k];
    const int index = static_cast<int>(k);
    ros::SubscribeOptions info;
    info.initByFullCallbackType<const ros::MessageEvent<const ShardInfo>&>(
        s.name + "/" + names::kShardInfoTopic, 1,
        [this, index](const ros::MessageEvent<const ShardInfo>& e) { OnInfo(index, e); });
    info.callback_queue = &info_queue_;
    s.info_sub = nh_.subscribe(info);
    s.distances_sub = nh_.subscribe<ShardDistances>(
        s.name + "/" + names::kShardDistancesTopic,
        static_cast<uint32_t>(std::max(1, options_.queue_size)),
        [this, index](const ShardDistances::ConstPtr& m) { OnDistances(index, m); });
  }
  ROS_INFO(
      "bsf_vpr: sharded map over %zu shard(s), waiting %.2f s for each; its sets come "
      "with the shards' shard_info, as each shard's get_shard_info confirms it",
      shards_.size(), options_.sharding.shard_timeout);
  // Asks again the shards that did not answer get_shard_info.
  ros::WallTimerOptions confirm(
      ros::WallDuration(1.0),
      [this](const ros::WallTimerEvent&) {
        for (size_t k = 0; k < options_.sharding.shards.size(); ++k) {  // one per configured shard
          ShardInfo::ConstPtr msg;
          std::string publisher;
          {
            MutexLock guard(&mutex_);
            std::swap(msg, shards_[k].unconfirmed);
            publisher = shards_[k].unconfirmed_publisher;
          }
          if (msg) ConfirmInfo(static_cast<int>(k), msg, publisher);
        }
      },
      &info_queue_);
  confirm_timer_ = nh_.createWallTimer(confirm);
  info_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &info_queue_);
  info_spinner_->start();
  // Decides the queries whose missing answers time out (every answer may have arrived).
  timer_ = nh_.createWallTimer(ros::WallDuration(std::max(0.005, options_.sharding.shard_timeout / 5)),
                               [this](const ros::WallTimerEvent&) {
                                 {
                                   MutexLock guard(&mutex_);
                                   Queue(join_.Tick(NowS()));
                                 }
                                 Deliver();
                               });
}

ShardedMap::~ShardedMap() {
  // Taken out under the lock (a callback still running reads them through CanAnswer), shut
  // down without it (shutdown waits for a running callback, which takes the lock).
  std::vector<ros::Subscriber> subscribers;
  {
    MutexLock lock(&mutex_);
    for (Shard& s : shards_) {
      subscribers.push_back(std::move(s.info_sub));
      subscribers.push_back(std::move(s.distances_sub));
    }
  }
  timer_.stop();
  confirm_timer_.stop();
  for (ros::Subscriber& s : subscribers) s.shutdown();
  if (info_spinner_) info_spinner_->stop();
  nh_.getCallbackQueue()->removeByID(reinterpret_cast<uint64_t>(this));
}

std::optional<MapBackend::Query> ShardedMap::Hear(const QueryDescriptor& descriptor) {
  if (descriptor.header.stamp_is_zero()) return std::nullopt;  // the shards' answers say so
  bool released = false;
  {
    MutexLock lock(&mutex_);
    std::vector<Join::Release> releases =
        join_.Hear(descriptor.header.stamp_ns(), Norm(descriptor), NowS());
    released = !releases.empty();
    Queue(std::move(releases));
  }
  if (released) DeliverLater();  // the caller holds the node's lock
  return std::nullopt;
}

void ShardedMap::DeliverLater() {
  nh_.getCallbackQueue()->addCallback(boost::make_shared<FunctionCallback>([this] { Deliver(); }),
                                      reinterpret_cast<uint64_t>(this));
}

MapBackend::Layout ShardedMap::layout() const {
  MutexLock lock(&mutex_);
  return layout_;
}

DistanceMetric ShardedMap::metric() const {
  MutexLock lock(&mutex_);
  return metric_;
}

bool ShardedMap::CanAnswer(int k) const {
  const Shard& shard = shards_[static_cast<size_t>(k)];
  return shard.info && shard.distances_sub && shard.distances_sub.getNumPublishers() > 0;
}

int ShardedMap::OwnerOf(const std::string& set) const {
  for (size_t k = 0; k < shards_.size(); ++k) {
    if (!shards_[k].info) continue;
    for (const ShardSet& s : shards_[k].info->sets) {
      if (s.name == set) return static_cast<int>(k);
    }
  }
  return -1;
}

int ShardedMap::LeastLoaded() const {
  int best = -1;
  size_t fewest = 0;
  for (size_t k = 0; k < shards_.size(); ++k) {
    if (!shards_[k].info || join_.counts(static_cast<int>(k)).missing) continue;
    size_t places = 0;
    for (const ShardSet& s : shards_[k].info->sets) places += s.place_ids.size();
    if (best < 0 || places < fewest) {
      best = static_cast<int>(k);
      fewest = places;
    }
  }
  return best;
}

void ShardedMap::OnInfo(int k, const ros::MessageEvent<const ShardInfo>& event) {
  {
    MutexLock lock(&mutex_);
    shards_[static_cast<size_t>(k)].unconfirmed.reset();  // superseded
  }
  ConfirmInfo(k, event.getConstMessage(), event.getPublisherName());
}

void ShardedMap::ConfirmInfo(int k, const ShardInfo::ConstPtr& msg, const std::string& publisher) {
  std::string name;
  std::shared_ptr<std::atomic<int>> stalled;
  {
    MutexLock lock(&mutex_);
    name = shards_[static_cast<size_t>(k)].name;
    stalled = shards_[static_cast<size_t>(k)].stalled_calls;
  }
  GetShardInfo ask;
  const std::string why =
      CallShard(name + "/" + names::kShardInfoService, &ask, stalled, options_.call_timeout_s());
  {
    MutexLock lock(&mutex_);
    Shard& shard = shards_[static_cast<size_t>(k)];
    if (!why.empty()) {
      // Not believed until the shard says so (a shard starting, or stalled): asked again.
      if (!shard.unconfirmed) {
        shard.unconfirmed = msg;
        shard.unconfirmed_publisher = publisher;
      }
      ROS_WARN_THROTTLE(5.0,
                        "bsf_vpr: shard %s %s: its shard_info (from %s) is not taken until it "
                        "confirms it; asking again every second",
                        name.c_str(), why.c_str(), publisher.c_str());
      return;
    }
    if (publisher != ask.response.node) {
      // Another process publishing on the shard's topic: refused, whatever it says.
      ++shard.foreign_infos;
      shard.last_foreign = publisher;
      ROS_ERROR_THROTTLE(5.0,
                         "bsf_vpr: refused a shard_info on %s/%s published by %s, not by the "
                         "shard (%s): %lu refused so far; the map keeps the shard's sets",
                         name.c_str(), names::kShardInfoTopic, publisher.c_str(),
                         ask.response.node.c_str(),
                         static_cast<unsigned long>(shard.foreign_infos));
      return;
    }
  }
  ShardInfo::ConstPtr confirmed = msg;
  if (!SameSets(msg.get(), &ask.response.info)) {
    // The shard's own answer is what it holds (its shard_info was superseded, or forged
    // under its name).
    MutexLock lock(&mutex_);
    ++shards_[static_cast<size_t>(k)].corrected_infos;
    ROS_WARN(
        "bsf_vpr: a shard_info of %s says it holds %s, the shard's get_shard_info %s: "
        "the map takes the shard's answer",
        name.c_str(), SetNames(msg.get()).c_str(), SetNames(&ask.response.info).c_str());
    confirmed = boost::make_shared<const ShardInfo>(ask.response.info);
  }
  TakeShardInfo(k, confirmed);
  Deliver();  // the new layout, if any
}

void ShardedMap::TakeShardInfo(int k, const ShardInfo::ConstPtr& msg) {
  MutexLock lock(&mutex_);
  Shard& shard = shards_[static_cast<size_t>(k)];
  // What the shard holds now supersedes a layout of it refused before (a load that was
  // refused and unloaded again, a restart).
  shard.refused.clear();
  shard.refused_info.reset();
  if (SameSets(shard.info.get(), msg.get())) {
    // Restarted (or republished) with the sets it had: nothing to rebuild. What it says of
    // them beyond their rows (conditions, images) is taken for the next layout.
    shard.info = msg;
    try {
      shard.sets = std::make_shared<const ShardSets>(FromShardInfoMsg(*msg, shard.name));
    } catch (const std::exception&) {
      // Poses that do not fit its places: the sets as taken before stay.
    }
    ++shard.info_count;
    shard.change_expected = false;
    if (join_.counts(k).missing) ROS_INFO("bsf_vpr: shard %s is back", shard.name.c_str());
    infos_changed_.notify_all();
    return;
  }
  if (TakeInfo(k, msg)) {
    // Another shard's layout refused earlier may fit now (the clash it had may be gone).
    for (size_t j = 0; j < shards_.size(); ++j) {
      if (static_cast<int>(j) != k && shards_[j].refused_info) {
        TakeInfo(static_cast<int>(j), shards_[j].refused_info);
      }
    }
  }
  infos_changed_.notify_all();
}

bool ShardedMap::TakeInfo(int k, const ShardInfo::ConstPtr& msg) {
  Shard& shard = shards_[static_cast<size_t>(k)];
  try {
    auto sets = std::make_shared<const ShardSets>(FromShardInfoMsg(*msg, shard.name));
    MergedLayout merged = LayoutWith(k, *sets);
    PlaceLayout& layout = merged.layout;
    const std::string why = "shard " + shard.name + " holds " + SetNames(msg.get()) +
                            (shard.info ? " (was " + SetNames(shard.info.get()) + ")" : "");
    ROS_INFO(
        "bsf_vpr: sharded map: %s; the map now has %d set(s), %d places; the belief starts "
        "afresh",
        why.c_str(), layout.num_sets(), layout.num_places());
    layout_ = std::make_shared<NumberedLayout>(std::move(layout), ++generations_);
    outbox_.push_back(Outgoing{std::nullopt, "", layout_});
    metric_ = merged.metric;
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
    shard.sets = std::move(sets);
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

void ShardedMap::OnDistances(int k, const ShardDistances::ConstPtr& msg) {
  {
    MutexLock lock(&mutex_);
    if (msg->header.stamp.isZero()) {
      // Every shard answers it: said once, by the first shard that answers queries.
      for (int j = 0; j < k; ++j) {
        if (join_.Expected(j)) return;
      }
      outbox_.push_back(Outgoing{std::nullopt,
                                 "a descriptor without a stamp: a sharded map pairs the shards' "
                                 "answers by header.stamp (shard " +
                                     shards_[static_cast<size_t>(k)].name + ")",
                                 nullptr});
    } else {
      Queue(join_.Answer(k, static_cast<int64_t>(msg->header.stamp.toNSec()), msg, NowS()));
    }
  }
  Deliver();
}

void ShardedMap::Queue(std::vector<Join::Release> releases) {
  for (Join::Release& d : releases) {
    std::vector<const ShardDistances*> answers;
    const ShardDistances* last = nullptr;  // the header comes from the last shard answering
    for (const ShardDistances::ConstPtr& a : d.answers) {
      answers.push_back(a.get());
      if (a) last = a.get();
    }
    const QueryHeader header = last ? ToQueryHeader(last->header) : QueryHeader();
    try {
      Query query = Assemble(header, d.query_norm, answers);
      ++decided_;
      if (!query.missing_shards.empty()) ++decided_partial_;
      outbox_.push_back(Outgoing{std::move(query), "", nullptr});
    } catch (const std::exception& e) {
      outbox_.push_back(Outgoing{std::nullopt, e.what(), nullptr});
    }
  }
}

void ShardedMap::Deliver() {
  MutexLock order(&deliver_);
  for (;;) {
    Outgoing next;
    {
      MutexLock lock(&mutex_);
      if (outbox_.empty()) return;
      next = std::move(outbox_.front());
      outbox_.pop_front();
    }
    if (next.query) {
      callbacks_.query(*next.query);
    } else if (next.layout) {
      callbacks_.layout(next.layout);
    } else {
      callbacks_.reject(next.rejection);
    }
  }
}

}  // namespace bsf_vpr
