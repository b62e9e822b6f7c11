// The fusion node: recognises the place of every descriptor that arrives and publishes the
// belief, the accepted matches, a tf frame for the matched place, the robot's pose, rviz
// markers and diagnostics. Services list, load and unload reference sets, answer what-if
// queries, and record a new set from the incoming descriptors.
//
// The sets and each query's distances to them are the map's (MapBackend: the node's own
// sets, LocalMap, or a sharded map's, ShardedMap). The node is handed the factory of its map
// (MakeFusionNode gives it make_map.h's, which picks one from the parameters; a test gives
// it a fake one) and decides (PlaceDecider) on the map's layout and publishes. It wires
// the parts beside it: RecognitionPublisher (the messages and tf of each query), Recording
// (start_recording / stop_recording), OdometryTracker, RobotPoseSource and
// SelectionCounters; the service handlers are in fusion_services.cpp.
//
// Used by the fusion nodelet and by the plain fusion node (fusion_node_main.cpp).
// Every callback takes mutex_ for the decision and the node's state: services and
// reconfiguration may run while descriptors stream in, from any thread. The map's slow work
// (files, shards) runs without it; a local map's distances under it. load_reference_set and
// unload_reference_set run on a queue and thread of their own, query_place on another, so
// that neither a large load nor a slow shard stops recognition. Which member mutex_ guards
// and which function needs it held is annotated (GUARDED_BY, REQUIRES) and checked by clang
// (docs/architecture.md, "Threads").
#pragma once

#include <bsf_vpr/Descriptor.h>
#include <bsf_vpr/DescriptorFormat.h>
#include <bsf_vpr/FusionConfig.h>
#include <bsf_vpr/InputDropped.h>
#include <bsf_vpr/GetSelectionStatistics.h>
#include <bsf_vpr/ListReferenceSets.h>
#include <bsf_vpr/LoadReferenceSet.h>
#include <bsf_vpr/QueryPlace.h>
#include <bsf_vpr/StartRecording.h>
#include <bsf_vpr/StopRecording.h>
#include <bsf_vpr/UnloadReferenceSet.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <ros/spinner.h>
#include <sensor_msgs/Image.h>

#include <Eigen/Core>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/core/place_decider.h"
#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/map/map_backend.h"
#include "src/ros/common/sequence_gaps.h"
#include "src/ros/fusion/busy_sets.h"
#include "src/ros/fusion/fusion_params.h"
#include "src/ros/fusion/odometry_tracker.h"
#include "src/ros/fusion/recognition_publisher.h"
#include "src/ros/fusion/recording.h"
#include "src/ros/fusion/robot_pose.h"
#include "src/ros/fusion/selection_counters.h"

namespace bsf_vpr {

class FusionNode {
 public:
  // Makes the node's map from its parameters, over its data directory (null: none), once
  // the directory's interrupted saves are recovered. Throws std::exception naming what keeps
  // the map from being made; the node then does not start.
  using MapFactory = std::function<std::unique_ptr<MapBackend>(const FusionParams& params,
                                                               const DataDirectory* data_dir)>;

  FusionNode(ros::NodeHandle nh, ros::NodeHandle pnh, MapFactory make_map);
  ~FusionNode();

  // Reads the parameters and makes the map (which loads the configured reference sets), then
  // starts listening. Throws std::exception with a message naming the problem if the node
  // cannot start.
  void Start();

