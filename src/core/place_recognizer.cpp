#include "bsf_vpr/core/place_recognizer.h"

#include <algorithm>
#include <stdexcept>

namespace bsf_vpr {

void RecognizerOptions::Validate() const {
  method_options.Validate();
  first_stage.Validate();
}

const OptionTable<RecognizerOptions>& RecognizerOptionsTable() {
  static const OptionTable<RecognizerOptions> kTable =
      OptionTable<RecognizerOptions>()
          .Add(
              "method", [](auto& o) -> auto& { return o.method; },
              "bsf, bayes_full, med, med_selective, nn:<set> or bayes:<set>, or one of the "
              "descriptor-level methods mean_descriptor, union_nn, subspace, discriminant "
              "(sets of one descriptor that share places), optionally with +filter "
              "(temporal filter prior; the Bayesian ones) and/or +seq (sequence matching)",
              "", {}, /*live=*/true)
          .Include(
              MethodOptionsTable(), [](auto& o) -> auto& { return o.method_options; })
          .Include(
              FirstStageOptionsTable(), [](auto& o) -> auto& { return o.first_stage; });
  return kTable;
}

PlaceRecognizer::PlaceRecognizer(RecognizerOptions options)
    : options_(std::move(options)), decider_(options_.method, options_.method_options) {
  options_.Validate();
  distances_.SetOptions(options_.first_stage);
  // The method is checked against the sets when they are known (SetOptions / Recognize):
  // nn:<set> before its set is loaded is refused by Recognize until it is.
  decider_.OnLayoutChanged(map_.layout());
}

void PlaceRecognizer::SetOptions(const RecognizerOptions& options) {
  options.Validate();
  const bool metric_changed = options.metric != options_.metric;
  decider_.SetMethod(options.method, options.method_options, map_.layout());  // may throw
  distances_.SetOptions(options.first_stage);
  options_ = options;
  if (metric_changed) decider_.Reset();  // every distance changes: no history applies
}

void PlaceRecognizer::AddReferenceSet(ReferenceSet set) {
  map_.Add(std::move(set));
  ++generation_;
  distances_.Invalidate();
  decider_.OnLayoutChanged(map_.layout());
}

void PlaceRecognizer::RemoveReferenceSet(const std::string& name) {
  CheckRemovable(name);
  map_.Remove(name);
  ++generation_;
  distances_.Invalidate();
  decider_.OnLayoutChanged(map_.layout());
}

void PlaceRecognizer::CheckRemovable(const std::string& name) const {
  if (map_.IndexOf(name) < 0) {
    throw std::invalid_argument("no reference set named '" + name + "' is loaded");
  }
  decider_.CheckRemovable(name);
}

void PlaceRecognizer::ResetPrior() { decider_.Reset(); }

Recognition PlaceRecognizer::Recognize(const Eigen::Ref<const Eigen::VectorXf>& descriptor,
                                       bool update_state, std::optional<double> step_places) {
  QueryDistances d = QueryDistances::AllPresent(Distances(descriptor));
  if (std::optional<QueryDistances::Joint> j = JointDistances(descriptor))
    d.SetJoint(std::move(*j));
  return Decide(d, update_state, step_places);
}

std::optional<QueryDistances::Joint> PlaceRecognizer::JointDistances(
    const Eigen::Ref<const Eigen::VectorXf>& descriptor) {
  const std::optional<JointKind> kind = decider_.method().JointNeeded(options_.method_options);
  if (!kind) return std::nullopt;
  const JointOptions& o = options_.method_options.joint;
  if (!joint_ || joint_->kind() != *kind || joint_->num_places() != map_.num_places() ||
      joint_options_.discriminant_dimensions != o.discriminant_dimensions ||
      joint_options_.discriminant_ridge != o.discriminant_ridge ||
      joint_generation_ != generation_) {
    joint_.reset();
    std::vector<const StoredReferenceSet*> sets;
    for (const StoredReferenceSet& s : map_.sets()) sets.push_back(&s);
    try {
      CheckJointSets(sets, map_.num_places());
    } catch (const std::invalid_argument&) {
      return std::nullopt;  // sets that make none: bsf fuses them alone
    }
    joint_ = std::make_shared<const JointRepresentation>(
        JointRepresentation::Build(*kind, sets, map_.num_places(), o));
    joint_options_ = o;
    joint_generation_ = generation_;
    ++joint_builds_;
  }
  map_.CheckQuery(descriptor);
  return QueryDistances::Joint{*kind, joint_builds_, joint_->Distances(descriptor.transpose())};
}

Recognition PlaceRecognizer::Decide(const QueryDistances& distances, bool update_state,
                                    std::optional<double> step_places) {
  return decider_.Decide(map_.layout(), distances, update_state, step_places);
}

std::vector<RowMatrixXf> PlaceRecognizer::Distances(
    const Eigen::Ref<const Eigen::VectorXf>& descriptor) {
  map_.CheckQuery(descriptor);
  const RowMatrixXf query = descriptor.transpose();
  return distances_.Distances(options_.metric, query, map_);
}

}  // namespace bsf_vpr
