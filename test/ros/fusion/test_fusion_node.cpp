// The fusion node's logic over a fake map (map_backend.h), constructed here as the nodelet
// constructs it over a real one: a descriptor in and a belief out, a load and an unload, a
// recording handed to the map, a map whose load stalls (beliefs go on meanwhile) and one that
// fails (the refusal reaches the caller, the node keeps serving). Run by
// test/ros/fusion_node.test (a master for the node's topics and services).
#include <bsf_vpr/Belief.h>
#include <bsf_vpr/Descriptor.h>
#include <bsf_vpr/ListReferenceSets.h>
#include <bsf_vpr/LoadReferenceSet.h>
#include <bsf_vpr/QueryPlace.h>
#include <bsf_vpr/StartRecording.h>
#include <bsf_vpr/StopRecording.h>
#include <bsf_vpr/UnloadReferenceSet.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <future>
#include <limits>
#include <mutex>
#include <thread>

#include "bsf_vpr/ros/names.h"
#include "src/ros/fusion/fusion_node.h"

namespace bsf_vpr {
namespace {

constexpr int kPlaces = 10;

// Sets of kPlaces places whose distances a descriptor dictates: to place i of set u,
// |d[0] - i| + 0.5 u. What its load does is the test's to say.
class FakeMap : public MapBackend {
 public:
  enum class LoadMode { kLoad, kStall, kFail };

  FakeMap() { AddSet("summer"); }

  void set_load_mode(LoadMode mode) {
    std::lock_guard<std::mutex> lock(mutex_);
    mode_ = mode;
  }
  // Lets a stalled load go on.
  void Release() {
    std::lock_guard<std::mutex> lock(mutex_);
    released_ = true;
    changed_.notify_all();
  }
  bool stalled() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stalling_;
  }
  int added() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return added_rows_;
  }

  void Start(Callbacks) override {}
  Layout layout() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return layout_;
  }
  DistanceMetric metric() const override { return DistanceMetric::kEuclidean; }
  std::optional<Query> Hear(const QueryDescriptor& descriptor) override { return Ask(descriptor); }
  Query Ask(const QueryDescriptor& descriptor) override {
    if (descriptor.size != 4)
      throw std::invalid_argument("dimension " + std::to_string(descriptor.size) + ", not 4");
    std::lock_guard<std::mutex> lock(mutex_);
    Query q;
    q.header = descriptor.header;
    q.layout = layout_;
    std::vector<RowMatrixXf> distances;
    for (int u = 0; u < layout_->num_sets(); ++u) {
      RowMatrixXf d(1, kPlaces);
      for (int i = 0; i < kPlaces; ++i) d(0, i) = std::abs(descriptor.values[0] - i) + 0.5f * u;
      distances.push_back(d);
    }
    q.distances = QueryDistances::AllPresent(std::move(distances));
    q.acceptance_rule = rule_;
    return q;
  }
  std::string Load(const LoadRequest& request, const SetCheck& check) override {
    std::unique_lock<std::mutex> lock(mutex_);
    if (mode_ == LoadMode::kFail) throw std::invalid_argument("the disk is on fire");
    if (mode_ == LoadMode::kStall) {
      stalling_ = true;
      changed_.wait(lock, [this] { return released_; });
      stalling_ = false;
    }
    lock.unlock();
    if (check) check(request.name);
    lock.lock();
    AddSet(request.name);
    return "loaded '" + request.name + "'";
  }
  std::string Unload(const std::string& name) override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (map_.IndexOf(name) < 0) throw std::invalid_argument("no set named '" + name + "'");
    map_.Remove(name);
    layout_ = std::make_shared<NumberedLayout>(map_.layout(), ++generation_);
    return "unloaded '" + name + "'";
  }
  std::string Add(ReferenceSet set, const std::string&) override {
    std::lock_guard<std::mutex> lock(mutex_);
    added_rows_ += set.size();
    return "added";
  }
  std::string CannotRecord() const override { return ""; }
  SetList List() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    SetList list;
    for (const SetLayout& s : layout_->sets()) {
      SetSummary summary;
      summary.layout = s;
      list.sets.push_back(summary);
    }
    list.num_places = layout_->num_places();
    list.calibration = calibration_ ? "asked for " + calibration_->method : "none asked for";
    return list;
  }
  void SetJoint(std::optional<JointKind>, const JointOptions&) override {}
  void SetCalibration(std::optional<CalibrationRequest> request) override {
    std::lock_guard<std::mutex> lock(mutex_);
    calibration_ = std::move(request);
    ++calibration_requests_;
  }
  // What the node asked the map to calibrate for, and how many times.
  std::optional<CalibrationRequest> calibration() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return calibration_;
  }
  int calibration_requests() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return calibration_requests_;
  }
  // The rule every query carries from now on, as a calibrated map's do.
  void SetRule(std::optional<AcceptanceRule> rule) {
    std::lock_guard<std::mutex> lock(mutex_);
    rule_ = rule;
  }
  void WaitForJoint() const override {}
  std::string Problem() const override { return ""; }
  StatusValues Diagnose() const override { return {{"fake map", "yes"}}; }

 private:
  // Caller holds mutex_ (or the constructor runs).
  void AddSet(const std::string& name) {
    ReferenceSet set;
    set.name = name;
    set.descriptors = RowMatrixXf::Zero(kPlaces, 4);
    for (int i = 0; i < kPlaces; ++i) {
      set.descriptors(i, 0) = static_cast<float>(i);
      set.place_ids.push_back(i);
    }
    map_.Add(std::move(set));
    layout_ = std::make_shared<NumberedLayout>(map_.layout(), ++generation_);
  }

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  LoadMode mode_ = LoadMode::kLoad;
  bool released_ = false, stalling_ = false;
  int added_rows_ = 0;
  std::optional<CalibrationRequest> calibration_;
  int calibration_requests_ = 0;
  std::optional<AcceptanceRule> rule_;
  ReferenceSets map_;
  Layout layout_;
  uint64_t generation_ = 0;
};