 private:
  // Start's part under the lock: the recording, the decider on the map's layout, the
  // publisher, odometry, the robot's pose and the services.
  void StartParts() REQUIRES(mutex_);
  void OnDescriptor(const ros::MessageEvent<const Descriptor>& event) EXCLUDES(mutex_);
  // Decides `query` and publishes the belief; the recognition, or nullopt when it was
  // dropped (reported). Adopts the query's layout first if the map's changed. Caller holds
  // mutex_.
  std::optional<Recognition> DecideAndPublish(MapBackend::Query& query) REQUIRES(mutex_);
  // Makes `layout` the one decided on if it is newer than the one in use: the method is
  // resolved against its sets and the belief starts afresh. False when it is older (a
  // superseded layout). Caller holds mutex_.
  bool AdoptLayout(MapBackend::Layout layout) REQUIRES(mutex_);
  // Adds a descriptor to the recording; what it refuses is reported, recognition goes on.
  // Caller holds mutex_.
  void Record(const Eigen::Ref<const Eigen::VectorXf>& d, const std::string& type,
              const std::optional<PlacePose>& pose, const std::optional<LocalizedPlace>& localized,
              double stamp_s) REQUIRES(mutex_);
  // The progress since the previous query in places, from odometry (nullopt without).
  // Caller holds mutex_.
  std::optional<double> OdometryStep(const ros::Time& stamp) REQUIRES(mutex_);
  // The distance between places in metres: place_spacing_m, or the median spacing of the
  // loaded place poses, or 1. Caller holds mutex_.
  double PlaceSpacing() const REQUIRES(mutex_);
  // The recognizer's options as they are in force (the parameters, with the live ones the
  // decider holds). Caller holds mutex_.
  RecognizerOptions OptionsInForce() const REQUIRES(mutex_);
  void OnReconfigure(FusionConfig& config, uint32_t level) EXCLUDES(mutex_);
  void Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) EXCLUDES(mutex_);
  // The diagnostics' level and summary: the most pressing problem, or OK.
  void DiagnoseSummary(diagnostic_updater::DiagnosticStatusWrapper& status) REQUIRES(mutex_);
  void RejectMessage(const std::string& why) REQUIRES(mutex_);
  // An input the ingest dropped (InputDropped): why no belief may follow.
  void OnInputDropped(const InputDropped::ConstPtr& msg) EXCLUDES(mutex_);
  // What is known of the inputs since the last belief, for "no belief for X s: ...".
  std::string WhyNoBelief() const REQUIRES(mutex_);

  bool OnList(ListReferenceSets::Request& req, ListReferenceSets::Response& res);
  bool OnLoad(LoadReferenceSet::Request& req, LoadReferenceSet::Response& res) EXCLUDES(mutex_);
  bool OnUnload(UnloadReferenceSet::Request& req, UnloadReferenceSet::Response& res)
      EXCLUDES(mutex_);
  bool OnQuery(QueryPlace::Request& req, QueryPlace::Response& res) EXCLUDES(mutex_);
  bool OnStartRecording(StartRecording::Request& req, StartRecording::Response& res)
      EXCLUDES(mutex_);
  bool OnStopRecording(StopRecording::Request& req, StopRecording::Response& res) EXCLUDES(mutex_);
  // A stopped recording saved: loaded into the map, the answer filled.
  void LoadRecorded(Recording::Saved saved, const std::string& summary,
                    StopRecording::Response* res) EXCLUDES(mutex_);
  bool OnStatistics(GetSelectionStatistics::Request& req, GetSelectionStatistics::Response& res)
      EXCLUDES(mutex_);

  // Warns (log and diagnostics) when a descriptor's type differs from the loaded sets'.
  void CheckDescriptorType(const std::string& type) REQUIRES(mutex_);
  // The ingest's announced format (DescriptorFormat, latched) against the loaded sets: a
  // dimension they do not have is an ERROR in the log and diagnostics at once, before any
  // descriptor. Called when the format arrives and whenever the sets change; caller holds
  // mutex_.
  void OnDescriptorFormat(const DescriptorFormat::ConstPtr& msg) EXCLUDES(mutex_);
  void CheckDescriptorFormat() REQUIRES(mutex_);
  // Recording with save_images: the camera images, encoded and handed to the recording.
  void OnRecordingImage(const sensor_msgs::ImageConstPtr& msg) EXCLUDES(mutex_);
  // Subscribes to the images while a recording takes them, and not otherwise. Caller holds
  // mutex_, and shuts the subscription returned (the one ended, if any) down after
  // releasing it: shutdown waits for a running OnRecordingImage, which takes mutex_.
  ros::Subscriber FollowRecordingImages() REQUIRES(mutex_);

  ros::NodeHandle nh_, pnh_;
  const MapFactory make_map_;
  // As read at start; what changes later is the decider's or the map's. Written by Start
  // alone, before any callback: read without the lock.
  FusionParams params_;
  Mutex mutex_;
  std::unique_ptr<DataDirectory> data_dir_;  // null: the file services are off
  std::set<std::string> keep_;  // the configured sets' files below data_dir_: never removed
  // Over data_dir_; thread-safe itself, called without mutex_ for its slow work.
  std::unique_ptr<MapBackend> map_;
  MapBackend::Layout layout_ GUARDED_BY(mutex_);  // the map's layout the decider is on
  PlaceDecider decider_ GUARDED_BY(mutex_);
  // The stamp of the last query decided: a query stamped more than kTimeJumpBackS before it
  // (a bag played again, a simulation restarted) starts the carried belief afresh.
  ros::Time last_query_stamp_ GUARDED_BY(mutex_);
  // The times it did (diagnostics).
  uint64_t time_jumps_ GUARDED_BY(mutex_) = 0;
  std::unique_ptr<Recording> recording_ PT_GUARDED_BY(mutex_);  // over data_dir_
  // load_reference_set's and unload_reference_set's queue and thread, and query_place's.
  ros::CallbackQueue load_queue_, query_queue_;
  std::unique_ptr<ros::AsyncSpinner> load_spinner_, query_spinner_;

