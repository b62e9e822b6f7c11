// The robot's progress between two queries from the odometry heard, ROS-free (the
// OdometryTracker feeds it and reads it; a gtest drives it with a clock of its own).
//
// A position that is not finite is refused and counted: it never becomes the latest, so one
// bad message cannot spoil every step after it. Odometry last heard more than `timeout_s`
// before a query is stale: that query gets no step (nullopt: the filter's own step
// distribution, as without odometry), and the step after odometry comes back starts afresh
// (the motion of the gap is not added on top of the steps the filter already predicted).
//
// Times are seconds on one clock of the caller's choice. Not thread-safe.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>

namespace bsf_vpr {

class OdometryProgress {
 public:
  enum class State {
    kNone,       // nothing heard yet
    kFresh,      // heard within timeout_s
    kStale,      // last heard more than timeout_s ago
  };

  explicit OdometryProgress(double timeout_s) : timeout_s_(timeout_s) {}

  // A position heard at `time_s`. False, counted and left out when a coordinate is not
  // finite.
  bool Hear(const Eigen::Vector3d& position, double time_s) {
    if (!position.allFinite()) {
      ++refused_;
      return false;
    }
    latest_ = position;
    latest_time_s_ = time_s;
    return true;
  }

  // The distance travelled since the previous step, in places (metres / spacing_m), and
  // moves the reference position on. nullopt at the first step, after stale odometry,
  // without odometry, and without a spacing (spacing_m <= 0; then nothing moves on).
  std::optional<double> StepPlaces(double now_s, double spacing_m) {
    if (StateAt(now_s) != State::kFresh) {
      if (latest_) ++stale_steps_;
      at_last_step_.reset();  // the step after the gap starts afresh
      return std::nullopt;
    }
    if (!(spacing_m > 0)) return std::nullopt;
    std::optional<double> step;
    if (at_last_step_) step = (*latest_ - *at_last_step_).norm() / spacing_m;
    at_last_step_ = latest_;
    return step;
  }

  State StateAt(double now_s) const {
    if (!latest_) return State::kNone;
    return now_s - latest_time_s_ > timeout_s_ ? State::kStale : State::kFresh;
  }
  // Seconds since the latest position (nullopt before any).
  std::optional<double> AgeAt(double now_s) const {
    if (!latest_) return std::nullopt;
    return now_s - latest_time_s_;
  }
  double timeout_s() const { return timeout_s_; }
  uint64_t refused() const { return refused_; }            // not finite, since construction
  uint64_t stale_steps() const { return stale_steps_; }    // steps on stale odometry

 private:
  double timeout_s_;
  std::optional<Eigen::Vector3d> latest_;
  double latest_time_s_ = 0;
  std::optional<Eigen::Vector3d> at_last_step_;  // where the previous step was taken
  uint64_t refused_ = 0, stale_steps_ = 0;
};

}  // namespace bsf_vpr