// A fusion node in namespace `ns` over a FakeMap, and a client of its topics and services.
struct NodeFixture : ::testing::Test {
  void SetUp() override {
    static int count = 0;
    ns = "/fake_" + std::to_string(++count);
    data_dir = std::filesystem::temp_directory_path() /
               ("bsf_fake_map_" + std::to_string(getpid()) + ns.substr(1));
    std::filesystem::remove_all(data_dir);
    ros::NodeHandle pnh(ns + "/fusion");
    pnh.setParam("method", "bsf");
    pnh.setParam("data_directory", data_dir.string());
    SetParams(pnh);
    auto fake = std::make_unique<FakeMap>();
    map = fake.get();
    node = std::make_unique<FusionNode>(
        ros::NodeHandle(ns), pnh,
        [&fake](const FusionParams&, const DataDirectory*) -> std::unique_ptr<MapBackend> {
          return std::move(fake);
        });
    node->Start();
    ros::NodeHandle nh(ns);
    belief_sub = nh.subscribe<Belief>(names::kBeliefTopic, 100, [this](const Belief::ConstPtr& b) {
      std::lock_guard<std::mutex> lock(mutex);
      beliefs.push_back(*b);
    });
    descriptor_pub = nh.advertise<Descriptor>(names::kDescriptorTopic, 100);
    WaitFor([&] {
      return descriptor_pub.getNumSubscribers() > 0 && belief_sub.getNumPublishers() > 0;
    });
  }
  // Parameters of a fixture's own, set before the node starts.
  virtual void SetParams(ros::NodeHandle& /*pnh*/) {}
  void TearDown() override {
    belief_sub.shutdown();
    descriptor_pub.shutdown();
    node.reset();
    std::filesystem::remove_all(data_dir);
  }