  ros::Subscriber descriptor_sub_;
  ros::Subscriber format_sub_;
  ros::Subscriber dropped_sub_;  // the ingest's InputDropped
  // While a recording with save_images runs.
  ros::Subscriber recording_image_sub_ GUARDED_BY(mutex_);
  DescriptorFormat::ConstPtr format_ GUARDED_BY(mutex_);  // the ingest's, once heard
  std::unique_ptr<RecognitionPublisher> publisher_ PT_GUARDED_BY(mutex_);
  std::vector<ros::ServiceServer> services_;
  std::unique_ptr<OdometryTracker> odometry_;    // thread-safe itself
  std::unique_ptr<RobotPoseSource> robot_pose_;  // for recording by pose; thread-safe itself
  std::unique_ptr<dynamic_reconfigure::Server<FusionConfig>> reconfigure_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::Timer diagnostics_timer_;

  // Statistics since the last diagnostics update.
  int processed_ GUARDED_BY(mutex_) = 0;
  int rejected_ GUARDED_BY(mutex_) = 0;
  int received_ GUARDED_BY(mutex_) = 0;
  // Descriptors lost to a full queue before this node saw them (header.seq gaps): in the
  // last diagnostics period, and since start.
  uint64_t lost_ GUARDED_BY(mutex_) = 0;
  uint64_t lost_total_ GUARDED_BY(mutex_) = 0;
  // Queries decided on a layout the map had changed since.
  uint64_t superseded_ GUARDED_BY(mutex_) = 0;
  SequenceGaps sequence_gaps_ GUARDED_BY(mutex_);
  // Since start: descriptors received and dropped as bad (every descriptor received becomes
  // a belief, or is dropped as bad, or its layout was superseded; those a full queue lost
  // are lost_total_).
  uint64_t received_total_ GUARDED_BY(mutex_) = 0;
  uint64_t rejected_total_ GUARDED_BY(mutex_) = 0;
  // Since the last belief: descriptors received, refused, and the inputs the ingest
  // dropped, with the last drop's words.
  uint64_t received_since_belief_ GUARDED_BY(mutex_) = 0;
  uint64_t refused_since_belief_ GUARDED_BY(mutex_) = 0;
  uint64_t dropped_since_belief_ GUARDED_BY(mutex_) = 0;
  std::string last_drop_ GUARDED_BY(mutex_);
  // Recording by pose: descriptors without a pose, by cause (since start).
  std::map<std::string, long> pose_losses_ GUARDED_BY(mutex_);
  // Why the descriptors the ingest announces cannot match the loaded sets ("" if they can).
  std::string format_mismatch_ GUARDED_BY(mutex_);
  // Sets being loaded (read, not yet in the map) or unloaded, so that another load, a
  // recording or a method cannot take their names meanwhile.
  BusySets busy_ GUARDED_BY(mutex_);
  double processing_s_sum_ GUARDED_BY(mutex_) = 0;
  double processing_s_max_ GUARDED_BY(mutex_) = 0;
  std::string last_rejection_ GUARDED_BY(mutex_);
  // "" since the last reconfiguration taken.
  std::string last_reconfigure_refusal_ GUARDED_BY(mutex_);
  // The last descriptor_type that differs from the sets'.
  std::string type_mismatch_ GUARDED_BY(mutex_);
  SelectionCounters counters_ GUARDED_BY(mutex_);  // since start or the last statistics reset
  ros::WallTime last_diagnostics_ GUARDED_BY(mutex_);
};

// The fusion node over the map its parameters name (MakeMap): what the nodelet and the plain
// node run.
std::unique_ptr<FusionNode> MakeFusionNode(ros::NodeHandle nh, ros::NodeHandle pnh);

}  // namespace bsf_vpr
