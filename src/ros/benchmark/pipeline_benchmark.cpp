// bsf_vpr/pipeline_benchmark: measures the ROS path. Loaded into the manager of
// descriptor_ingest and fusion, it publishes descriptor messages (~queries, on descriptor_out)
// or camera images (~images, on image_out: sensor_msgs/Image bgr8, decoded once) into the ingest
// input as shared pointers (no serialisation, as from a camera or descriptor nodelet),
// receives the beliefs, and compares each query's latency (publish to belief callback) with
// the core's own time for it: the belief's processing_time, plus for images the time ingest
// took to describe it (descriptor_ingest's ~describe_time, subscribed as describe_time).
// One query is in flight at a time, and ingest publishes an image's describe time before its
// descriptor; both arrive on this nodelet's single-threaded callback queue, so a describe
// time belongs to the query in flight. Phases: one per entry of ~rates_hz (0 = as fast as
// possible: the next query leaves when the previous belief arrives). The table goes to
// stdout, to ~results (std_msgs/String, latched) and to ~output if set. See
// launch/benchmark_pipeline.launch and docs/performance.md.
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/fill_image.h>
#include <sensor_msgs/image_encodings.h>
#include <std_msgs/Float64.h>
#include <std_msgs/String.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <map>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <pluginlib/class_list_macros.hpp>
#include <sstream>
#include <thread>

#include "bsf_vpr/Belief.h"
#include "bsf_vpr/Descriptor.h"
#include "bsf_vpr/core/mutex.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "src/ros/common/param_util.h"

namespace bsf_vpr {
namespace {

using Clock = std::chrono::steady_clock;

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5)];
}

struct PipelineBenchmarkOptions {
  std::string queries;  // Q x D .npy, or
  std::string images;   // a folder of images
  int count = 200;
  int warmup = 10;
  std::vector<double> rates_hz = {10.0, 0.0};
  std::string output;
  bool shutdown_when_done = true;
  double timeout_s = 10;
};

const OptionTable<PipelineBenchmarkOptions>& Table() {
  static const OptionTable<PipelineBenchmarkOptions> kTable =
      OptionTable<PipelineBenchmarkOptions>()
          .Add(
              "queries", [](auto& o) -> auto& { return o.queries; },
              "Q x D descriptor .npy published as queries (cycled); \"\" with images")
          .Add(
              "images", [](auto& o) -> auto& { return o.images; },
              "folder of images published as queries instead (sensor_msgs/Image bgr8, decoded "
              "once, cycled)")
          .Add(
              "count", [](auto& o) -> auto& { return o.count; }, "queries per phase", "",
              AtLeast(1))
          .Add(
              "warmup", [](auto& o) -> auto& { return o.warmup; },
              "queries before the first phase, not measured", "", AtLeast(0))
          .Add(
              "rates_hz", [](auto& o) -> auto& { return o.rates_hz; },
              "one phase per rate; 0 = flat out (the next query leaves when the previous "
              "belief arrives)",
              "Hz", AtLeast(0))
          .Add(
              "output", [](auto& o) -> auto& { return o.output; },
              "file the table is also written to (\"\": none)")
          .Add(
              "shutdown_when_done", [](auto& o) -> auto& { return o.shutdown_when_done; },
              "shut the process down after the last phase")
          .Add(
              "timeout_s", [](auto& o) -> auto& { return o.timeout_s; },
              "longest wait for one belief", "s", Above(0));
  return kTable;
}

// The images of `folder` as bgr8 messages, decoded once (the benchmark cycles through them).
std::vector<sensor_msgs::ImageConstPtr> LoadImages(const std::string& folder) {
  std::vector<sensor_msgs::ImageConstPtr> out;
  for (const std::string& file : ListImageFiles(folder)) {
    const cv::Mat m = cv::imread(file, cv::IMREAD_COLOR);
    if (m.empty()) throw std::runtime_error("cannot decode image '" + file + "'");
    auto msg = boost::make_shared<sensor_msgs::Image>();
    sensor_msgs::fillImage(*msg, sensor_msgs::image_encodings::BGR8, m.rows, m.cols,
                           static_cast<uint32_t>(m.step[0]), m.data);
    out.push_back(msg);
  }
  if (out.empty()) throw std::runtime_error("no images in '" + folder + "'");
  return out;
}

struct Sample {
  double latency_ms;   // publish to belief callback
  double fusion_ms;    // the belief's processing_time
  double describe_ms;  // ingest's describe time (images); NaN when none came
};