  template <class Ready>
  static bool WaitFor(Ready ready, double timeout_s = 10) {
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (!ready()) {
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }
  // Publishes a descriptor showing place `place` and waits for its belief.
  Belief Recognise(float place) {
    size_t before;
    {
      std::lock_guard<std::mutex> lock(mutex);
      before = beliefs.size();
    }
    Descriptor d;
    d.header.stamp = ros::Time::now();
    d.header.frame_id = "camera";
    d.data = {place, 0.0f, 0.0f, 0.0f};
    descriptor_pub.publish(d);
    EXPECT_TRUE(WaitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex);
          return beliefs.size() > before;
        },
        2.0))
        << "no belief within 2 s";
    std::lock_guard<std::mutex> lock(mutex);
    return beliefs.empty() ? Belief() : beliefs.back();
  }
  template <class Srv>
  Srv Call(const char* service, Srv srv = Srv()) {
    EXPECT_TRUE(ros::service::call(ns + "/" + service, srv)) << service;
    return srv;
  }
  LoadReferenceSet LoadSet(const std::string& name) {
    LoadReferenceSet load;
    load.request.path = name + ".yaml";
    load.request.name = name;
    return Call(names::kLoadReferenceSetService, load);
  }

  std::string ns;
  std::filesystem::path data_dir;
  FakeMap* map = nullptr;  // the node's
  std::unique_ptr<FusionNode> node;
  ros::Subscriber belief_sub;
  ros::Publisher descriptor_pub;
  std::mutex mutex;
  std::vector<Belief> beliefs;
};

TEST_F(NodeFixture, ADescriptorInGivesItsBeliefOut) {
  for (int place : {3, 4, 7}) {
    const Belief b = Recognise(static_cast<float>(place));
    EXPECT_EQ(b.match, place);
    EXPECT_EQ(b.num_places, kPlaces);
    EXPECT_EQ(b.set_names, std::vector<std::string>{"summer"});
    EXPECT_EQ(b.header.frame_id, "camera");
  }
}

// A threshold the fake map's beliefs pass (one set of 10 places: confidence about -1.4).
struct LaxFixture : NodeFixture {
  void SetParams(ros::NodeHandle& pnh) override { pnh.setParam("threshold", 0.1); }
};

TEST_F(LaxFixture, TheRuleTheMapsQueriesCarryDecidesBesideTheThreshold) {
  // max_false_accept_rate 0 (the default): the map is asked for no calibration.
  EXPECT_GE(map->calibration_requests(), 1);
  EXPECT_FALSE(map->calibration());
  const Belief free = Recognise(5);
  ASSERT_TRUE(free.accepted) << free.confidence;
  AcceptanceRule none;
  none.cut = std::numeric_limits<double>::infinity();
  map->SetRule(none);
  const Belief ruled = Recognise(5);
  EXPECT_EQ(ruled.match, 5);
  EXPECT_FALSE(ruled.accepted);
  EXPECT_NEAR(ruled.confidence, free.confidence, 1e-9);  // the rule moves no confidence
  EXPECT_FLOAT_EQ(ruled.match_distance, 0.0f);           // the query is place 5's own descriptor
  QueryPlace query;  // a what-if query is decided with the rule too
  query.request.descriptor.data = {5.0f, 0.0f, 0.0f, 0.0f};
  query = Call(names::kQueryPlaceService, query);
  EXPECT_TRUE(query.response.success);
  EXPECT_FALSE(query.response.belief.accepted);
  map->SetRule(std::nullopt);
  EXPECT_TRUE(Recognise(5).accepted);
}

struct CalibratingFixture : NodeFixture {
  void SetParams(ros::NodeHandle& pnh) override { pnh.setParam("max_false_accept_rate", 0.05); }
};

TEST_F(CalibratingFixture, TheNodeAsksItsMapToCalibrateForItsMethodAndRate) {
  const std::optional<CalibrationRequest> asked = map->calibration();
  ASSERT_TRUE(asked);
  EXPECT_EQ(asked->method, "bsf");
  EXPECT_DOUBLE_EQ(asked->max_false_accept_rate, 0.05);
  EXPECT_EQ(Call<ListReferenceSets>(names::kListReferenceSetsService).response.calibration,
            "asked for bsf");
  // Reconfigured live (dynparam): the map is asked for the new rate, and for none at 0.
  const auto reconfigure = [this](double rate) {
    dynamic_reconfigure::Reconfigure rc;
    dynamic_reconfigure::DoubleParameter p;
    p.name = "max_false_accept_rate";
    p.value = rate;
    rc.request.config.doubles.push_back(p);
    EXPECT_TRUE(ros::service::call(ns + "/fusion/set_parameters", rc));
  };
  reconfigure(0.02);
  ASSERT_TRUE(map->calibration());
  EXPECT_DOUBLE_EQ(map->calibration()->max_false_accept_rate, 0.02);
  reconfigure(0);
  EXPECT_FALSE(map->calibration());
}

