#include "src/ros/fusion/fusion_node.h"

#include <cv_bridge/cv_bridge.h>

#include <chrono>
#include <opencv2/imgcodecs.hpp>

#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "bsf_vpr/map/set_loading.h"
#include "bsf_vpr/ros/names.h"
#include "src/ros/common/conversions.h"
#include "src/ros/common/image_problem.h"
#include "src/ros/common/service_queue.h"
#include "src/ros/fusion/reconfigure_options.h"
#include "src/ros/map/configured_paths.h"

namespace bsf_vpr {
namespace {

// A query this far before the previous one is another drive's (FusionNode::last_query_stamp_);
// a little earlier is a reordering (two publishers) and is decided on.
constexpr double kTimeJumpBackS = 1.0;

}  // namespace

FusionNode::FusionNode(ros::NodeHandle nh, ros::NodeHandle pnh, MapFactory make_map)
    : nh_(std::move(nh)), pnh_(std::move(pnh)), make_map_(std::move(make_map)) {}

FusionNode::~FusionNode() {
  // No callback may run on parts about to be destroyed (a nodelet unloaded while a
  // descriptor waits for its pose on another thread): shutdown waits for a running one.
  descriptor_sub_.shutdown();
  recording_image_sub_.shutdown();
  format_sub_.shutdown();
  dropped_sub_.shutdown();
  diagnostics_timer_.stop();
  services_.clear();
  if (load_spinner_) load_spinner_->stop();
  if (query_spinner_) query_spinner_->stop();
  map_.reset();  // its threads call back into the node
}

void FusionNode::Start() {
  params_ = LoadFusionParams(pnh_);
  if (!params_.data_directory.empty()) {
    data_dir_ = std::make_unique<DataDirectory>(params_.data_directory, /*create=*/true);
    // The configured sets' files are never removed, wherever their YAML lies.
    std::vector<std::string> configured;
    for (const ReferenceSetEntry& e : params_.reference_sets) {
      try {
        configured.push_back(ResolveConfiguredPath(data_dir_->path(), e.path));
      } catch (const std::exception&) {
        // Refused with its message when the map loads it.
      }
    }
    keep_ = FilesOfReferenceSets(*data_dir_, configured);
    // A save killed on the way (kill -9, a power cut) is finished or undone by its journal;
    // nothing else is removed, whatever its name or age.
    for (const std::string& line : RecoverInterruptedSaves(*data_dir_, keep_)) {
      ROS_WARN("bsf_vpr: %s: %s", data_dir_->path().c_str(), line.c_str());
    }
    const std::vector<std::string> stale = data_dir_->Temporaries();
    if (!stale.empty()) {
      std::string names;
      for (size_t i = 0; i < stale.size() && i < 10; ++i) names += (i ? ", " : "") + stale[i];
      ROS_WARN("bsf_vpr: %s holds %zu file(s) named like the temporaries of an interrupted write "
               "(%s%s) that no journal of a save names: left as they are; remove them by hand "
               "if they are not yours",
               data_dir_->path().c_str(), stale.size(), names.c_str(),
               stale.size() > 10 ? ", ..." : "");
    }
  }
  map_ = make_map_(params_, data_dir_.get());  // calls back only once started, below
  {
    // The services' callbacks wait for it; released before the reconfiguration server calls
    // back (on this thread).
    MutexLock lock(&mutex_);
    StartParts();
  }
  reconfigure_ = std::make_unique<dynamic_reconfigure::Server<FusionConfig>>(pnh_);
  reconfigure_->setCallback(
      [this](FusionConfig& config, uint32_t level) { OnReconfigure(config, level); });

  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh_, pnh_);
  diagnostics_->setHardwareID("bsf_vpr");
  diagnostics_->add("fusion", this, &FusionNode::Diagnose);
  diagnostics_timer_ = nh_.createTimer(ros::Duration(0.1), [this](const ros::TimerEvent&) {
    {
      // Beliefs that stopped coming: not localised, with what is known of the inputs.
      MutexLock lock(&mutex_);
      publisher_->CheckStale(ros::Time::now(), WhyNoBelief());
    }
    diagnostics_->update();  // publishes at ~diagnostic_period
  });

