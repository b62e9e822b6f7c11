#include "bsf_vpr/map/place_recognizer.h"

#include <stdexcept>

namespace bsf_vpr {

namespace {

LocalMapOptions MapOptionsOf(const RecognizerOptions& options, StoragePrecision storage) {
  LocalMapOptions out;
  out.metric = options.metric;
  out.storage = storage;
  out.first_stage = options.first_stage;
  return out;
}

bool SameFirstStage(const FirstStageOptions& a, const FirstStageOptions& b) {
  for (const auto& spec : FirstStageOptionsTable().specs()) {
    if (spec.get && !(spec.get(a) == spec.get(b))) return false;
  }
  return true;
}

}  // namespace

PlaceRecognizer::PlaceRecognizer(RecognizerOptions options, StoragePrecision storage)
    : options_(std::move(options)), decider_(options_.method, options_.method_options) {
  options_.Validate();
  map_ = std::make_unique<LocalMap>(MapOptionsOf(options_, storage), /*data_dir=*/nullptr);
  // The method is checked against the sets when they are known (SetOptions / Recognize):
  // nn:<set> before its set is loaded is refused by Recognize until it is.
  decider_.OnLayoutChanged(*map_->layout());
}

void PlaceRecognizer::SetOptions(const RecognizerOptions& options) {
  options.Validate();
  if (options.metric != options_.metric ||
      !SameFirstStage(options.first_stage, options_.first_stage)) {
    throw std::invalid_argument(
        "the distance and the first stage are the map's, fixed when the recogniser is made");
  }
  decider_.SetMethod(options.method, options.method_options, *map_->layout());  // may throw
  options_ = options;   // the joint representation it needs is asked for at the next query,
  calibrated_ = false;  // and so is the calibration
}

void PlaceRecognizer::AddReferenceSet(ReferenceSet set) {
  const std::string name = set.name;
  map_->SetJoint(std::nullopt, {});    // built once, at the next query, not after every set
  map_->SetCalibration(std::nullopt);  // the same
  calibrated_ = false;
  map_->Add(std::move(set), "'" + name + "'");
  decider_.OnLayoutChanged(*map_->layout());
}

void PlaceRecognizer::RemoveReferenceSet(const std::string& name) {
  decider_.CheckRemovable(name);
  map_->SetJoint(std::nullopt, {});
  map_->SetCalibration(std::nullopt);
  calibrated_ = false;
  map_->Unload(name);  // throws when it is not loaded
  decider_.OnLayoutChanged(*map_->layout());
}

std::shared_ptr<const ApproximateIndex> PlaceRecognizer::index() {
  Ready();
  return map_->index();
}

void PlaceRecognizer::Ready() {
  // The joint representation the method needs now, of the sets now (a no-op when the map
  // holds it already).
  map_->SetJoint(decider_.method().JointNeeded(options_.method_options),
                 options_.method_options.joint);
  map_->WaitForJoint();
  map_->WaitForIndex();
  if (!calibrated_) {  // the map's own rule, for the options and sets now
    map_->SetCalibration(CalibrationRequestOf(options_));
    map_->WaitForCalibration();
    calibrated_ = true;
  }
}

QueryDistances PlaceRecognizer::Distances(const Eigen::Ref<const Eigen::VectorXf>& descriptor) {
  Ready();
  QueryDescriptor query;
  query.values = descriptor.data();
  query.size = descriptor.size();
  return map_->Ask(query).distances;
}

Recognition PlaceRecognizer::Recognize(const Eigen::Ref<const Eigen::VectorXf>& descriptor,
                                       bool update_state, std::optional<double> step_places) {
  Ready();
  QueryDescriptor query;
  query.values = descriptor.data();
  query.size = descriptor.size();
  const MapBackend::Query q = map_->Ask(query);
  decider_.SetAcceptanceRule(q.acceptance_rule);
  return decider_.Decide(*q.layout, q.distances, update_state, step_places);
}

Recognition PlaceRecognizer::Decide(const QueryDistances& distances, bool update_state,
                                    std::optional<double> step_places) {
  decider_.SetAcceptanceRule(map_->acceptance_rule());
  return decider_.Decide(*map_->layout(), distances, update_state, step_places);
}

}  // namespace bsf_vpr
