#include "bsf_vpr/map/map_calibrator.h"

#include <cstdio>
#include <exception>

namespace bsf_vpr {

std::optional<CalibrationRequest> CalibrationRequestOf(const RecognizerOptions& options) {
  if (options.calibration.max_false_accept_rate == 0) return std::nullopt;
  return CalibrationRequest{options.method, options.method_options,
                            options.calibration.max_false_accept_rate};
}

bool operator==(const CalibrationRequest& a, const CalibrationRequest& b) {
  return a.method == b.method && a.max_false_accept_rate == b.max_false_accept_rate &&
         MethodOptionsTable().Values(a.options) == MethodOptionsTable().Values(b.options);
}

MapCalibrator::~MapCalibrator() {
  MutexLock lock(&mutex_);
  if (cancel_) *cancel_ = true;  // a running calibration stops at its next stream
}

bool MapCalibrator::SetRequest(std::optional<CalibrationRequest> request) {
  MutexLock lock(&mutex_);
  if (request.has_value() == request_.has_value() && (!request || *request == *request_)) {
    return false;
  }
  request_ = std::move(request);
  ++request_id_;  // a calibration for the previous request is not taken
  if (cancel_) *cancel_ = true;
  if (!request_) latest_.reset();  // else it answers until the new one is done
  failed_.clear();
  return true;
}

void MapCalibrator::Calibrate(const ReferenceSets& map, DistanceMetric metric,
                              uint64_t generation) {
  MutexLock lock(&mutex_);
  if (cancel_) *cancel_ = true;  // the sets changed: what runs is for others
  if (!request_ || map.num_sets() == 0) {
    ++request_id_;  // nor is one still running for sets that are gone
    latest_.reset();
    return;
  }
  std::vector<StoredReferenceSet> sets = map.sets();  // copies share their rows
  const double place_pose_tolerance_m = map.place_pose_tolerance_m();
  const CalibrationRequest request = *request_;
  const uint64_t id = request_id_;
  cancel_ = std::make_shared<std::atomic<bool>>(false);
  running_ = "calibrating " + std::to_string(sets.size()) + " set(s) for " + request.method;
  job_.Ask([this, sets = std::move(sets), metric, place_pose_tolerance_m, generation, request, id,
            cancel = cancel_]() mutable {
    std::shared_ptr<const MapCalibration> done;
    std::string error;
    try {
      ReferenceSets map;
      map.SetStoragePrecision(sets.front().precision());
      map.SetPlacePoseTolerance(place_pose_tolerance_m);
      for (StoredReferenceSet& s : sets) map.Add(std::move(s));
      done = std::make_shared<const MapCalibration>(
          CalibrateMap(map, metric, request.method, request.options, request.max_false_accept_rate,
                       cancel.get()));
    } catch (const CalibrationCancelled&) {
      return;  // superseded
    } catch (const std::exception& e) {
      error = e.what();
    }
    MutexLock lock(&mutex_);
    if (id != request_id_) return;  // asked for something else since
    failed_ = error;
    if (done && (!latest_ || generation >= latest_generation_)) {
      latest_ = std::move(done);
      latest_generation_ = generation;
    }
  });
}

std::shared_ptr<const MapCalibration> MapCalibrator::latest() const {
  MutexLock lock(&mutex_);
  return latest_;
}

std::optional<AcceptanceRule> MapCalibrator::rule() const {
  MutexLock lock(&mutex_);
  if (!latest_ || !latest_->usable()) return std::nullopt;
  return latest_->rule;
}

std::string MapCalibrator::status() const {
  const bool busy = job_.busy();
  MutexLock lock(&mutex_);
  if (!request_) return "none asked for (max_false_accept_rate 0: the threshold alone)";
  std::string s;
  if (latest_) {
    char took[48];
    std::snprintf(took, sizeof took, " (%.1f s, layout %llu)", latest_->seconds,
                  static_cast<unsigned long long>(latest_generation_));
    s = latest_->Summary() + took;
  } else {
    s = "none yet";
  }
  if (!failed_.empty()) s += "; the last calibration failed: " + failed_;
  if (busy) s += "; " + running_ + (latest_ ? ", the last one answers meanwhile" : "");
  return s;
}

}  // namespace bsf_vpr