TEST_F(NodeFixture, ALoadAndAnUnloadChangeTheSetsTheBeliefsFollow) {
  const LoadReferenceSet load = LoadSet("winter");
  EXPECT_TRUE(load.response.success) << load.response.message;
  EXPECT_EQ(load.response.message, "loaded 'winter'");
  EXPECT_EQ(Call<ListReferenceSets>(names::kListReferenceSetsService).response.sets.size(), 2u);
  EXPECT_EQ(Recognise(5).set_names, (std::vector<std::string>{"summer", "winter"}));
  UnloadReferenceSet unload;
  unload.request.name = "summer";
  unload = Call(names::kUnloadReferenceSetService, unload);
  EXPECT_TRUE(unload.response.success) << unload.response.message;
  const Belief b = Recognise(2);
  EXPECT_EQ(b.set_names, std::vector<std::string>{"winter"});
  EXPECT_EQ(b.match, 2);
  unload = Call(names::kUnloadReferenceSetService, unload);  // gone already
  EXPECT_FALSE(unload.response.success);
  EXPECT_NE(unload.response.message.find("no set named 'summer'"), std::string::npos);
}

TEST_F(NodeFixture, BeliefsGoOnWhileTheMapStallsOnALoad) {
  map->set_load_mode(FakeMap::LoadMode::kStall);
  auto pending = std::async(std::launch::async, [this] { return LoadSet("night"); });
  ASSERT_TRUE(WaitFor([&] { return map->stalled(); }));
  for (int place = 0; place < 5; ++place) {
    const auto start = std::chrono::steady_clock::now();
    EXPECT_EQ(Recognise(static_cast<float>(place)).match, place);
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
  }
  // The list answers meanwhile too (it does not wait for the load).
  EXPECT_EQ(Call<ListReferenceSets>(names::kListReferenceSetsService).response.sets.size(), 1u);
  map->Release();
  const LoadReferenceSet load = pending.get();
  EXPECT_TRUE(load.response.success) << load.response.message;
  EXPECT_EQ(Recognise(1).set_names.size(), 2u);
}

TEST_F(NodeFixture, AMapThatFailsRefusesTheLoadAndTheNodeKeepsServing) {
  map->set_load_mode(FakeMap::LoadMode::kFail);
  const LoadReferenceSet load = LoadSet("winter");
  EXPECT_FALSE(load.response.success);
  EXPECT_EQ(load.response.message, "the disk is on fire");
  EXPECT_EQ(Recognise(6).match, 6);
  EXPECT_EQ(Call<ListReferenceSets>(names::kListReferenceSetsService).response.sets.size(), 1u);
  // A descriptor the map refuses is dropped and reported; the next is recognised.
  Descriptor wrong;
  wrong.header.stamp = ros::Time::now();
  wrong.data = {1.0f};
  descriptor_pub.publish(wrong);
  EXPECT_EQ(Recognise(8).match, 8);
}

TEST_F(NodeFixture, ARecordingIsHandedToTheMapWhenItStops) {
  StartRecording start;
  start.request.name = "recorded";
  start.request.places = "sequential";
  start = Call(names::kStartRecordingService, start);
  ASSERT_TRUE(start.response.success) << start.response.message;
  // (Place 0's descriptor is all zeros, which no set may hold.)
  for (int place = 1; place <= 6; ++place) Recognise(static_cast<float>(place));
  const StopRecording stop = Call<StopRecording>(names::kStopRecordingService);
  ASSERT_TRUE(stop.response.success) << stop.response.message;
  EXPECT_EQ(stop.response.num_descriptors, 6);
  EXPECT_EQ(map->added(), 6);
  EXPECT_TRUE(std::filesystem::exists(stop.response.path)) << stop.response.path;
}

}  // namespace
}  // namespace bsf_vpr

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_fusion_node");
  ros::AsyncSpinner spinner(2);  // the node's own queue, and this test's subscriptions
  spinner.start();
  const int result = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  return result;
}
