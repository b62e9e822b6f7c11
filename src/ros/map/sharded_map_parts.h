// What the parts of ShardedMap (sharded_map*.cpp) share: clocks, the query's norm, a
// shard's set names, and the bounded call to a shard's service.
#pragma once

#include <bsf_vpr/ShardInfo.h>
#include <ros/service.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/map/map_backend.h"

namespace bsf_vpr {
namespace sharded {

// How long a routed load or unload waits for the shard's new shard_info.
constexpr double kShardInfoWaitS = 10.0;

inline double NowS() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The descriptor's L2 norm (it bounds a Euclidean distance: ShardDistancesProblem).
inline double Norm(const QueryDescriptor& descriptor) {
  double sum = 0;
  for (Eigen::Index i = 0; i < descriptor.size; ++i) {
    sum += static_cast<double>(descriptor.values[i]) * descriptor.values[i];
  }
  return std::sqrt(sum);
}

inline std::string SetNames(const ShardInfo* info) {
  if (!info || info->sets.empty()) return "no sets";
  std::string out;
  for (const ShardSet& s : info->sets) out += (out.empty() ? "" : ", ") + s.name;
  return out;
}

inline std::chrono::steady_clock::time_point Deadline(double seconds) {
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

}  // namespace sharded
}  // namespace bsf_vpr
