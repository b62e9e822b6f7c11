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

namespace bsf_vpr {
namespace {

// How long a routed load or unload waits for the shard's new shard_info.
constexpr double kShardInfoWaitS = 10.0;

double NowS() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The descriptor's L2 norm (it bounds a Euclidean distance: ShardDistancesProblem).
double Norm(const QueryDescriptor& descriptor) {
  double sum = 0;
  for (Eigen::Index i = 0; i < descriptor.size; ++i) {
    sum += static_cast<double>(descriptor.values[i]) * descriptor.values[i];
  }
  return std::sqrt(sum);
}

std::string SetNames(const ShardInfo* info) {
  if (!info || info->sets.empty()) return "no sets";
  std::string out;
  for (const ShardSet& s : info->sets) out += (out.empty() ? "" : ", ") + s.name;
  return out;
}

std::chrono::steady_clock::time_point Deadline(double seconds) {
  return std::chrono::steady_clock::now() +
         std::chrono::duration_cast<std::chrono::steady_clock::duration>(
             std::chrono::duration<double>(seconds));
}

// A call to a shard's service that is waited for a bounded time: roscpp's calls cannot be
// cancelled, so each runs in a thread of its own, which goes on (owning its request and
// response) when the wait ends first. Such a call raises the shard's count of stalled calls
// until it returns; while it is raised, the shard is not called (a stalled shard would
// otherwise gather one blocked thread per call).
template <typename Service>
class ShardCall {
 public:
  ShardCall(const std::string& service, const Service& srv,
            std::shared_ptr<std::atomic<int>> stalled)
      : service_(service), state_(std::make_shared<State>()) {
    state_->srv = srv;
    state_->stalled = std::move(stalled);
    if (*state_->stalled > 0) {
      busy_ = true;
      return;
    }
    std::thread([state = state_, service] {
      const bool ok = ros::service::call(service, state->srv);
      MutexLock lock(&state->mutex);
      state->finished = true;
      state->ok = ok;
      if (state->abandoned) --*state->stalled;
      state->done.notify_all();
    }).detach();
  }

  // Waits for the answer until `deadline`: "" once answered (response()), else why not.
  std::string Wait(std::chrono::steady_clock::time_point deadline, double timeout_s) {
    if (busy_) {
      return "has not answered an earlier call yet (a stalled shard is not called again until "
             "it does)";
    }
    MutexLock lock(&state_->mutex);
    if (!lock.AwaitUntil(state_->done, deadline, [this] {
          state_->mutex.AssertHeld();
          return state_->finished;
        })) {
      if (!state_->abandoned) {
        state_->abandoned = true;
        ++*state_->stalled;
      }
      char seconds[32];
      std::snprintf(seconds, sizeof(seconds), "%.2f", timeout_s);
      return std::string("did not answer ") + service_ + " within " + seconds + " s (stalled?)";
    }
    return state_->ok ? "" : "did not answer " + service_;
  }
  // The response; read after Wait returned "".
  const typename Service::Response& response() const { return state_->srv.response; }

