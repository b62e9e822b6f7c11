// bsf_vpr/pipeline_benchmark: measures the ROS path. Loaded into the manager of
// descriptor_ingest and fusion, it publishes descriptor messages (shared pointers: no
// serialisation, as from a descriptor nodelet) into the ingest input, receives the beliefs,
// and compares each query's latency (publish to belief callback) with the core's own time
// for it (the belief's processing_time). Phases: one per entry of ~rates_hz (0 = as fast as
// possible: the next query leaves when the previous belief arrives). The table goes to
// stdout, to ~results (std_msgs/String, latched) and to ~output if set. See
// launch/benchmark_pipeline.launch and docs/performance.md.
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <std_msgs/String.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <map>
#include <mutex>
#include <pluginlib/class_list_macros.hpp>
#include <sstream>
#include <thread>

#include "bsf_vpr/Belief.h"
#include "bsf_vpr/Descriptor.h"
#include "bsf_vpr/core/file_util.h"
#include "bsf_vpr/core/npy.h"
#include "param_util.h"

namespace bsf_vpr {
namespace {

using Clock = std::chrono::steady_clock;

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5)];
}

struct PipelineBenchmarkOptions {
  std::string queries;  // Q x D .npy
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
              "Q x D descriptor .npy published as queries (cycled)")
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

}  // namespace

class PipelineBenchmarkNodelet : public nodelet::Nodelet {
 public:
  ~PipelineBenchmarkNodelet() override {
    stop_ = true;
    cv_.notify_all();
    if (worker_.joinable()) worker_.join();
  }

 private:
  struct Sample {
    double latency_ms, core_ms;
  };

  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    try {
      RosParamSource source = RosParamSource::FromNodeHandle(pnh);
      options_ = LoadOptions(Table(), source);
      source.RefuseUnread();
      queries_ = ReadNpyMatrix(options_.queries);
    } catch (const std::exception& e) {
      NODELET_FATAL("bsf_vpr pipeline_benchmark cannot start: %s", e.what());
      throw;
    }
    pub_ = nh.advertise<Descriptor>("descriptor_out", 10);
    sub_ = nh.subscribe("belief", 10, &PipelineBenchmarkNodelet::OnBelief, this);
    results_pub_ = pnh.advertise<std_msgs::String>("results", 1, true);  // latched
    worker_ = std::thread([this] { Run(); });
  }

  void OnBelief(const Belief::ConstPtr& msg) {
    const Clock::time_point now = Clock::now();
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = sent_.find(msg->header.stamp.sec);
    if (it == sent_.end()) return;
    const double ms = std::chrono::duration<double, std::milli>(now - it->second).count();
    received_[msg->header.stamp.sec] = {ms, msg->processing_time * 1e3};
    sent_.erase(it);
    cv_.notify_all();
  }

  // Publishes query `k` (stamp.sec = k + 1 identifies it); returns at once.
  void Send(int k) {
    auto msg = boost::make_shared<Descriptor>();
    const Eigen::Index row = k % queries_.rows();
    msg->data.assign(queries_.row(row).data(), queries_.row(row).data() + queries_.cols());
    msg->header.stamp = ros::Time(k + 1, 0);
    std::lock_guard<std::mutex> lock(mutex_);
    sent_[k + 1] = Clock::now();
    pub_.publish(boost::shared_ptr<const Descriptor>(msg));
  }

  bool WaitFor(int k) {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, std::chrono::duration<double>(options_.timeout_s), [&] {
      return stop_ || received_.count(k + 1) > 0;
    }) && !stop_;
  }

  void Run() {
    while (!stop_ && ros::ok() && pub_.getNumSubscribers() == 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    std::ostringstream table;
    table << "| rate | queries | beliefs | latency median ms | latency p90 ms | core median ms | "
             "overhead median ms | overhead p90 ms |\n| --- | --- | --- | --- | --- | --- | --- | "
             "--- |\n";
    int k = 0;
    for (int i = 0; i < options_.warmup && !stop_;
         ++i, ++k) {  // the first queries touch cold memory
      Send(k);
      WaitFor(k);
    }
    for (double rate : options_.rates_hz) {
      std::vector<Sample> samples;
      const Clock::time_point phase_start = Clock::now();
      for (int i = 0; i < options_.count && !stop_; ++i, ++k) {
        if (rate > 0) {
          std::this_thread::sleep_until(phase_start + std::chrono::duration_cast<Clock::duration>(
                                                          std::chrono::duration<double>(i / rate)));
        }
        Send(k);
        if (WaitFor(k)) {
          std::lock_guard<std::mutex> lock(mutex_);
          samples.push_back(received_[k + 1]);
        }
      }
      const double seconds = std::chrono::duration<double>(Clock::now() - phase_start).count();
      std::vector<double> latency, core, overhead;
      for (const Sample& s : samples) {
        latency.push_back(s.latency_ms);
        core.push_back(s.core_ms);
        overhead.push_back(s.latency_ms - s.core_ms);
      }
      char row[512];
      std::snprintf(
          row, sizeof row, "| %s | %d | %zu | %.3f | %.3f | %.3f | %.3f | %.3f |\n",
          rate > 0 ? (std::to_string(static_cast<int>(rate)) + " Hz").c_str()
                   : ("flat out (" +
                      std::to_string(static_cast<int>(samples.size() / std::max(seconds, 1e-9))) +
                      " Hz)")
                         .c_str(),
          options_.count, samples.size(), Percentile(latency, 0.5), Percentile(latency, 0.9),
          Percentile(core, 0.5), Percentile(overhead, 0.5), Percentile(overhead, 0.9));
      table << row;
    }
    std::printf("bsf_vpr pipeline_benchmark (%ld x %ld queries):\n%s", queries_.rows(),
                queries_.cols(), table.str().c_str());
    std::fflush(stdout);
    if (!options_.output.empty()) WriteFileAtomically(options_.output, table.str());
    std_msgs::String results;
    results.data = table.str();
    results_pub_.publish(results);
    if (options_.shutdown_when_done && !stop_) ros::requestShutdown();
  }

  PipelineBenchmarkOptions options_;
  RowMatrixXf queries_;
  ros::Publisher pub_, results_pub_;
  ros::Subscriber sub_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::map<int, Clock::time_point> sent_;
  std::map<int, Sample> received_;
  std::atomic<bool> stop_{false};
  std::thread worker_;
};

}  // namespace bsf_vpr

PLUGINLIB_EXPORT_CLASS(bsf_vpr::PipelineBenchmarkNodelet, nodelet::Nodelet)