  // Last: everything the map's callbacks and the descriptors use exists.
  MapBackend::Callbacks callbacks;
  callbacks.query = [this](MapBackend::Query& query) {
    MutexLock lock(&mutex_);
    DecideAndPublish(query);
  };
  callbacks.reject = [this](const std::string& why) {
    MutexLock lock(&mutex_);
    RejectMessage(why);
  };
  callbacks.layout = [this](MapBackend::Layout layout) {
    MutexLock lock(&mutex_);
    AdoptLayout(std::move(layout));
  };
  map_->Start(std::move(callbacks));
  format_sub_ =
      nh_.subscribe(names::kDescriptorFormatTopic, 1, &FusionNode::OnDescriptorFormat, this);
  dropped_sub_ = nh_.subscribe(names::kInputDroppedTopic, 100, &FusionNode::OnInputDropped, this);
  // Always subscribed: the belief is state that must follow every query (a sharded map only
  // notes the stamp: its shards hear the descriptors themselves).
  descriptor_sub_ =
      nh_.subscribe(names::kDescriptorTopic, static_cast<uint32_t>(params_.queue_size),
                    &FusionNode::OnDescriptor, this);
  MutexLock lock(&mutex_);
  ROS_INFO("bsf_vpr: fusion ready: method %s, %d reference set(s), %d places",
           params_.recognizer.method.c_str(), layout_->num_sets(), layout_->num_places());
}

void FusionNode::StartParts() {
  recording_ = std::make_unique<Recording>(
      data_dir_.get(), RecordingLimits{params_.recording_max_descriptors,
                                       int64_t{params_.recording_max_megabytes} * 1000000});
  recording_->set_keep(keep_);
  decider_ = PlaceDecider(params_.recognizer.method, params_.recognizer.method_options);
  layout_ = map_->layout();
  decider_.OnLayoutChanged(*layout_);
  // Checks the method against the sets.
  decider_.SetMethod(params_.recognizer.method, params_.recognizer.method_options, *layout_);
  const Method& method = decider_.method();
  map_->SetJoint(method.JointNeeded(params_.recognizer.method_options),
                 params_.recognizer.method_options.joint);
  map_->SetCalibration(CalibrationRequestOf(params_.recognizer));
  // The configured sets' joint representation before the first descriptor, so that a replay
  // decides its first queries as the offline evaluation does (later changes of sets rebuild
  // it in the background).
  map_->WaitForJoint();
  if (!method.IsBayesian() && !method.sequence &&
      params_.recognizer.method_options.decision.max_match_distance == 0) {
    ROS_WARN(
        "bsf_vpr: method %s is gated by max_match_distance, which is 0: only a query "
        "identical to a reference is accepted; set it to the largest distance to accept",
        params_.recognizer.method.c_str());
  }

  const RecognitionPublisherOptions& publishing = params_;  // the parameters' own part
  publisher_ = std::make_unique<RecognitionPublisher>(nh_, pnh_, publishing, data_dir_.get());
  odometry_ = std::make_unique<OdometryTracker>(
      nh_, params_.odometry_source, params_.odometry_topic, params_.odom_frame, params_.base_frame,
      params_.odometry_timeout_s);
  RobotPoseOptions pose_options;
  pose_options.source = params_.pose_source;
  pose_options.topic = params_.pose_topic;
  pose_options.map_frame = params_.map_frame;
  pose_options.base_frame = params_.base_frame;
  robot_pose_ = std::make_unique<RobotPoseSource>(nh_, pose_options);
  services_.push_back(
      nh_.advertiseService(names::kListReferenceSetsService, &FusionNode::OnList, this));
  {
    // Its own queue and thread: reading a large set must not hold up the descriptors.
    services_.push_back(AdvertiseOnQueue<LoadReferenceSet>(
        nh_, names::kLoadReferenceSetService, &FusionNode::OnLoad, this, &load_queue_));
    // On the same thread: a sharded map's waits for the shard's new shard_info, which
    // arrives on the node's own queue.
    services_.push_back(AdvertiseOnQueue<UnloadReferenceSet>(
        nh_, names::kUnloadReferenceSetService, &FusionNode::OnUnload, this, &load_queue_));
    // Two threads: a sharded map's loads and unloads wait for shards, and one stalled shard
    // must not hold up a load to another; a local map's loads take its lock in turn.
    load_spinner_ = std::make_unique<ros::AsyncSpinner>(2, &load_queue_);
    load_spinner_->start();
  }
  // query_place on a queue and thread of its own: a sharded map's calls every shard, and a
  // shard that does not answer must hold up neither the descriptors nor a load.
  services_.push_back(AdvertiseOnQueue<QueryPlace>(nh_, names::kQueryPlaceService,
                                                   &FusionNode::OnQuery, this, &query_queue_));
  query_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &query_queue_);
  query_spinner_->start();
  services_.push_back(
      nh_.advertiseService(names::kStartRecordingService, &FusionNode::OnStartRecording, this));
  // On the load queue's thread: a stop builds, writes and loads the set (seconds for a long
  // recording) while the descriptors go on.
  services_.push_back(AdvertiseOnQueue<StopRecording>(
      nh_, names::kStopRecordingService, &FusionNode::OnStopRecording, this, &load_queue_));
  services_.push_back(
      nh_.advertiseService(names::kSelectionStatisticsService, &FusionNode::OnStatistics, this));

  last_diagnostics_ = ros::WallTime::now();
}