 private:
  struct State {
    Service srv;
    std::shared_ptr<std::atomic<int>> stalled;
    Mutex mutex;
    std::condition_variable done;
    bool finished GUARDED_BY(mutex) = false;
    bool ok GUARDED_BY(mutex) = false;
    bool abandoned GUARDED_BY(mutex) = false;
  };
  std::string service_;
  std::shared_ptr<State> state_;
  bool busy_ = false;
};

template <typename Service>
std::string CallShard(const std::string& service, Service* srv,
                      std::shared_ptr<std::atomic<int>> stalled, double timeout_s) {
  ShardCall<Service> call(service, *srv, std::move(stalled));
  const std::string why = call.Wait(Deadline(timeout_s), timeout_s);
  if (why.empty()) srv->response = call.response();
  return why;
}

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
      shards_(options_.shards.size()),
      join_(
          static_cast<int>(options_.shards.size()), options_.timeout_s,
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
  for (size_t k = 0; k < shards_.size(); ++k) shards_[k].name = nh_.resolveName(options_.shards[k]);
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
      shards_.size(), options_.timeout_s);
  // Asks again the shards that did not answer get_shard_info.
  ros::WallTimerOptions confirm(
      ros::WallDuration(1.0),
      [this](const ros::WallTimerEvent&) {
        for (size_t k = 0; k < options_.shards.size(); ++k) {  // one per configured shard
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
  timer_ = nh_.createWallTimer(ros::WallDuration(std::max(0.005, options_.timeout_s / 5)),
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
  bool decided = false;
  {
    MutexLock lock(&mutex_);
    std::vector<Join::Decision> decisions =
        join_.Hear(descriptor.header.stamp_ns(), Norm(descriptor), NowS());
    decided = !decisions.empty();
    Queue(std::move(decisions));
  }
  if (decided) DeliverLater();  // the caller holds the node's lock
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
      CallShard(name + "/" + names::kShardInfoService, &ask, stalled, options_.call_timeout_s);
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
    // Restarted (or republished) with the sets it had: nothing to rebuild.
    shard.info = msg;
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

PlaceLayout ShardedMap::LayoutWith(int k, const ShardInfo& info, DistanceMetric* metric) const {
  // Every shard's info, shard k's replaced by `info`.
  std::vector<const ShardInfo*> infos;
  for (size_t j = 0; j < shards_.size(); ++j) {
    infos.push_back(static_cast<int>(j) == k ? &info : shards_[j].info.get());
  }
  // The distance of the map: that of the shards holding sets (one without sets has its
  // configured or default distance, which does not matter).
  std::string distance;
  PlaceLayout layout;
  layout.SetPlacePoseTolerance(options_.place_pose_tolerance_m);
  for (size_t j = 0; j < infos.size(); ++j) {
    if (!infos[j] || infos[j]->sets.empty()) continue;
    if (distance.empty()) distance = infos[j]->distance;
    if (infos[j]->distance != distance) {
      throw std::invalid_argument("the shards' sets are meant for different distances (" +
                                  distance + ", and " + infos[j]->distance + " on shard " +
                                  shards_[j].name + ")");
    }
    for (const ShardSet& s : infos[j]->sets) {
      if (const std::string bad = SetNameProblem(s.name); !bad.empty()) {
        throw std::invalid_argument("shard " + shards_[j].name + " holds a set " + bad);
      }
      if (layout.IndexOf(s.name) >= 0) {
        throw std::invalid_argument("set '" + s.name + "' is held by two shards");
      }
      if (layout.dimension() != 0 && s.dimension != layout.dimension()) {
        throw std::invalid_argument("set '" + s.name + "' has dimension " +
                                    std::to_string(s.dimension) + ", the map " +
                                    std::to_string(layout.dimension()));
      }
      layout.Add(LayoutFromShardSetMsg(s));
    }
  }
  *metric = ParseDistanceMetric(distance.empty() ? info.distance : distance);
  if (layout.num_sets() > 0 && options_.metric && *metric != *options_.metric) {
    throw std::invalid_argument("the shards use " + ToString(*metric) + " distance, this node " +
                                ToString(*options_.metric));
  }
  return layout;
}

bool ShardedMap::TakeInfo(int k, const ShardInfo::ConstPtr& msg) {
  Shard& shard = shards_[static_cast<size_t>(k)];
  try {
    DistanceMetric metric;
    PlaceLayout layout = LayoutWith(k, *msg, &metric);
    const std::string why = "shard " + shard.name + " holds " + SetNames(msg.get()) +
                            (shard.info ? " (was " + SetNames(shard.info.get()) + ")" : "");
    ROS_INFO(
        "bsf_vpr: sharded map: %s; the map now has %d set(s), %d places; the belief starts "
        "afresh",
        why.c_str(), layout.num_sets(), layout.num_places());
    layout_ = std::make_shared<NumberedLayout>(std::move(layout), ++generations_);
    outbox_.push_back(Outgoing{std::nullopt, "", layout_});
    metric_ = metric;
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

void ShardedMap::Queue(std::vector<Join::Decision> decisions) {
  for (Join::Decision& d : decisions) {
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

MapBackend::Query ShardedMap::Assemble(const QueryHeader& header, double query_norm,
                                       const std::vector<const ShardDistances*>& answers) {
  Query query;
  query.header = header;
  query.layout = layout_;
  query.distances = QueryDistances(layout_->num_sets());
  std::string refusals;  // of the shards that refused the descriptor
  bool any = false;      // a shard's distances are in
  int u = 0;             // the layout's index of the shard's first set
  for (size_t k = 0; k < shards_.size(); ++k) {
    Shard& shard = shards_[k];
    if (!shard.info) {
      query.missing_shards.push_back(shard.name);  // no sets known yet
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
    // Distances no exact distance can be (a broken kernel, a corrupted message): that
    // shard's fault, not the query's.
    for (size_t i = 0, offset = 0; usable && i < sets.size();
         offset += sets[i].place_ids.size(), ++i) {
      const std::string problem =
          ShardDistancesProblem(a->distances.data() + offset, sets[i].place_ids.size(),
                                metric_ == DistanceMetric::kCosine, query_norm, sets[i].max_norm);
      if (problem.empty()) continue;
      usable = false;
      ++shard.invalid_answers;
      shard.invalid = "set '" + sets[i].name + "': " + problem;
      ROS_WARN_THROTTLE(5.0,
                        "bsf_vpr: shard %s answered distances that cannot be exact (%s): "
                        "deciding without its sets for that query",
                        shard.name.c_str(), shard.invalid.c_str());
    }
    if (!usable) {
      if (!sets.empty()) query.missing_shards.push_back(shard.name);
      u += static_cast<int>(sets.size());  // absent
      continue;
    }
    any = any || !sets.empty();
    query.seconds = std::max(query.seconds, a->processing_time);
    size_t offset = 0;
    for (size_t i = 0; i < sets.size(); ++i, ++u) {
      const Eigen::Index n = a->counts[i];
      query.distances.Set(u, Eigen::Map<const RowMatrixXf>(a->distances.data() + offset, 1, n));
      offset += static_cast<size_t>(n);
    }
  }
  // A descriptor every shard with distances refused is refused (its dimension, a NaN: the
  // same reason on each); one shard's refusal alone makes that shard missing.
  if (!any && !refusals.empty()) throw std::invalid_argument(refusals);
  AttachJoint(answers, &query);
  return query;
}

MapBackend::Query ShardedMap::Ask(const QueryDescriptor& descriptor) {
  // Each shard's distances through its get_distances service, called at once and waited for
  // until one deadline (without the lock: the shards answer while descriptors stream in).
  std::vector<std::string> names;
  std::vector<std::shared_ptr<std::atomic<int>>> stalled;
  {
    MutexLock lock(&mutex_);
    for (const Shard& s : shards_) {
      names.push_back(s.name);
      stalled.push_back(s.stalled_calls);
    }
  }
  GetShardDistances request;
  request.request.descriptor = ToDescriptorMsg(descriptor);
  std::vector<std::unique_ptr<ShardCall<GetShardDistances>>> calls;
  for (size_t k = 0; k < names.size(); ++k) {
    calls.push_back(std::make_unique<ShardCall<GetShardDistances>>(
        names[k] + "/" + names::kShardDistancesService, request, stalled[k]));
  }
  const auto deadline = Deadline(options_.call_timeout_s);
  std::vector<const ShardDistances*> answers(names.size(), nullptr);
  for (size_t k = 0; k < names.size(); ++k) {
    const std::string why = calls[k]->Wait(deadline, options_.call_timeout_s);
    if (why.empty()) {
      answers[k] = &calls[k]->response().distances;
    } else {
      ROS_WARN_THROTTLE(5.0, "bsf_vpr: query_place: shard %s %s: answered without its sets",
                        names[k].c_str(), why.c_str());
    }
  }
  MutexLock lock(&mutex_);
  return Assemble(descriptor.header, Norm(descriptor), answers);
}

template <typename Service>
std::string ShardedMap::Route(int k, const std::string& service, Service* srv, double timeout_s) {
  std::string name;
  uint64_t infos = 0, refusals = 0;
  std::shared_ptr<std::atomic<int>> stalled;
  {
    MutexLock lock(&mutex_);
    Shard& shard = shards_.at(static_cast<size_t>(k));
    name = shard.name;
    infos = shard.info_count;
    refusals = shard.refusals;
    stalled = shard.stalled_calls;
    shard.change_expected = true;  // its next change of sets is not warned about as lost
  }
  const std::string why = CallShard(name + "/" + service, srv, stalled, timeout_s);
  if (!why.empty()) {
    throw std::invalid_argument("shard " + name + " " + why +
                                "; if it completes later, the map takes the shard's new sets "
                                "when its shard_info arrives (list_reference_sets)");
  }
  if (!srv->response.success) {
    throw std::invalid_argument("shard " + name + ": " + srv->response.message);
  }
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(kShardInfoWaitS);
  MutexLock lock(&mutex_);
  const Shard& shard = shards_[static_cast<size_t>(k)];
  const auto taken = [&] {
    mutex_.AssertHeld();
    return shard.info_count > infos;
  };
  // The shard published its new sets before answering: wait for the map to take them, or
  // to refuse them (a set that cannot share the map with the other shards' sets).
  if (!lock.AwaitUntil(infos_changed_, deadline, [&] {
        mutex_.AssertHeld();
        return taken() || shard.refusals > refusals;
      })) {
    throw std::invalid_argument(
        srv->response.message + ", but its new shard_info has not reached this node in " +
        std::to_string(static_cast<int>(kShardInfoWaitS)) + " s (see diagnostics)");
  }
  if (taken()) return srv->response.message;
  // Take the shard back to the sets the map holds (without the lock: a call), and answer
  // once they are back in the map (nothing refused).
  std::vector<std::string> added;
  if (shard.refused_info) {
    for (const ShardSet& s : shard.refused_info->sets) {
      bool held = false;
      if (shard.info) {
        for (const ShardSet& t : shard.info->sets) held = held || t.name == s.name;
      }
      if (!held) added.push_back(s.name);
    }
  }
  const std::string refusal = shard.refused;
  lock.Unlock();
  for (const std::string& set : added) {
    UnloadReferenceSet undo;
    undo.request.name = set;
    const std::string undone = CallShard(name + "/" + names::kUnloadReferenceSetService, &undo,
                                         stalled, options_.call_timeout_s);
    if (!undone.empty()) ROS_WARN("bsf_vpr: shard %s %s", name.c_str(), undone.c_str());
  }
  lock.Lock();
  if (!added.empty()) lock.AwaitUntil(infos_changed_, deadline, taken);
  throw std::invalid_argument("the map refused shard " + name + "'s new sets (" + refusal + ")" +
                              (added.empty() ? "" : "; unloaded again from the shard"));
}

std::string ShardedMap::Load(const LoadRequest& request, const SetCheck&) {
  // Routed to the shard asked for, or the one holding the fewest places; the path is below
  // that shard's data directory.
  int shard = -1;
  {
    MutexLock lock(&mutex_);
    for (size_t k = 0; k < shards_.size(); ++k) {
      const std::string& name = shards_[k].name;
      if (!request.shard.empty() &&
          (name == request.shard || name == nh_.resolveName(request.shard))) {
        shard = static_cast<int>(k);
      }
    }
    if (request.shard.empty()) shard = LeastLoaded();
    if (!request.name.empty() && OwnerOf(request.name) >= 0) {
      throw std::invalid_argument("a reference set named " + QuotedForMessage(request.name) +
                                  " is already loaded, on shard " +
                                  shards_[static_cast<size_t>(OwnerOf(request.name))].name);
    }
  }
  if (shard < 0) {
    throw std::invalid_argument(request.shard.empty()
                                    ? "no shard has published its sets yet"
                                    : "no shard named " + QuotedForMessage(request.shard) +
                                          " (parameter shards)");
  }
  LoadReferenceSet forward;
  forward.request = ToLoadRequestMsg(request);
  forward.request.shard.clear();
  return Route(shard, names::kLoadReferenceSetService, &forward, options_.load_timeout_s);
}

std::string ShardedMap::Unload(const std::string& name) {
  int shard = -1;
  {
    MutexLock lock(&mutex_);
    shard = OwnerOf(name);
  }
  if (shard < 0) {
    throw std::invalid_argument("no shard holds a reference set named " + QuotedForMessage(name));
  }
  UnloadReferenceSet forward;
  forward.request.name = name;
  return Route(shard, names::kUnloadReferenceSetService, &forward, options_.call_timeout_s);
}

std::string ShardedMap::CannotRecord() const {
  return "this node fuses shards and sees no descriptors: record with a fusion node of its "
         "own sets, then load the recorded set on a shard (load_reference_set with shard)";
}

std::string ShardedMap::Add(ReferenceSet, const std::string&) {
  throw std::invalid_argument(CannotRecord());
}

SetList ShardedMap::List() const {
  // This map holds the layout; the shard, the rows (a shard's refused sets are in its
  // refused_info, not in info).
  MutexLock lock(&mutex_);
  SetList out;
  for (const Shard& shard : shards_) {
    if (!shard.info) continue;
    for (const ShardSet& s : shard.info->sets) {
      SetSummary info;
      info.name = s.name;
      info.condition = s.condition;
      info.descriptor_type = s.descriptor_type;
      info.num_places = static_cast<int>(s.place_ids.size());
      info.dimension = s.dimension;
      info.memory_bytes = s.memory_bytes;
      info.storage = s.storage;
      info.shard = shard.name;
      out.sets.push_back(info);
    }
  }
  out.num_places = layout_->num_places();
  return out;
}

std::string ShardedMap::MissingSummaryLocked() const {
  std::string out;
  for (size_t k = 0; k < shards_.size(); ++k) {
    const Shard& shard = shards_[k];
    std::string why;
    if (!shard.info) {
      why = "no shard_info yet";
    } else if (!shard.refused.empty()) {
      why = "its sets refused: " + shard.refused;
    } else if (!shard.info->sets.empty() && (join_.counts(static_cast<int>(k)).missing ||
                                             shard.distances_sub.getNumPublishers() == 0)) {
      why = SetNames(shard.info.get());
    }
    if (!why.empty()) out += (out.empty() ? "" : "; ") + shard.name + " (" + why + ")";
  }
  return out;
}

void ShardedMap::AttachJoint(const std::vector<const ShardDistances*>& answers, Query* query) {
  joint_used_.clear();
  if (!joint_kind_) return;
  const std::string kind = ToString(*joint_kind_);
  const int places = layout_->num_places();
  // Of the shards' joint representations of the kind asked for, over every place of the
  // layout, finite and not negative, the one built from the most sets of the layout.
  const ShardDistances* best = nullptr;
  size_t best_k = 0;
  for (size_t k = 0; k < answers.size(); ++k) {
    const ShardDistances* a = answers[k];
    if (!a || !a->error.empty() || a->joint_kind != kind || a->joint_sets.size() < 2 ||
        a->joint_distances.size() != static_cast<size_t>(places)) {
      continue;
    }
    bool fits = true;
    for (const std::string& name : a->joint_sets) fits = fits && layout_->IndexOf(name) >= 0;
    for (float v : a->joint_distances) fits = fits && v >= 0 && v <= 3.0f;  // within [0, 2]
    if (fits && (!best || a->joint_sets.size() > best->joint_sets.size())) {
      best = a;
      best_k = k;
    }
  }
  if (!best) return;
  // The build names the shard too: another shard's, or its next, starts the state again.
  QueryDistances::Joint joint;
  joint.kind = *joint_kind_;
  joint.build = (static_cast<uint64_t>(best_k + 1) << 48) ^ best->joint_build;
  joint.distances = Eigen::Map<const RowMatrixXf>(best->joint_distances.data(), 1, places);
  query->distances.SetJoint(std::move(joint));
  joint_used_ = shards_[best_k].name + " (" + std::to_string(best->joint_sets.size()) + " sets)";
}

void ShardedMap::SetJoint(std::optional<JointKind> kind, const JointOptions& /*options*/) {
  MutexLock lock(&mutex_);
  joint_kind_ = kind;
}

std::string ShardedMap::Problem() const {
  MutexLock lock(&mutex_);
  const std::string missing = MissingSummaryLocked();
  return missing.empty() ? "" : "deciding without shard(s) " + missing;
}

StatusValues ShardedMap::Diagnose() const {
  MutexLock lock(&mutex_);
  StatusValues status;
  const auto add = [&status](const std::string& key, const std::string& value) {
    status.emplace_back(key, value);
  };
  // The shards' own: this map computes no distances.
  add("first stage", ToString(FirstStageKind::kExact));
  add("joint representation",
      !joint_kind_ ? std::string("none asked for")
      : joint_used_.empty()
          ? "none: no shard serves the " + ToString(*joint_kind_) +
                " of two or more sets over every place (shard parameter fusion_joint)"
          : ToString(*joint_kind_) + " from shard " + joint_used_);
  add("shards", std::to_string(shards_.size()));
  add("map layouts taken", std::to_string(layouts_));
  add("queries decided", std::to_string(decided_));
  add("decided without some shard", std::to_string(decided_partial_));
  // Heard, but no shard's answer came within shard_timeout_s (lost on the way, e.g. from a
  // shard's full publisher queue while this node stalled): no belief for them.
  add("queries no shard answered", std::to_string(join_.unanswered()));
  for (size_t k = 0; k < shards_.size(); ++k) {
    const Shard& shard = shards_[k];
    const Join::ShardCounts& counts = join_.counts(static_cast<int>(k));
    std::string state;
    if (!shard.refused.empty()) state = "sets refused: " + shard.refused + "; ";
    if (!shard.info) {
      state += "no shard_info yet";
    } else if (shard.distances_sub.getNumPublishers() == 0) {
      state += "not publishing (" + SetNames(shard.info.get()) + " missing)";
    } else if (counts.missing) {
      state += "missing for " + std::to_string(static_cast<int>(NowS() - counts.missing_since_s)) +
               " s (" + SetNames(shard.info.get()) + ")";
    } else {
      state += "answering: " + SetNames(shard.info.get());
    }
    if (!shard.lost.empty()) state += "; lost at its last change: " + shard.lost;
    if (shard.unconfirmed) state += "; a shard_info waits for the shard to confirm it";
    if (shard.foreign_infos > 0) {
      state += "; " + std::to_string(shard.foreign_infos) +
               " shard_info refused: published by another node (last " + shard.last_foreign + ")";
    }
    if (shard.corrected_infos > 0) {
      state += "; " + std::to_string(shard.corrected_infos) +
               " shard_info other than the shard's own answer (its answer taken)";
    }
    if (*shard.stalled_calls > 0) {
      state += "; " + std::to_string(shard.stalled_calls->load()) +
               " service call(s) not answered in time, still pending";
    }
    char counted[256];
    std::snprintf(counted, sizeof counted,
                  "; %ld answers, %ld missed, %ld late, %ld for stamps no descriptor had, %ld "
                  "with impossible distances",
                  static_cast<long>(counts.answered), static_cast<long>(counts.missed),
                  static_cast<long>(counts.late), static_cast<long>(counts.unheard),
                  static_cast<long>(shard.invalid_answers));
    add("shard " + shard.name,
        state + counted + (shard.invalid.empty() ? "" : " (last: " + shard.invalid + ")"));
  }
  return status;
}

}  // namespace bsf_vpr
