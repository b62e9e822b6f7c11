// FusionNode's diagnostics: the summary (the most pressing problem) and the values.
#include <algorithm>
#include <string>

#include "src/ros/common/conversions.h"
#include "src/ros/fusion/fusion_node.h"

namespace bsf_vpr {

void FusionNode::Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  MutexLock lock(&mutex_);
  const ros::WallTime now = ros::WallTime::now();
  const double elapsed = std::max(1e-9, (now - last_diagnostics_).toSec());
  const PlaceLayout& places = *layout_;
  DiagnoseSummary(status);
  // What arrived, what was recognised and what was dropped, each a rate of its own: a
  // stream that arrives but is dropped whole shows as such.
  status.add("received rate (Hz)", received_ / elapsed);
  status.add("recognised rate (Hz)", processed_ / elapsed);
  status.add("dropped rate (Hz)", (rejected_ + static_cast<double>(lost_)) / elapsed);
  status.add("mean processing time (ms)", processed_ ? 1e3 * processing_s_sum_ / processed_ : 0.0);
  status.add("max processing time (ms)", 1e3 * processing_s_max_);
  // Every drop: the bad ones and those a full queue lost before this node saw them.
  status.add("dropped descriptors", rejected_ + lost_);
  status.add("dropped: bad", rejected_);
  status.add("dropped: queue overflow", lost_);
  status.add("dropped: queue overflow since start", lost_total_);
  status.add("dropped: the map's sets changed under the query since start", superseded_);
  // Since start, every descriptor by its fate: received = beliefs + bad + superseded (a
  // recording without sets aside); sent by the ingest = received + lost to the queue.
  status.add("received since start", received_total_);
  status.add("dropped: bad since start", rejected_total_);
  status.add("beliefs published", publisher_->beliefs_published());
  publisher_->Diagnose(status);
  status.add("method", decider_.method_name());
  if (!last_reconfigure_refusal_.empty()) {
    status.add("last reconfiguration refused", last_reconfigure_refusal_);
  }
  status.add("distance", ToString(map_->metric()));
  AddStatus(map_->Diagnose(), status);  // the first stage; a sharded map's shards
  odometry_->Diagnose(status);
  status.add("data directory", data_dir_ ? data_dir_->path() : "(none: file services off)");
  status.add("loaded reference sets", places.num_sets());
  status.add("places", places.num_places());
  status.add("belief started afresh, time went back", time_jumps_);
  for (const SetLayout& s : places.sets()) {
    const ReferenceSetUsage usage = counters_.Usage(s.name);
    status.addf("selected: " + s.name, "%.1f%% of %ld queries, mean weight %.3f",
                100.0 * usage.selected_fraction, counters_.queries(), usage.mean_weight);
  }
  recording_->Diagnose(status);
  for (const auto& [cause, n] : pose_losses_) {
    status.add("descriptors not recorded, no pose: " + cause, n);
  }
  processed_ = rejected_ = received_ = 0;
  lost_ = 0;
  type_mismatch_.clear();
  processing_s_sum_ = processing_s_max_ = 0;
  last_diagnostics_ = now;
}

void FusionNode::DiagnoseSummary(diagnostic_updater::DiagnosticStatusWrapper& status) {
  const std::string map_problem = map_->Problem();
  const std::string odometry_problem = odometry_->Problem();
  // Recording by pose while the poses fail (a frame missing, no publisher) keeps nothing.
  const std::string pose_problem =
      recording_->accepting() && recording_->places() == RecordingPlaces::kPose
          ? robot_pose_->Problem()
          : "";
  if (!format_mismatch_.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR, format_mismatch_);
  } else if (rejected_ > 0 && processed_ == 0) {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::ERROR, "every descriptor dropped (%d): %s",
                    rejected_, last_rejection_.c_str());
  } else if (!publisher_->stale().empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "not localised: " + publisher_->stale());
  } else if (lost_ > 0) {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                    "dropped %lu descriptor(s) to a full queue (queue_size %d): they arrive "
                    "faster than they are recognised",
                    static_cast<unsigned long>(lost_), params_.queue_size);
  } else if (rejected_ > 0) {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "dropped %d bad descriptor(s): %s",
                    rejected_, last_rejection_.c_str());
  } else if (!recording_->LimitProblem().empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "recording '" + recording_->name() + "' " + recording_->LimitProblem());
  } else if (!recording_->pending_reason().empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "recording '" + recording_->name() +
                       "' is pending after a failed stop: " + recording_->pending_reason());
  } else if (!pose_problem.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "recording '" + recording_->name() + "' by pose: " + pose_problem);
  } else if (!map_problem.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, map_problem);
  } else if (layout_->num_sets() == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no reference set loaded");
  } else if (!odometry_problem.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, odometry_problem);
  } else if (!type_mismatch_.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, type_mismatch_);
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "recognising places");
  }
}

}  // namespace bsf_vpr