void FusionNode::RejectMessage(const std::string& why) {
  ++rejected_;
  ++rejected_total_;
  ++refused_since_belief_;
  last_rejection_ = why;
  ROS_ERROR_THROTTLE(1.0, "bsf_vpr: dropped a descriptor: %s", why.c_str());
}

void FusionNode::OnInputDropped(const InputDropped::ConstPtr& msg) {
  MutexLock lock(&mutex_);
  ++dropped_since_belief_;
  last_drop_ = msg->detail.empty() ? msg->cause : msg->detail;
}

std::string FusionNode::WhyNoBelief() const {
  std::string why;
  if (dropped_since_belief_ > 0) {
    why = "the ingest dropped " + std::to_string(dropped_since_belief_) +
          " input(s) since the last (" + last_drop_ + ")";
  }
  if (refused_since_belief_ > 0) {
    why += std::string(why.empty() ? "" : "; ") + "refused " +
           std::to_string(refused_since_belief_) + " descriptor(s) since the last (" +
           last_rejection_ + ")";
  }
  if (why.empty()) {
    why = received_since_belief_ > 0
              ? std::to_string(received_since_belief_) +
                    " descriptor(s) received since the last, none decided"
              : "no descriptor since the last (is the camera or the ingest running?)";
  }
  return why;
}

void FusionNode::OnDescriptorFormat(const DescriptorFormat::ConstPtr& msg) {
  MutexLock lock(&mutex_);
  format_ = msg;
  CheckDescriptorFormat();
}

void FusionNode::CheckDescriptorFormat() {
  const PlaceLayout& places = *layout_;
  std::string problem;
  if (format_ && format_->dimension > 0 && places.num_sets() > 0 &&
      places.dimension() != format_->dimension) {
    std::string types;
    for (const SetLayout& s : places.sets()) {
      if (!s.descriptor_type.empty() && types.find(s.descriptor_type) == std::string::npos) {
        types += (types.empty() ? "" : ", ") + s.descriptor_type;
      }
    }
    problem =
        "descriptor_ingest sends " + std::to_string(format_->dimension) + "-d " +
        (format_->descriptor_type.empty() ? std::string("descriptors")
                                          : "'" + format_->descriptor_type + "' descriptors") +
        " (" + format_->source + "); the reference sets hold " +
        std::to_string(places.dimension()) + "-d ones" + (types.empty() ? "" : " (" + types + ")") +
        ": no descriptor can be recognised. Load sets made with the ingest's describer "
        "(bsf_make_reference --images <folder> --image-descriptor <the ingest's "
        "image_descriptor>), or give the ingest the sets' describer or input:=descriptor";
  }
  if (problem != format_mismatch_ && !problem.empty()) ROS_ERROR("bsf_vpr: %s", problem.c_str());
  if (problem.empty() && !format_mismatch_.empty()) {
    ROS_INFO("bsf_vpr: the reference sets now match the ingest's descriptors");
  }
  format_mismatch_ = problem;
}

