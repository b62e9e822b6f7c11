#include "src/ros/ingest/descriptor_ingest.h"

#include <bsf_vpr/InputDropped.h>
#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>
#include <xmlrpcpp/XmlRpcException.h>

#include <chrono>
#include <cmath>

#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/ros/names.h"
#include "src/ros/common/param_util.h"

namespace bsf_vpr {
const EnumNames<IngestInput>& IngestInputNames() {
  static const EnumNames<IngestInput> kNames{{IngestInput::kImage, "image"},
                                             {IngestInput::kDescriptor, "descriptor"}};
  return kNames;
}

IngestInput ParseIngestInput(const std::string& name) {
  return IngestInputNames().Parse(name, "input");
}

std::string ToString(IngestInput input) { return IngestInputNames().Name(input); }

const OptionTable<IngestParams>& IngestParamsTable() {
  static const OptionTable<IngestParams> kTable =
      OptionTable<IngestParams>()
          .AddChoice(
              "input", [](auto& p) -> auto& { return p.input; },
              "what arrives: image (sensor_msgs/Image on \"image\", described here) or "
              "descriptor (bsf_vpr/Descriptor or std_msgs/Float32MultiArray on "
              "\"descriptor_in\", e.g. from a NetVLAD node)",
              IngestInputNames())
          .Add(
              "expected_dimension", [](auto& p) -> auto& { return p.expected_dimension; },
              "refuse descriptors of another dimension; 0 = any", "", AtLeast(0))
          .Add(
              "l2_normalize", [](auto& p) -> auto& { return p.l2_normalize; },
              "scale each descriptor to unit L2 norm")
          .Include(
              ImageDescriberOptionsTable(), [](auto& p) -> auto& { return p.describer; })
          .Add(
              "descriptor_type", [](auto& p) -> auto& { return p.descriptor_type; },
              "stamped on the output; \"\" = the image descriptor's name for images, the "
              "incoming message's for descriptors")
          .Add(
              "queue_size", [](auto& p) -> auto& { return p.queue_size; },
              "input messages buffered", "messages", AtLeast(1))
          .Add(
              "image_transport", [](auto& p) -> auto& { return p.image_transport; },
              "image_transport transport of the image topic (raw, compressed, ...)")
          .Add(
              "diagnostic_period", [](auto& p) -> auto& { return p.diagnostic_period; },
              "time between diagnostics updates (read by diagnostic_updater)", "s", Above(0));
  return kTable;
}

IngestParams LoadIngestParams(RosParamSource& source) {
  IngestParams p = LoadOptions(IngestParamsTable(), source);
  source.RefuseUnread();
  p.describer.patch_norm.Validate();
  return p;
}

IngestParams LoadIngestParams(const ros::NodeHandle& pnh) {
  RosParamSource source = RosParamSource::FromNodeHandle(pnh);
  return LoadIngestParams(source);
}

Descriptor::Ptr FromFloat32MultiArray(const std_msgs::Float32MultiArray& array) {
  int long_dims = 0;
  for (const std_msgs::MultiArrayDimension& d : array.layout.dim) long_dims += d.size > 1;
  if (long_dims > 1) {
    throw std::invalid_argument("a Float32MultiArray descriptor must be 1-D, got " +
                                std::to_string(array.layout.dim.size()) + " dimensions");
  }
  if (array.layout.data_offset > array.data.size()) {
    throw std::invalid_argument("Float32MultiArray data_offset " +
                                std::to_string(array.layout.data_offset) + " lies beyond its " +
                                std::to_string(array.data.size()) + " values");
  }
  auto out = boost::make_shared<Descriptor>();
  out->header.stamp = ros::Time::now();  // the array carries no stamp: its time of arrival
  out->data.assign(array.data.begin() + array.layout.data_offset, array.data.end());
  return out;
}

DescriptorIngest::DescriptorIngest(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(std::move(nh)), pnh_(std::move(pnh)), it_(nh_) {}

void DescriptorIngest::Start() {
  params_ = LoadIngestParams(pnh_);
  if (params_.input == IngestInput::kImage) {
    describer_ = MakeImageDescriber(params_.describer);  // a bad ONNX model fails here
    if (params_.expected_dimension != 0 && params_.expected_dimension != describer_->dimension()) {
      throw std::invalid_argument(
          "expected_dimension " + std::to_string(params_.expected_dimension) +
          " differs from the image descriptor's " + std::to_string(describer_->dimension()));
    }
    if (params_.descriptor_type.empty()) params_.descriptor_type = describer_->descriptor_type();
  }
  auto on_connect = [this](const ros::SingleSubscriberPublisher&) { UpdateSubscription(); };
  pub_ = nh_.advertise<Descriptor>(
      names::kDescriptorTopic, static_cast<uint32_t>(params_.queue_size), on_connect, on_connect);
  if (params_.input == IngestInput::kImage) {
    describe_time_pub_ = pnh_.advertise<std_msgs::Float64>(
        names::kDescribeTimeTopic, static_cast<uint32_t>(params_.queue_size));
  }
  // What this ingest will send, latched: the fusion node checks its sets against it now.
  format_pub_ = nh_.advertise<DescriptorFormat>(names::kDescriptorFormatTopic, 1, /*latch=*/true);
  dropped_pub_ = nh_.advertise<InputDropped>(names::kInputDroppedTopic, 100);
  DescriptorFormat format;
  format.descriptor_type = params_.descriptor_type;
  if (params_.input == IngestInput::kImage) {
    format.dimension = describer_->dimension();
    format.source = "images on " + nh_.resolveName(names::kImageTopic) + " described with " +
                    describer_->descriptor_type();
  } else {
    format.dimension = params_.expected_dimension;
    format.source = "descriptors on " + nh_.resolveName(names::kExternalDescriptorTopic);
  }
  format_pub_.publish(format);
  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh_, pnh_);
  diagnostics_->setHardwareID("bsf_vpr");
  diagnostics_->add("descriptor_ingest", this, &DescriptorIngest::Diagnose);
  diagnostics_timer_ = nh_.createTimer(ros::Duration(0.1),
                                       [this](const ros::TimerEvent&) { diagnostics_->update(); });
  UpdateSubscription();
}

void DescriptorIngest::UpdateSubscription() {
  MutexLock lock(&mutex_);
  const bool wanted = pub_.getNumSubscribers() > 0;
  const bool subscribed = image_sub_ || descriptor_sub_;
  if (wanted && !subscribed) {
    const uint32_t q = static_cast<uint32_t>(params_.queue_size);
    if (params_.input == IngestInput::kImage) {
      // The transport is the nodelet's own parameter (by default image_transport reads ~ of
      // the process, which in a nodelet manager is the manager's namespace).
      image_sub_ = it_.subscribe(
          names::kImageTopic, q, &DescriptorIngest::OnImage, this,
          image_transport::TransportHints(params_.image_transport, ros::TransportHints(), pnh_));
    } else {
      // Any type: bsf_vpr/Descriptor and std_msgs/Float32MultiArray are told apart per
      // message, and a publisher of another type is reported rather than silently unheard.
      descriptor_sub_ = nh_.subscribe(names::kExternalDescriptorTopic, q,
                                      &DescriptorIngest::OnAnyDescriptor, this);
    }
  } else if (!wanted && subscribed) {
    image_sub_.shutdown();
    descriptor_sub_.shutdown();
    heard_.clear();  // the next subscription hears its publishers afresh
    first_listed_.clear();
  }
}

void DescriptorIngest::Reject(const std::string& cause, const std::string& why,
                              const std_msgs::Header& header) {
  {
    MutexLock lock(&mutex_);
    ++rejected_;
    ++dropped_by_cause_[cause];
    last_rejection_ = why;
  }
  ROS_ERROR_THROTTLE(1.0, "bsf_vpr: descriptor_ingest dropped an input: %s", why.c_str());
  auto msg = boost::make_shared<InputDropped>();
  msg->header = header;
  if (msg->header.stamp.isZero()) msg->header.stamp = ros::Time::now();
  msg->cause = cause;
  msg->detail = why;
  dropped_pub_.publish(msg);
}

void DescriptorIngest::OnImage(const sensor_msgs::ImageConstPtr& msg) {
  NoteSequence("", msg->header.seq);  // image_transport does not say who published
  auto out = boost::make_shared<Descriptor>();
  const std::string problem = ImageProblem(*msg);
  if (!problem.empty()) return Reject("bad image", "bad image: " + problem, msg->header);
  double seconds = 0;  // in Describe
  try {
    // toCvShare converts only when the encoding differs (e.g. rgb8 -> bgr8).
    const cv_bridge::CvImageConstPtr cv =
        cv_bridge::toCvShare(msg, sensor_msgs::image_encodings::BGR8);
    const auto t0 = std::chrono::steady_clock::now();  // the check is part of describing
    const std::string blind = BlindImageProblem(cv->image);
    if (!blind.empty()) return Reject("blind image", "image " + blind, msg->header);
    const Eigen::VectorXf d = describer_->Describe(cv->image);
    seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out->data.assign(d.data(), d.data() + d.size());
  } catch (const std::exception& e) {
    Reject("cannot describe", std::string("cannot describe image: ") + e.what(), msg->header);
    return;
  }
  if (describe_time_pub_.getNumSubscribers() > 0) {
    auto time = boost::make_shared<std_msgs::Float64>();
    time->data = seconds;
    describe_time_pub_.publish(time);
  }
  out->header = msg->header;
  out->descriptor_type = params_.descriptor_type;
  ValidateAndPublish(out);
}

void DescriptorIngest::OnAnyDescriptor(
    const ros::MessageEvent<const topic_tools::ShapeShifter>& event) {
  const topic_tools::ShapeShifter::ConstPtr& msg = event.getConstMessage();
  const std::string type = msg->getDataType();
  {
    MutexLock lock(&mutex_);
    heard_[event.getPublisherName()] = type;
    ++received_;
  }
  try {
    if (type == ros::message_traits::DataType<Descriptor>::value()) {
      Descriptor::ConstPtr d = msg->instantiate<Descriptor>();
      NoteSequence(event.getPublisherName(), d->header.seq);
      return OnDescriptor(d);
    }
    if (type == ros::message_traits::DataType<std_msgs::Float32MultiArray>::value()) {
      Descriptor::Ptr out = FromFloat32MultiArray(*msg->instantiate<std_msgs::Float32MultiArray>());
      out->descriptor_type = params_.descriptor_type;
      return ValidateAndPublish(out);
    }
  } catch (const std::exception& e) {
    return Reject("bad descriptor", std::string("bad descriptor message: ") + e.what(),
                  std_msgs::Header());
  }
  {
    MutexLock lock(&mutex_);
    wrong_type_ = type;
  }
  Reject("wrong message type",
         "the input topic carries " + type +
             "; expected bsf_vpr/Descriptor or std_msgs/Float32MultiArray",
         std_msgs::Header());
}

void DescriptorIngest::OnDescriptor(const Descriptor::ConstPtr& msg) {
  const bool retype =
      !params_.descriptor_type.empty() && msg->descriptor_type != params_.descriptor_type;
  if (!params_.l2_normalize && !retype) {
    // Nothing to change: the validated input itself goes on (no copy of the descriptor).
    double squared_norm = 0;
    const std::string problem = Problem(*msg, &squared_norm);
    if (!problem.empty()) return Reject("bad descriptor", problem, msg->header);
    return Published(msg);
  }
  // The output differs from the input: one copy, which then travels on without another.
  auto out = boost::make_shared<Descriptor>(*msg);
  if (retype) out->descriptor_type = params_.descriptor_type;
  ValidateAndPublish(out);
}

std::string DescriptorIngest::Problem(const Descriptor& d, double* squared_norm) const {
  const size_t n = d.data.size();
  if (n == 0) return "empty descriptor";
  if (params_.expected_dimension != 0 && n != static_cast<size_t>(params_.expected_dimension)) {
    return "descriptor has dimension " + std::to_string(n) + ", expected " +
           std::to_string(params_.expected_dimension);
  }
  // The fusion node's own rule for a query (not finite, too large, all zeros), said here
  // where the descriptor comes in.
  const Eigen::Map<const Eigen::RowVectorXf> v(d.data.data(), static_cast<Eigen::Index>(n));
  const std::string problem = QueryDescriptorProblem(v);
  if (!problem.empty()) return "descriptor " + problem;
  *squared_norm = v.cast<double>().squaredNorm();
  return "";
}

void DescriptorIngest::NoteSequence(const std::string& publisher, uint32_t seq) {
  MutexLock lock(&mutex_);
  const uint64_t lost = sequence_gaps_.Note(publisher, seq);
  lost_ += lost;
  lost_total_ += lost;
  if (publisher.empty()) ++received_;  // an image (a descriptor is counted when heard)
}

void DescriptorIngest::ValidateAndPublish(const Descriptor::Ptr& out) {
  double sq = 0;
  const std::string problem = Problem(*out, &sq);
  if (!problem.empty()) return Reject("bad descriptor", problem, out->header);
  if (params_.l2_normalize) {
    if (sq <= 0)
      return Reject("bad descriptor", "cannot L2-normalise a zero descriptor", out->header);
    const float inv = static_cast<float>(1.0 / std::sqrt(sq));
    for (float& v : out->data) v *= inv;
  }
  {
    // Numbered here, once it is sure to go, so that the fusion node counts what its own
    // queue loses (a nodelet in the same manager receives the message as it is, seq
    // included) and nothing else.
    MutexLock lock(&mutex_);
    out->header.seq = next_seq_++;
  }
  Published(out);
}

void DescriptorIngest::Published(const Descriptor::ConstPtr& out) {
  pub_.publish(out);  // shared pointer: no copy to nodelets in the same manager
  MutexLock lock(&mutex_);
  ++published_;
}

void DescriptorIngest::Diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  // A publisher whose type differs from the image input's never connects (roscpp refuses
  // the connection), so it is looked up on the master.
  std::string image_type_problem;
  if (params_.input == IngestInput::kImage) {
    ros::master::V_TopicInfo topics;
    const std::string topic = nh_.resolveName(names::kImageTopic);
    if (ros::master::getTopics(topics)) {
      for (const ros::master::TopicInfo& t : topics) {
        if (t.name == topic && t.datatype != "sensor_msgs/Image") {
          image_type_problem = "the input topic " + topic + " is published as " + t.datatype +
                               "; expected sensor_msgs/Image";
        }
      }
    }
  }
  const std::string unheard = UnheardPublishers();
  MutexLock lock(&mutex_);
  if (!unheard.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR, unheard);
  } else if (!image_type_problem.empty() || !wrong_type_.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR,
                   !image_type_problem.empty()
                       ? image_type_problem
                       : "the input topic carries " + wrong_type_ +
                             "; expected bsf_vpr/Descriptor or std_msgs/Float32MultiArray");
  } else if (lost_ > 0) {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                    "dropped %lu input(s) to a full queue (queue_size %d): they arrive faster "
                    "than they are described",
                    static_cast<unsigned long>(lost_), params_.queue_size);
  } else if (rejected_ > 0) {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "dropped %ld bad input(s): %s",
                    rejected_, last_rejection_.c_str());
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "ok");
  }
  status.add("input", params_.input == IngestInput::kImage ? "image" : "descriptor");
  for (const auto& [publisher, type] : heard_) status.add("heard: " + publisher, type);
  status.add("published", published_);
  // Every drop: the bad inputs and those a full queue lost before this node saw them.
  status.add("dropped", rejected_ + static_cast<long>(lost_));
  status.add("dropped: bad", rejected_);
  status.add("dropped: queue overflow", lost_);
  status.add("subscribed", static_cast<bool>(image_sub_ || descriptor_sub_));
  // Since start, every input by its fate: what was sent is received + lost.
  status.add("received since start", received_);
  status.add("published since start", published_);
  status.add("dropped: queue overflow since start", lost_total_);
  for (const auto& [cause, n] : dropped_by_cause_) status.add("dropped since start: " + cause, n);
  rejected_ = 0;
  lost_ = 0;
  wrong_type_.clear();
}