// The table's header; with images two columns more: the parts of the core's time.
std::string TableHeader(bool images) {
  std::string h =
      "| rate | queries | beliefs | latency median ms | latency p90 ms | core median ms | "
      "overhead median ms | overhead p90 ms |";
  if (images) h += " describe median ms | fusion median ms |";
  h += "\n|";
  for (int c = 0; c < (images ? 10 : 8); ++c) h += " --- |";
  return h + "\n";
}

// One phase's row. The core's time of a query is the belief's processing_time plus, for an
// image, its describe time; the overhead is the latency less the core's time.
std::string TableRow(const std::string& rate, int count, const std::vector<Sample>& samples,
                     bool images, int* missing_describe) {
  std::vector<double> latency, core, overhead, describe, fusion;
  for (const Sample& s : samples) {
    const bool described = !std::isnan(s.describe_ms);
    if (images && !described) ++*missing_describe;
    const double c = s.fusion_ms + (described ? s.describe_ms : 0.0);
    latency.push_back(s.latency_ms);
    core.push_back(c);
    overhead.push_back(s.latency_ms - c);
    fusion.push_back(s.fusion_ms);
    if (described) describe.push_back(s.describe_ms);
  }
  char row[512];
  std::snprintf(row, sizeof row, "| %s | %d | %zu | %.3f | %.3f | %.3f | %.3f | %.3f |",
                rate.c_str(), count, samples.size(), Percentile(latency, 0.5),
                Percentile(latency, 0.9), Percentile(core, 0.5), Percentile(overhead, 0.5),
                Percentile(overhead, 0.9));
  std::string out = row;
  if (images) {
    std::snprintf(row, sizeof row, " %.3f | %.3f |", Percentile(describe, 0.5),
                  Percentile(fusion, 0.5));
    out += row;
  }
  return out + "\n";
}

}  // namespace

class PipelineBenchmarkNodelet : public nodelet::Nodelet {
 public:
  ~PipelineBenchmarkNodelet() override {
    stop_ = true;
    cv_.notify_all();
    if (worker_.joinable()) worker_.join();
  }