ros::Subscriber FusionNode::FollowRecordingImages() {
  const bool wanted = recording_->accepting() && recording_->saves_images();
  if (wanted && !recording_image_sub_) {
    recording_image_sub_ =
        nh_.subscribe(names::kImageTopic, 10, &FusionNode::OnRecordingImage, this);
  }
  ros::Subscriber ended;
  if (!wanted) std::swap(ended, recording_image_sub_);
  return ended;
}

void FusionNode::OnRecordingImage(const sensor_msgs::ImageConstPtr& msg) {
  // Encoded without the lock: recognition goes on meanwhile.
  std::vector<uchar> jpeg;
  try {
    if (!ImageProblem(*msg).empty()) return;  // the ingest reports bad images
    const cv_bridge::CvImageConstPtr cv = cv_bridge::toCvShare(msg, "bgr8");
    cv::imencode(".jpg", cv->image, jpeg, {cv::IMWRITE_JPEG_QUALITY, 90});
  } catch (const std::exception& e) {
    ROS_WARN_THROTTLE(5.0, "bsf_vpr: recording: cannot keep a camera image: %s", e.what());
    return;
  }
  MutexLock lock(&mutex_);
  recording_->AddImage(msg->header.stamp.toSec(), std::string(jpeg.begin(), jpeg.end()));
}

void FusionNode::CheckDescriptorType(const std::string& type) {
  const std::string mismatch = TypeMismatch(type, *layout_);
  if (mismatch.empty()) return;
  type_mismatch_ = mismatch;
  ROS_WARN_THROTTLE(5.0, "bsf_vpr: %s: the distances compare unlike descriptors",
                    type_mismatch_.c_str());
}

void FusionNode::OnDescriptor(const ros::MessageEvent<const Descriptor>& event) {
  const Descriptor::ConstPtr& msg = event.getConstMessage();
  // A recording by pose waits for the robot's pose at the descriptor's stamp (up to
  // pose_wait_s: a camera image is usually newer than the last pose), without the lock.
  // Other recordings take a pose only if there is one already.
  RecordingPlaces places = RecordingPlaces::kSequential;
  bool recording = false;
  {
    MutexLock lock(&mutex_);
    ++received_;
    ++received_total_;
    ++received_since_belief_;
    const uint64_t lost = sequence_gaps_.Note(event.getPublisherName(), msg->header.seq);
    lost_ += lost;
    lost_total_ += lost;
    recording = recording_->accepting();
    places = recording_->places();
  }
  PoseLookup pose;
  if (recording && places != RecordingPlaces::kLocalized) {
    pose = robot_pose_->PoseAt(msg->header.stamp,
                               places == RecordingPlaces::kPose ? params_.pose_wait_s : 0.0);
  }
  MutexLock lock(&mutex_);
  const Eigen::Map<const Eigen::VectorXf> d = DescriptorView(*msg);
  // Recording by localisation waits for the match; the other modes record every descriptor.
  const bool localized =
      recording_->accepting() && recording_->places() == RecordingPlaces::kLocalized;
  // (A recording that started or changed mode between the two locks takes the next one.)
  if (recording && recording_->accepting() && recording_->places() == places && !localized) {
    if (!pose.pose && recording_->places() == RecordingPlaces::kPose) {
      // Reported and counted by cause; recognition goes on.
      const std::string& cause = pose.cause;  // names what is missing
      recording_->NoteLost("no pose: " + cause);
      ++pose_losses_[cause];
      ROS_WARN_THROTTLE(1.0,
                        "bsf_vpr: recording by pose: no pose of the robot at the descriptor's "
                        "stamp from %s (%s: %s); not recorded",
                        robot_pose_->Describe().c_str(), cause.c_str(), pose.detail.c_str());
    } else {
      Record(d, msg->descriptor_type, pose.pose, std::nullopt, msg->header.stamp.toSec());
    }
  }
  CheckDescriptorType(msg->descriptor_type);
  // A map holding the sets answers now; a sharded map's query comes back through
  // DecideAndPublish once the shards answered.
  std::optional<MapBackend::Query> query;
  try {
    query = map_->Hear(ToQueryDescriptor(*msg));
  } catch (const std::exception& e) {
    // Without sets a recording still takes the descriptors.
    if (!(recording_->recording() && layout_->num_sets() == 0)) RejectMessage(e.what());
    return;
  }
  if (!query) return;
  const std::optional<Recognition> r = DecideAndPublish(*query);
  if (r && localized && r->belief.accepted) {
    Record(d, msg->descriptor_type, std::nullopt,
           LocalizedPlace{r->belief.match, r->belief.confidence}, msg->header.stamp.toSec());
  } else if (localized && recording_->accepting()) {
    recording_->NoteLost(r ? "not localised (no accepted match)" : "no belief for it");
  }
}

