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

#include <std_msgs/String.h>

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
      RefuseUnknownParams(pnh, {"queries", "count", "warmup", "rates_hz", "output",
                                "shutdown_when_done", "timeout_s"});
      queries_ = ReadNpyMatrix(GetParam<std::string>(pnh, "queries", ""));
      count_ = GetParam<int>(pnh, "count", 200);
      warmup_ = GetParam<int>(pnh, "warmup", 10);
      rates_hz_ = GetParam<std::vector<double>>(pnh, "rates_hz", {10.0, 0.0});
      output_ = GetParam<std::string>(pnh, "output", "");
      shutdown_when_done_ = GetParam<bool>(pnh, "shutdown_when_done", true);
      timeout_s_ = GetParam<double>(pnh, "timeout_s", 10.0);
      if (count_ < 1 || warmup_ < 0) throw std::invalid_argument("count must be >= 1, warmup >= 0");
      for (double r : rates_hz_) {
        if (!(r >= 0)) throw std::invalid_argument("rates_hz entries must be >= 0 (0: flat out)");
      }
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
    return cv_.wait_for(lock, std::chrono::duration<double>(timeout_s_),
                        [&] { return stop_ || received_.count(k + 1) > 0; }) &&
           !stop_;
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
    for (int i = 0; i < warmup_ && !stop_; ++i, ++k) {  // the first queries touch cold memory
      Send(k);
      WaitFor(k);
    }
    for (double rate : rates_hz_) {
      std::vector<Sample> samples;
      const Clock::time_point phase_start = Clock::now();
      for (int i = 0; i < count_ && !stop_; ++i, ++k) {
        if (rate > 0) {
          std::this_thread::sleep_until(phase_start +
                                        std::chrono::duration_cast<Clock::duration>(
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
      std::snprintf(row, sizeof row, "| %s | %d | %zu | %.3f | %.3f | %.3f | %.3f | %.3f |\n",
                    rate > 0 ? (std::to_string(static_cast<int>(rate)) + " Hz").c_str()
                             : ("flat out (" + std::to_string(static_cast<int>(
                                                   samples.size() / std::max(seconds, 1e-9))) +
                                " Hz)")
                                   .c_str(),
                    count_, samples.size(), Percentile(latency, 0.5), Percentile(latency, 0.9),
                    Percentile(core, 0.5), Percentile(overhead, 0.5), Percentile(overhead, 0.9));
      table << row;
    }
    std::printf("bsf_vpr pipeline_benchmark (%ld x %ld queries):\n%s", queries_.rows(),
                queries_.cols(), table.str().c_str());
    std::fflush(stdout);
    if (!output_.empty()) WriteFileAtomically(output_, table.str());
    std_msgs::String results;
    results.data = table.str();
    results_pub_.publish(results);
    if (shutdown_when_done_ && !stop_) ros::requestShutdown();
  }

  RowMatrixXf queries_;
  int count_ = 200, warmup_ = 10;
  std::vector<double> rates_hz_;
  std::string output_;
  bool shutdown_when_done_ = true;
  double timeout_s_ = 10;
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