std::string DescriptorIngest::UnheardPublishers() {
  // roscpp takes a subscription of any type (ShapeShifter) as the type of the first publisher
  // that connects and refuses publishers of another type from then on: their messages never
  // arrive. The master lists every publisher; those this node has no connection to after a
  // grace period are named.
  if (params_.input != IngestInput::kDescriptor) return "";
  ros::Subscriber sub;
  {
    MutexLock lock(&mutex_);
    sub = descriptor_sub_;
  }
  if (!sub) return "";
  const std::string topic = sub.getTopic();
  XmlRpc::XmlRpcValue request, response, payload;
  request[0] = ros::this_node::getName();
  if (!ros::master::execute("getSystemState", request, response, payload, false)) return "";
  std::vector<std::string> publishers;
  try {
    if (payload.getType() == XmlRpc::XmlRpcValue::TypeArray && payload.size() > 0) {
      XmlRpc::XmlRpcValue& pubs = payload[0];
      for (int i = 0; i < pubs.size(); ++i) {
        if (pubs[i].size() < 2 || static_cast<std::string>(pubs[i][0]) != topic) continue;
        for (int j = 0; j < pubs[i][1].size(); ++j) publishers.push_back(pubs[i][1][j]);
      }
    }
  } catch (const XmlRpc::XmlRpcException&) {
    return "";  // a malformed answer from the master: nothing to say this time
  }
  const ros::WallTime now = ros::WallTime::now();
  MutexLock lock(&mutex_);
  for (const std::string& p : publishers) first_listed_.emplace(p, now);  // keeps the first time
  if (static_cast<int>(sub.getNumPublishers()) >= static_cast<int>(publishers.size())) return "";
  std::string names, heard_type;
  for (const std::string& p : publishers) {
    if (heard_.count(p)) {
      heard_type = heard_[p];
      continue;
    }
    if ((now - first_listed_[p]).toSec() < kUnheardGraceS) continue;  // still connecting
    names += (names.empty() ? "" : ", ") + p;
  }
  if (names.empty()) return "";
  return "publisher(s) " + names + " on " + topic + " are not heard: this input took " +
         (heard_type.empty() ? std::string("another publisher's message type")
                             : heard_type + " from the first publisher") +
         ", and a topic carries one type; publish bsf_vpr/Descriptor or "
         "std_msgs/Float32MultiArray, not both, on one topic";
}

}  // namespace bsf_vpr