void FusionNode::Record(const Eigen::Ref<const Eigen::VectorXf>& d, const std::string& type,
                        const std::optional<PlacePose>& pose,
                        const std::optional<LocalizedPlace>& localized, double stamp_s) {
  // Reported; recognition goes on (a recording must not stop localisation).
  try {
    const std::string warning = recording_->Add(d, type, pose, localized, stamp_s);
    if (!warning.empty()) ROS_WARN("bsf_vpr: %s", warning.c_str());
  } catch (const RecordingFull& e) {
    ROS_WARN_THROTTLE(10.0, "bsf_vpr: %s", e.what());  // counted by the recording
  } catch (const std::exception& e) {
    RejectMessage(std::string("recording: ") + e.what());
  }
}

bool FusionNode::AdoptLayout(MapBackend::Layout layout) {
  if (layout->generation < layout_->generation) return false;  // superseded
  if (layout->generation == layout_->generation) return true;
  layout_ = std::move(layout);
  decider_.OnLayoutChanged(*layout_);
  if (!decider_.problem().empty()) {
    ROS_ERROR("bsf_vpr: the map's sets changed: %s", decider_.problem().c_str());
  }
  CheckDescriptorFormat();
  return true;
}

std::optional<Recognition> FusionNode::DecideAndPublish(MapBackend::Query& query) {
  // A query on a layout the map has changed since (a sharded map's answers queued while a
  // load went through) is not decided: its sets are not the ones the belief now follows.
  if (!AdoptLayout(query.layout)) {
    ++superseded_;  // counted: no belief for it
    return std::nullopt;
  }
  const ros::Time stamp(query.header.sec, query.header.nsec);
  // (A descriptor stamped 0, decided as of now, neither starts afresh nor moves the time.)
  if (!stamp.isZero()) {
    if (!last_query_stamp_.isZero() && (last_query_stamp_ - stamp).toSec() > kTimeJumpBackS) {
      // What the filter, the sequence matcher and the adaptive fusion carry belongs to another
      // drive, as tf's buffer does on a jump back.
      ROS_WARN_THROTTLE(1.0,
                        "bsf_vpr: the descriptors' time went back %.1f s (a bag played again, a "
                        "simulation restarted): the belief starts afresh",
                        (last_query_stamp_ - stamp).toSec());
      decider_.Reset();
      ++time_jumps_;
    }
    last_query_stamp_ = stamp;
  }
  const auto start = std::chrono::steady_clock::now();
  Recognition r;
  try {
    decider_.SetAcceptanceRule(query.acceptance_rule);
    r = decider_.Decide(*layout_, query.distances, true, OdometryStep(stamp));
  } catch (const std::exception& e) {
    RejectMessage(e.what());
    return std::nullopt;
  }
  // The core's own time: the map's distances and the decision here.
  const double seconds =
      query.seconds +
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ++processed_;
  processing_s_sum_ += seconds;
  processing_s_max_ = std::max(processing_s_max_, seconds);
  counters_.Count(r, *layout_);
  publisher_->Publish(ToHeaderMsg(query.header), r, *layout_, decider_, seconds);
  received_since_belief_ = refused_since_belief_ = dropped_since_belief_ = 0;
  return r;
}

