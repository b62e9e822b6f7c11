// descriptor_ingest: turns images (described with one of the core's image descriptors:
// patch-normalised, HOG or an ONNX network) or descriptor messages from another node (NetVLAD, ...)
// into validated bsf_vpr/Descriptor messages: non-empty, finite, not all zeros
// (QueryDescriptorProblem), of the expected dimension, optionally L2-normalised. Descriptors
// may come as bsf_vpr/Descriptor or std_msgs/Float32MultiArray (a 1-D array, as a Python node
// publishes it) on the same topic. Bad input (an image whose sizes do not fit its data, a
// blind image that shows nothing: uniform, or only noise (BlindImageProblem), a message of
// another type) is dropped with a throttled error and counted in diagnostics. It subscribes to
// its input only while someone listens to its output (a pure transform). With images it also
// publishes, while someone listens, the seconds each image took to check and describe on
// ~describe_time (std_msgs/Float64), before
// that image's descriptor: the core's own time for it, as Belief.processing_time is the fusion
// node's.
#pragma once

#include <bsf_vpr/Descriptor.h>
#include <bsf_vpr/DescriptorFormat.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/Float32MultiArray.h>
#include <std_msgs/Float64.h>
#include <topic_tools/shape_shifter.h>

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "bsf_vpr/core/enum_names.h"
#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/image/image_describer.h"
#include "src/ros/common/image_problem.h"
#include "src/ros/common/param_util.h"
#include "src/ros/common/sequence_gaps.h"

namespace bsf_vpr {

// What the ingest takes: images to describe, or descriptors computed elsewhere.
enum class IngestInput { kImage, kDescriptor };
// Their names (input).
const EnumNames<IngestInput>& IngestInputNames();
IngestInput ParseIngestInput(const std::string& name);  // throws naming the choices
std::string ToString(IngestInput input);

struct IngestParams {
  IngestInput input = IngestInput::kImage;  // parameter input: image | descriptor
  int expected_dimension = 0;               // 0: any non-empty dimension
  bool l2_normalize = false;
  std::string descriptor_type;      // stamped on the output; default: the image descriptor's name
  ImageDescriberOptions describer;  // for images: patchnorm | hog | onnx
  int queue_size = 10;
  std::string image_transport = "raw";  // how images arrive (raw, compressed, ...)
  double diagnostic_period = 1.0;       // seconds (diagnostic_updater reads it too)
};

// The declaration of every parameter (options.h); config/ingest.yaml is written from it.
const OptionTable<IngestParams>& IngestParamsTable();

// Reads and validates the parameters; throws std::invalid_argument naming a bad or unknown one.
IngestParams LoadIngestParams(RosParamSource& source);
IngestParams LoadIngestParams(const ros::NodeHandle& pnh);

// The descriptor in a std_msgs/Float32MultiArray: its data after data_offset, which must be
// a 1-D array (at most one dimension of size > 1). Throws std::invalid_argument otherwise.
Descriptor::Ptr FromFloat32MultiArray(const std_msgs::Float32MultiArray& array);

class DescriptorIngest {
 public:
  DescriptorIngest(ros::NodeHandle nh, ros::NodeHandle pnh);
  void Start();  // throws std::exception naming the problem if it cannot start

 private:
  void UpdateSubscription();
  void OnImage(const sensor_msgs::ImageConstPtr& msg);
  void OnAnyDescriptor(const ros::MessageEvent<const topic_tools::ShapeShifter>& event);
  // Why publishers on the descriptor input are never heard ("" if all are): see the .cpp.
  std::string UnheardPublishers();
  void OnDescriptor(const Descriptor::ConstPtr& msg);
  // Counts the inputs lost before `seq` from `publisher` (SequenceGaps).
  void NoteSequence(const std::string& publisher, uint32_t seq) EXCLUDES(mutex_);
  // Validates, normalises and publishes; `out` is handed to the publisher without a copy.
  void ValidateAndPublish(const Descriptor::Ptr& out);
  // Why `d` cannot pass ("" if it can); `squared_norm` receives its squared L2 norm.
  std::string Problem(const Descriptor& d, double* squared_norm) const;
  void Published(const Descriptor::ConstPtr& out);
  // Drops an input: counted by `cause` ("blind image", "bad descriptor", ...), logged
  // (throttled) and sent on input_dropped with the input's `header`.
  void Reject(const std::string& cause, const std::string& why, const std_msgs::Header& header)
      EXCLUDES(mutex_);
  void Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) EXCLUDES(mutex_);

  ros::NodeHandle nh_, pnh_;
  IngestParams params_;
  std::unique_ptr<ImageDescriber> describer_;  // built at start (an ONNX model is loaded then)
  Mutex mutex_;
  image_transport::ImageTransport it_;
  image_transport::Subscriber image_sub_ GUARDED_BY(mutex_);
  ros::Subscriber descriptor_sub_ GUARDED_BY(mutex_);
  ros::Publisher pub_;
  ros::Publisher describe_time_pub_;  // images only
  ros::Publisher format_pub_;         // DescriptorFormat, latched
  ros::Publisher dropped_pub_;        // InputDropped, one per input dropped
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::Timer diagnostics_timer_;
  long published_ GUARDED_BY(mutex_) = 0;
  long rejected_ GUARDED_BY(mutex_) = 0;
  // Since start: every input heard, and its fate: published (published_), dropped by cause,
  // or lost to a full queue before this node saw it (lost_total_): received_ + lost_total_ is
  // what was sent, each counted once.
  long received_ GUARDED_BY(mutex_) = 0;
  std::map<std::string, long> dropped_by_cause_ GUARDED_BY(mutex_);
  uint64_t lost_total_ GUARDED_BY(mutex_) = 0;
  // Inputs lost to a full queue before this node saw them (header.seq gaps), since the
  // last diagnostics; and the number of the next descriptor made here (header.seq).
  uint64_t lost_ GUARDED_BY(mutex_) = 0;
  uint32_t next_seq_ GUARDED_BY(mutex_) = 0;
  SequenceGaps sequence_gaps_ GUARDED_BY(mutex_);
  std::string last_rejection_ GUARDED_BY(mutex_);
  // The input topic's type, when a publisher offers another one.
  std::string wrong_type_ GUARDED_BY(mutex_);
  // Descriptor input: the type each publisher was heard with, and when the master first
  // listed each publisher (one not connected after kUnheardGraceS is reported).
  std::map<std::string, std::string> heard_ GUARDED_BY(mutex_);
  std::map<std::string, ros::WallTime> first_listed_ GUARDED_BY(mutex_);
  static constexpr double kUnheardGraceS = 3.0;
};

}  // namespace bsf_vpr
