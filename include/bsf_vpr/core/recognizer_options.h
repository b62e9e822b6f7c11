// The options of a place recogniser: the method, its options and the first stage. The fusion
// node reads them as parameters (RecognizerOptionsTable), PlaceRecognizer (map/) is made with
// them.
#pragma once

#include <string>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/first_stage.h"
#include "bsf_vpr/core/methods.h"
#include "bsf_vpr/core/options.h"
#include "bsf_vpr/core/self_calibration.h"

namespace bsf_vpr {

struct RecognizerOptions {
  std::string method = "bsf";  // a method name, see methods.h (with +filter / +seq)
  DistanceMetric metric = DistanceMetric::kEuclidean;
  // The belief is carried between queries by the +filter suffix (method_options.filter);
  // without it every query has a uniform prior, the paper's single-image setting.
  MethodOptions method_options;
  // Exact distances, or the compressed first stage for large maps (first_stage.h).
  FirstStageOptions first_stage;
  // The map's own acceptance rule (self_calibration.h): max_false_accept_rate.
  CalibrationOptions calibration;

  void Validate() const;  // throws std::invalid_argument naming the bad field
};

// The options of RecognizerOptions: method, the MethodOptionsTable(), the first stage's and
// the calibration's (the metric is the loaded sets' own, chosen by whoever loads them).
const OptionTable<RecognizerOptions>& RecognizerOptionsTable();

}  // namespace bsf_vpr