std::optional<double> FusionNode::OdometryStep(const ros::Time& stamp) {
  const double spacing = params_.place_spacing_m > 0 ? params_.place_spacing_m
                                                     : layout_->MedianPlaceSpacing().value_or(0.0);
  return odometry_->StepPlaces(stamp, spacing);
}

double FusionNode::PlaceSpacing() const {
  if (params_.place_spacing_m > 0) return params_.place_spacing_m;
  const double median = layout_->MedianPlaceSpacing().value_or(1.0);
  return median > 0 ? median : 1.0;
}

RecognizerOptions FusionNode::OptionsInForce() const {
  RecognizerOptions o = params_.recognizer;
  o.method = decider_.method_name();
  o.method_options = decider_.method_options();
  o.metric = map_->metric();
  return o;
}

void FusionNode::OnReconfigure(FusionConfig& config, uint32_t /*level*/) {
  MutexLock lock(&mutex_);
  const OptionTable<RecognizerOptions>& table = RecognizerOptionsTable();
  dynamic_reconfigure::Config request;
  config.__toMessage__(request);
  NamedValueSource source(ValuesFromConfig(request), pnh_.getNamespace() + "/");
  const RecognizerOptions in_force = OptionsInForce();
  RecognizerOptions o = in_force;
  try {
    table.Apply(source, &o, /*live_only=*/true);  // refuses values out of the table's bounds
    Threshold& h = o.method_options.decision.threshold;
    const Threshold& before = in_force.method_options.decision.threshold;
    const bool kind_alone = h.kind != before.kind && h.value == before.value;
    h = ThresholdAsAsked(before, h);  // threshold_kind switched alone: the same threshold
    if (kind_alone) {
      ROS_INFO("bsf_vpr: threshold %g (%s) is %g as %s", before.value,
               ToString(before.kind).c_str(), h.value, ToString(h.kind).c_str());
    }
    o.Validate();
    if (!busy_.empty()) {  // a method of a set being unloaded (or loaded)
      const std::string set = ParseMethod(o.method, layout_->SetNames()).set_name;
      if (!set.empty()) busy_.Check(set);
    }
    decider_.SetMethod(o.method, o.method_options, *layout_);
    map_->SetJoint(decider_.method().JointNeeded(o.method_options), o.method_options.joint);
    params_.recognizer.calibration = o.calibration;
    map_->SetCalibration(CalibrationRequestOf(o));  // the map calibrates for these afresh
    last_reconfigure_refusal_.clear();
    ROS_INFO("bsf_vpr: reconfigured: method %s, gamma %.3f, %s selection, %s likelihood",
             o.method.c_str(), o.method_options.selection.gamma_fraction,
             ToString(o.method_options.selection.rule).c_str(),
             ToString(o.method_options.likelihood.variant).c_str());
  } catch (const std::exception& e) {
    last_reconfigure_refusal_ = e.what();
    ROS_ERROR("bsf_vpr: reconfiguration refused, keeping the previous settings: %s", e.what());
  }
  // Report what is in force (the previous values where the request was refused).
  dynamic_reconfigure::Config now = ConfigFromValues(table.Values(OptionsInForce(), true));
  config.__fromMessage__(now);
}

}  // namespace bsf_vpr
