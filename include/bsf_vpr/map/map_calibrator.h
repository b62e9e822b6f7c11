// A map calibrating itself in the background (core/self_calibration.h): after every change
// of its sets and every new request, the latest calibration is run on a thread of its own
// with a snapshot of the sets (copies of StoredReferenceSet share their rows), and the one
// finished last answers meanwhile, as the joint representation is built (joint_builder.h).
//
// Thread-safe. It calls nothing of its owner, so its owner may call it under its own lock.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/latest_job.h"
#include "bsf_vpr/core/methods.h"
#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/core/recognizer_options.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/core/self_calibration.h"

namespace bsf_vpr {

// What a map calibrates itself for: the method and its options, and the rate.
struct CalibrationRequest {
  std::string method;
  MethodOptions options;
  double max_false_accept_rate = 0.01;
};

// Same method, option values and rate.
bool operator==(const CalibrationRequest& a, const CalibrationRequest& b);

// The request `options` make: their method, method options and max_false_accept_rate;
// nullopt where the rate is 0 (the threshold alone).
std::optional<CalibrationRequest> CalibrationRequestOf(const RecognizerOptions& options);

class MapCalibrator {
 public:
  MapCalibrator() = default;
  // Stops a running calibration at its next stream (and waits for it).
  ~MapCalibrator();
  MapCalibrator(const MapCalibrator&) = delete;
  MapCalibrator& operator=(const MapCalibrator&) = delete;

  // The request from now on (nullopt: none, and the calibration answering is dropped).
  // Returns whether it changed; a new request is calibrated at the next Calibrate, the last
  // calibration answering until then, and one still running for the old request stops.
  bool SetRequest(std::optional<CalibrationRequest> request);
  // Calibrates a snapshot of `map`'s sets (compared with `metric`) for the request in force,
  // on the calibrator's thread; `generation` names the layout. Nothing without a request
  // or without sets (the calibration answering is then dropped).
  void Calibrate(const ReferenceSets& map, DistanceMetric metric, uint64_t generation);

  // The calibration finished last for the request in force (null: none yet).
  std::shared_ptr<const MapCalibration> latest() const;
  // Its rule, where it vouches for one (MapCalibration::usable); else nullopt.
  std::optional<AcceptanceRule> rule() const;
  // One line for diagnostics and list_reference_sets: the latest summary, and what runs.
  std::string status() const;
  // Blocks until no calibration runs or waits (tests, benchmarks).
  void Wait() const { job_.Wait(); }

 private:
  mutable Mutex mutex_;
  std::optional<CalibrationRequest> request_ GUARDED_BY(mutex_);
  // Counts the requests and the resets: a calibration made under another is not taken.
  uint64_t request_id_ GUARDED_BY(mutex_) = 0;
  std::shared_ptr<const MapCalibration> latest_ GUARDED_BY(mutex_);
  uint64_t latest_generation_ GUARDED_BY(mutex_) = 0;
  std::shared_ptr<std::atomic<bool>> cancel_ GUARDED_BY(mutex_);  // the last job asked's
  std::string running_ GUARDED_BY(mutex_);                        // what the last job asked does
  std::string failed_ GUARDED_BY(mutex_);  // why the last run failed ("" if it did not)
  LatestJob job_;                          // last member: its thread ends first
};

}  // namespace bsf_vpr