 private:
  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    try {
      RosParamSource source = RosParamSource::FromNodeHandle(pnh);
      options_ = LoadOptions(Table(), source);
      source.RefuseUnread();
      if (options_.queries.empty() == options_.images.empty()) {
        throw std::invalid_argument("set exactly one of ~queries and ~images");
      }
      if (images()) {
        images_ = LoadImages(options_.images);
      } else {
        queries_ = ReadNpyMatrix(options_.queries);
      }
    } catch (const std::exception& e) {
      NODELET_FATAL("bsf_vpr pipeline_benchmark cannot start: %s", e.what());
      throw;
    }
    if (images()) {
      pub_ = nh.advertise<sensor_msgs::Image>("image_out", 10);
      describe_time_sub_ =
          nh.subscribe("describe_time", 10, &PipelineBenchmarkNodelet::OnDescribeTime, this);
    } else {
      pub_ = nh.advertise<Descriptor>("descriptor_out", 10);
    }
    sub_ = nh.subscribe("belief", 10, &PipelineBenchmarkNodelet::OnBelief, this);
    results_pub_ = pnh.advertise<std_msgs::String>("results", 1, true);  // latched
    worker_ = std::thread([this] { Run(); });
  }

  bool images() const { return !options_.images.empty(); }

  void OnDescribeTime(const std_msgs::Float64::ConstPtr& msg) {
    MutexLock lock(&mutex_);
    describe_ms_.emplace(in_flight_, msg->data * 1e3);  // the first for this query counts
  }

  void OnBelief(const Belief::ConstPtr& msg) {
    const Clock::time_point now = Clock::now();
    MutexLock lock(&mutex_);
    const int id = msg->header.stamp.sec;
    const auto it = sent_.find(id);
    if (it == sent_.end()) return;
    const double ms = std::chrono::duration<double, std::milli>(now - it->second).count();
    const auto d = describe_ms_.find(id);
    received_[id] = {ms, msg->processing_time * 1e3,
                     d != describe_ms_.end() ? d->second : std::nan("")};
    sent_.erase(it);
    cv_.notify_all();
  }

  // Publishes query `k` (stamp.sec = k + 1 identifies it); returns at once. An image is
  // copied into a new message first (as a camera driver makes one per frame), untimed.
  void Send(int k) {
    const ros::Time stamp(k + 1, 0);
    boost::shared_ptr<sensor_msgs::Image> image;
    boost::shared_ptr<Descriptor> descriptor;
    if (images()) {
      image = boost::make_shared<sensor_msgs::Image>(*images_[k % images_.size()]);
      image->header.stamp = stamp;
    } else {
      descriptor = boost::make_shared<Descriptor>();
      const Eigen::Index row = k % queries_.rows();
      descriptor->data.assign(queries_.row(row).data(), queries_.row(row).data() + queries_.cols());
      descriptor->header.stamp = stamp;
    }
    MutexLock lock(&mutex_);
    in_flight_ = k + 1;
    sent_[k + 1] = Clock::now();
    if (image) {
      pub_.publish(boost::shared_ptr<const sensor_msgs::Image>(image));
    } else {
      pub_.publish(boost::shared_ptr<const Descriptor>(descriptor));
    }
  }

  bool WaitFor(int k) {
    MutexLock lock(&mutex_);
    return lock.AwaitFor(cv_, std::chrono::duration<double>(options_.timeout_s), [&] {
      mutex_.AssertHeld();
      return stop_ || received_.count(k + 1) > 0;
    }) && !stop_;
  }

  // Whether the pipeline is connected: ingest subscribes (lazily, once fusion listens to it)
  // and, for images, its describe times reach this nodelet.
  bool Connected() const {
    return pub_.getNumSubscribers() > 0 && (!images() || describe_time_sub_.getNumPublishers() > 0);
  }

  // One phase of options_.count queries at `rate` (0: flat out), from query `*k` on.
  std::vector<Sample> Phase(double rate, int* k, double* seconds) {
    std::vector<Sample> samples;
    const Clock::time_point phase_start = Clock::now();
    for (int i = 0; i < options_.count && !stop_; ++i, ++*k) {
      if (rate > 0) {
        std::this_thread::sleep_until(phase_start + std::chrono::duration_cast<Clock::duration>(
                                                        std::chrono::duration<double>(i / rate)));
      }
      Send(*k);
      if (WaitFor(*k)) {
        MutexLock lock(&mutex_);
        samples.push_back(received_[*k + 1]);
      }
    }
    *seconds = std::chrono::duration<double>(Clock::now() - phase_start).count();
    return samples;
  }

  void Run() {
    while (!stop_ && ros::ok() && !Connected()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    std::string table = TableHeader(images());
    int k = 0, missing_describe = 0;
    for (int i = 0; i < options_.warmup && !stop_;
         ++i, ++k) {  // the first queries touch cold memory
      Send(k);
      WaitFor(k);
    }
    for (double rate : options_.rates_hz) {
      double seconds = 0;
      const std::vector<Sample> samples = Phase(rate, &k, &seconds);
      const int achieved = static_cast<int>(samples.size() / std::max(seconds, 1e-9));
      std::string label = "flat out (" + std::to_string(achieved) + " Hz)";
      if (rate > 0) {
        label = std::to_string(static_cast<int>(rate)) + " Hz";
        // A query that outlasts the period delays the next: the rate was not kept.
        if (achieved < 0.95 * rate) label += " (fell behind: " + std::to_string(achieved) + " Hz)";
      }
      table += TableRow(label, options_.count, samples, images(), &missing_describe);
    }
    if (missing_describe > 0) {
      table += "\n" + std::to_string(missing_describe) +
               " beliefs came without a describe time (counted as 0 ms)\n";
    }
    std::string what;
    if (images()) {
      what = std::to_string(images_.size()) + " images of " + std::to_string(images_[0]->width) +
             "x" + std::to_string(images_[0]->height) + " from " + options_.images +
             "; core = describe + fusion";
    } else {
      what = std::to_string(queries_.rows()) + " x " + std::to_string(queries_.cols()) + " queries";
    }
    std::printf("bsf_vpr pipeline_benchmark (%s):\n%s", what.c_str(), table.c_str());
    std::fflush(stdout);
    if (!options_.output.empty()) WriteFileAtomically(options_.output, table);
    std_msgs::String results;
    results.data = table;
    results_pub_.publish(results);
    if (options_.shutdown_when_done && !stop_) ros::requestShutdown();
  }

  PipelineBenchmarkOptions options_;
  RowMatrixXf queries_;
  std::vector<sensor_msgs::ImageConstPtr> images_;
  ros::Publisher pub_, results_pub_;
  ros::Subscriber sub_, describe_time_sub_;
  Mutex mutex_;
  std::condition_variable cv_;
  int in_flight_ GUARDED_BY(mutex_) = 0;  // the id (stamp.sec) of the last query sent
  std::map<int, Clock::time_point> sent_ GUARDED_BY(mutex_);
  std::map<int, double> describe_ms_ GUARDED_BY(mutex_);
  std::map<int, Sample> received_ GUARDED_BY(mutex_);
  std::atomic<bool> stop_{false};
  std::thread worker_;
};

}  // namespace bsf_vpr

PLUGINLIB_EXPORT_CLASS(bsf_vpr::PipelineBenchmarkNodelet, nodelet::Nodelet)
