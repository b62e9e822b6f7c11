// The fusion node's parts that need no master: selection counters, enumerations parsed
// from parameters, message conversions, and the recording of a new reference set.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "bsf_vpr/io/reference_set_io.h"
#include "bsf_vpr/map/place_recognizer.h"
#include "src/ros/common/conversions.h"
#include "src/ros/fusion/busy_sets.h"
#include "src/ros/fusion/odometry_progress.h"
#include "src/ros/fusion/odometry_tracker.h"
#include "src/ros/fusion/recording.h"
#include "src/ros/fusion/selection_counters.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;

ReferenceSets ThreeSets() {
  ReferenceSets map;
  for (const char* name : {"summer", "fall", "winter"}) {
    map.Add(MakeReferenceSet(name, RowMatrixXf::Random(4, 3)));
  }
  return map;
}

TEST(BusySets, ANameTakenByOneLoadOrUnloadIsRefusedToAnotherUntilReleased) {
  BusySets busy;
  EXPECT_TRUE(busy.empty());
  busy.Take("winter", "loaded");
  EXPECT_NO_THROW(busy.Take("summer", "unloaded"));
  try {
    busy.Take("winter", "unloaded");
    FAIL() << "a name being loaded was taken for an unload";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "a reference set named 'winter' is being loaded");
  }
  EXPECT_THROW(busy.Check("summer"), std::invalid_argument);
  busy.Release("winter", "loaded");
  EXPECT_NO_THROW(busy.Check("winter"));
  // A stopped recording's set is held beside the unload that has it: each ends its own.
  busy.Hold("summer", "loaded");
  busy.Release("summer", "unloaded");
  EXPECT_THROW(busy.Take("summer", "loaded"), std::invalid_argument);  // still loading
  busy.Release("summer", "loaded");
  EXPECT_TRUE(busy.empty());
}

TEST(Conversions, AShardsMalformedDistancesLeaveOutItsSetsButNotItsJoint) {
  ShardDistances msg;
  msg.set_names = {"summer", "fall"};
  msg.fingerprints = {1, 2};
  msg.counts = {2, 3};
  msg.distances = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f};
  msg.processing_time = 0.25;
  ShardAnswer a = FromShardDistancesMsg(msg);
  EXPECT_FALSE(a.malformed);
  ASSERT_EQ(a.distances.size(), 2u);
  EXPECT_EQ(a.distances[1].cols(), 3);
  EXPECT_EQ(a.distances[1](0, 2), 0.5f);
  EXPECT_EQ(a.seconds, 0.25);
  msg.counts = {2, 4};  // more than the distances sent
  msg.joint_kind = "discriminant";
  msg.joint_sets = {"summer", "fall"};
  msg.joint_distances = {0.5f, 0.6f};
  a = FromShardDistancesMsg(msg);
  EXPECT_TRUE(a.malformed);
  EXPECT_TRUE(a.distances.empty());
  ASSERT_TRUE(a.joint_kind.has_value());
  EXPECT_EQ(a.joint_distances.cols(), 2);
  msg.error = "dimension 3, the sets' 4";
  a = FromShardDistancesMsg(msg);
  EXPECT_EQ(a.error, msg.error);
}

TEST(SelectionCounters, CountSelectedBestAndSuppliedPerSet) {
  const ReferenceSets map = ThreeSets();
  SelectionCounters c;
  Recognition r;
  r.belief.selection.selected = {0, 2};
  r.belief.selection.best = 2;
  r.closest_set = 0;
  c.Count(r, map);
  r.belief.selection.selected = {2};
  r.closest_set = 2;
  c.Count(r, map);
  EXPECT_EQ(c.queries(), 2);
  const ReferenceSetUsage winter = c.Usage("winter");
  EXPECT_EQ(winter.selected, 2);
  EXPECT_EQ(winter.best, 2);
  EXPECT_EQ(winter.supplied_match, 1);
  EXPECT_DOUBLE_EQ(winter.selected_fraction, 1.0);
  EXPECT_EQ(c.Usage("summer").selected, 1);
  EXPECT_EQ(c.Usage("fall").selected, 0);
  c.Forget("winter");
  EXPECT_EQ(c.Usage("winter").selected, 0);
  EXPECT_EQ(c.queries(), 2);
  c.Reset();
  EXPECT_EQ(c.queries(), 0);
  EXPECT_EQ(c.Usage("summer").selected_fraction, 0.0);
}

TEST(OdometrySource, ParsesOnceAndNamesTheChoices) {
  for (const char* name : {"none", "topic", "tf"}) {
    EXPECT_EQ(ToString(ParseOdometrySource(name)), name);
  }
  try {
    ParseOdometrySource("gps");
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("none, topic or tf"), std::string::npos);
  }
}

// Two sets of 3-d descriptors over 6 places; only "day" has poses (place k at x = 10 k).
// `day_rows` (may be null) receives day's descriptors.
PlaceRecognizer TwoSetsWithPoses(RowMatrixXf* day_rows = nullptr) {
  ReferenceSet day = MakeReferenceSet("day", RowMatrixXf::Random(6, 3), "sunny");
  if (day_rows) *day_rows = day.descriptors;
  for (int k = 0; k < 6; ++k) day.poses.push_back(PlacePose{10.0 * k, 0, 0, 0.1 * k});
  day.descriptor_type = "test_3";
  PlaceRecognizer r;
  r.AddReferenceSet(day);
  r.AddReferenceSet(MakeReferenceSet("night", RowMatrixXf::Random(6, 3), "dark"));
  return r;
}

// Issue 41 row 8: the last odometry message NaN, then odometry stopped, dropped every query.
TEST(OdometryProgress, ANonFinitePositionIsRefusedAndNeverBecomesTheLatest) {
  OdometryProgress odometry(/*timeout_s=*/1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(odometry.Hear({0, 0, 0}, 10.0));
  EXPECT_EQ(odometry.StepPlaces(10.1, 2.0), std::nullopt);  // the first step
  EXPECT_TRUE(odometry.Hear({4, 0, 0}, 10.2));
  EXPECT_FALSE(odometry.Hear({nan, 0, 0}, 10.3));
  EXPECT_FALSE(odometry.Hear({5, std::numeric_limits<double>::infinity(), 0}, 10.3));
  EXPECT_EQ(odometry.refused(), 2u);
  const std::optional<double> step = odometry.StepPlaces(10.4, 2.0);
  ASSERT_TRUE(step.has_value());
  EXPECT_DOUBLE_EQ(*step, 2.0);  // from (0,0,0) to the last finite (4,0,0), 2 m a place
  EXPECT_EQ(odometry.StateAt(10.4), OdometryProgress::State::kFresh);
}

TEST(OdometryProgress, StaleOdometryGivesNoStepAndTheStepAfterItStartsAfresh) {
  OdometryProgress odometry(/*timeout_s=*/1.0);
  EXPECT_EQ(odometry.StateAt(0.0), OdometryProgress::State::kNone);
  EXPECT_EQ(odometry.StepPlaces(0.0, 1.0), std::nullopt);
  EXPECT_EQ(odometry.stale_steps(), 0u);  // none heard is not stale
  odometry.Hear({0, 0, 0}, 1.0);
  EXPECT_EQ(odometry.StepPlaces(1.5, 1.0), std::nullopt);
  odometry.Hear({3, 0, 0}, 1.9);
  EXPECT_EQ(odometry.StepPlaces(2.0, 1.0), std::optional<double>(3.0));
  // Odometry stops: still a step of 0 within the timeout, then none (stale).
  EXPECT_EQ(odometry.StepPlaces(2.8, 1.0), std::optional<double>(0.0));
  EXPECT_EQ(odometry.StateAt(3.0), OdometryProgress::State::kStale);
  EXPECT_NEAR(*odometry.AgeAt(3.0), 1.1, 1e-12);
  EXPECT_EQ(odometry.StepPlaces(3.0, 1.0), std::nullopt);
  EXPECT_EQ(odometry.StepPlaces(9.0, 1.0), std::nullopt);
  EXPECT_EQ(odometry.stale_steps(), 2u);
  // Back, 50 m on: the gap's motion is not one step (the filter predicted it meanwhile).
  odometry.Hear({53, 0, 0}, 10.0);
  EXPECT_EQ(odometry.StepPlaces(10.0, 1.0), std::nullopt);
  odometry.Hear({54, 0, 0}, 10.5);
  EXPECT_EQ(odometry.StepPlaces(10.5, 1.0), std::optional<double>(1.0));
}

TEST(Conversions, TheBeliefListsEveryPlaceOrTheBestKBestFirst) {
  RowMatrixXf day;
  PlaceRecognizer r = TwoSetsWithPoses(&day);
  const Recognition rec = r.Recognize(day.row(2).transpose(), false);
  Belief all;
  ToBeliefMsg(rec, *r.layout(), r.decider(), 0, &all);
  EXPECT_EQ(all.method, "bsf");
  EXPECT_EQ(all.num_places, 6);
  ASSERT_EQ(all.place_ids.size(), 6u);
  ASSERT_EQ(all.posterior.size(), 6u);
  double sum = 0;
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(all.place_ids[static_cast<size_t>(k)], k);
    sum += all.posterior[static_cast<size_t>(k)];
  }
  EXPECT_NEAR(sum, 1.0, 1e-5);
  EXPECT_EQ(all.set_names, (std::vector<std::string>{"day", "night"}));
  ASSERT_EQ(all.set_min_distances.size(), 2u);
  EXPECT_FLOAT_EQ(all.set_min_distances[0], 0.0f);  // the query is day's place 2
  EXPECT_EQ(all.match, rec.belief.match);
  EXPECT_EQ(all.accepted, rec.belief.accepted);
  Belief best;
  ToBeliefMsg(rec, *r.layout(), r.decider(), 2, &best);
  ASSERT_EQ(best.place_ids.size(), 2u);
  EXPECT_EQ(best.place_ids[0], rec.belief.match);
  EXPECT_GE(best.posterior[0], best.posterior[1]);
  EXPECT_FLOAT_EQ(best.posterior[0], all.posterior[static_cast<size_t>(rec.belief.match)]);
}

TEST(Conversions, TheMatchCarriesItsSetAndThePlacePoseIfAnySetHasOne) {
  RowMatrixXf day;
  PlaceRecognizer r = TwoSetsWithPoses(&day);
  RecognizerOptions nn;
  nn.method = "nn:day";
  r.SetOptions(nn);
  const Recognition rec = r.Recognize(day.row(4).transpose(), false);
  Match m;
  ToMatchMsg(rec, *r.layout(), &m);
  EXPECT_EQ(m.place_id, 4);
  EXPECT_EQ(m.reference_set, "day");
  EXPECT_DOUBLE_EQ(m.confidence, rec.belief.confidence);
  ASSERT_TRUE(m.has_pose);
  EXPECT_DOUBLE_EQ(m.pose.position.x, 40.0);
  EXPECT_DOUBLE_EQ(m.pose.orientation.z, std::sin(0.2));
  // Without any pose: an identity orientation, has_pose false.
  PlaceRecognizer bare;
  bare.AddReferenceSet(MakeReferenceSet("night", RowMatrixXf::Random(6, 3)));
  Match none;
  ToMatchMsg(bare.Recognize(Eigen::VectorXf::Ones(3), false), *bare.layout(), &none);
  EXPECT_FALSE(none.has_pose);
  EXPECT_EQ(none.pose.orientation.w, 1.0);
  ReferenceSetInfo info;
  r.ReadSets([&](const ReferenceSets& sets) { info = ToInfoMsg(sets.set(0)); });
  EXPECT_EQ(info.name, "day");
  EXPECT_EQ(info.condition, "sunny");
  EXPECT_EQ(info.descriptor_type, "test_3");
  EXPECT_EQ(info.num_places, 6);
  EXPECT_EQ(info.dimension, 3);
  EXPECT_EQ(info.storage, "float32");
  EXPECT_GT(info.memory_bytes, 6u * 3u * sizeof(float));
}

TEST(Conversions, APlacePoseThatIsNotFiniteIsLeftOutOfTheMatch) {
  // The last guard before /match and tf: the sets' checks refuse such poses, so this is
  // what a broken invariant would publish.
  for (const PlacePose& bad : {PlacePose{NAN, 0, 0, 0}, PlacePose{0, INFINITY, 0, 0},
                               PlacePose{0, 0, 0, NAN}, PlacePose{1e12, 0, 0, 0}}) {
    Match m;
    EXPECT_FALSE(ToMatchPose(bad, &m));
    EXPECT_FALSE(m.has_pose);
    for (const double v : {m.pose.position.x, m.pose.position.y, m.pose.position.z,
                           m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z}) {
      EXPECT_EQ(v, 0.0);
    }
    EXPECT_EQ(m.pose.orientation.w, 1.0);
  }
  Match good;
  EXPECT_TRUE(ToMatchPose(PlacePose{1, 2, 3, 0}, &good));
  EXPECT_TRUE(good.has_pose);
  EXPECT_DOUBLE_EQ(good.pose.position.y, 2.0);
  Match none;
  EXPECT_TRUE(ToMatchPose(std::nullopt, &none));
  EXPECT_FALSE(none.has_pose);
}

TEST(Conversions, ThePlaceTransformIsTheMatchedPoseInTheMatchFrame) {
  Match match;
  match.header.frame_id = "map";
  match.header.stamp = ros::Time(3);
  match.has_pose = true;
  match.pose = ToPoseMsg(PlacePose{1.5, -2.0, 0.25, 0.5});
  const geometry_msgs::TransformStamped t = ToPlaceTransformMsg(match, ros::Time(7), "vpr_place");
  EXPECT_EQ(t.header.frame_id, "map");
  EXPECT_EQ(t.child_frame_id, "vpr_place");
  EXPECT_EQ(t.header.stamp, ros::Time(7));
  EXPECT_DOUBLE_EQ(t.transform.translation.x, 1.5);
  EXPECT_DOUBLE_EQ(t.transform.translation.y, -2.0);
  EXPECT_DOUBLE_EQ(t.transform.translation.z, 0.25);
  EXPECT_DOUBLE_EQ(t.transform.rotation.z, std::sin(0.25));  // yaw 0.5 about z
  EXPECT_DOUBLE_EQ(t.transform.rotation.w, std::cos(0.25));
}

// A Recording over a fresh data directory, with a map of one 3-d set named "day".
class RecordingTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/bsf_recording_XXXXXX";
    root_ = mkdtemp(tmpl);
    dir_ = std::make_unique<DataDirectory>(root_);
    map_.Add(MakeReferenceSet("day", RowMatrixXf::Random(4, 3)));
  }
  void TearDown() override { fs::remove_all(root_); }

  // What std::invalid_argument `f` throws (fails the test if it throws nothing).
  template <typename F>
  static std::string Refusal(F f) {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    ADD_FAILURE() << "not refused";
    return "";
  }
  static Eigen::VectorXf Row(float value) { return Eigen::VectorXf::Constant(3, value); }

  std::string root_;
  std::unique_ptr<DataDirectory> dir_;
  ReferenceSets map_;
};

TEST_F(RecordingTest, WithSaveImagesEachPlaceKeepsTheImageOfItsDescriptor) {
  // Real encoded images, each a grey level of its own: the image of the descriptor stamped
  // k has grey 10 k, whether it arrives before or after its descriptor.
  const auto jpeg = [](int grey) {
    std::vector<uchar> bytes;
    cv::imencode(".jpg", cv::Mat(8, 8, CV_8UC3, cv::Scalar::all(grey)), bytes);
    return std::string(bytes.begin(), bytes.end());
  };
  Recording rec(dir_.get());
  rec.Start("tonight", "", false, map_, RecordingPlaces::kSequential, /*save_images=*/true);
  EXPECT_TRUE(rec.saves_images());
  rec.AddImage(1.0, jpeg(10));  // before its descriptor
  rec.Add(Row(1), "", std::nullopt, std::nullopt, 1.0);
  rec.Add(Row(2), "", std::nullopt, std::nullopt, 2.0);
  rec.AddImage(2.0, jpeg(20));  // after it
  rec.AddImage(9.0, jpeg(90));  // no descriptor claims it
  EXPECT_NE(rec.Summary().find("2 kept, 2 with an image"), std::string::npos) << rec.Summary();
  const Recording::Saved saved = rec.Save(DistanceMetric::kCosine);
  EXPECT_EQ(saved.note, "");
  const ReferenceSet back = LoadReferenceSetFile(*dir_, "tonight.yaml", "");
  ASSERT_EQ(back.image_files.size(), 2u);
  // A folder of this save's own, "tonight_images.<8 characters>".
  EXPECT_EQ(back.images.rfind(dir_->path() + "/tonight_images.", 0), 0u) << back.images;
  EXPECT_EQ(back.images.size(), (dir_->path() + "/tonight_images.").size() + 8) << back.images;
  EXPECT_EQ(back.images, saved.set.images);  // the loaded set shows them too
  for (int k = 0; k < 2; ++k) {
    const cv::Mat image = cv::imread(back.images + "/" + back.image_files[static_cast<size_t>(k)]);
    ASSERT_FALSE(image.empty()) << k;
    EXPECT_NEAR(image.at<cv::Vec3b>(4, 4)[0], 10 * (k + 1), 2) << k;
  }
  // A place without its image (the first descriptor, before the image subscription
  // connected): saved without one, the others with theirs, and the answer says so.
  rec.Start("partial", "", false, map_, RecordingPlaces::kSequential, true);
  rec.Add(Row(1), "", std::nullopt, std::nullopt, 5.0);
  rec.Add(Row(2), "", std::nullopt, std::nullopt, 6.0);
  rec.AddImage(6.0, jpeg(60));
  const Recording::Saved partial = rec.Save(DistanceMetric::kCosine);
  EXPECT_NE(partial.note.find("saved 1 of its 2 places with an image: 1 had no camera image"),
            std::string::npos)
      << partial.note;
  const ReferenceSet partial_back = LoadReferenceSetFile(*dir_, "partial.yaml", "");
  ASSERT_EQ(partial_back.image_files.size(), 2u);
  EXPECT_EQ(partial_back.image_files[0], "");
  const cv::Mat second = cv::imread(partial_back.images + "/" + partial_back.image_files[1]);
  ASSERT_FALSE(second.empty());
  EXPECT_NEAR(second.at<cv::Vec3b>(4, 4)[0], 60, 2);
  EXPECT_EQ(partial.set.image_files, partial_back.image_files);
}

TEST_F(RecordingTest, SavesTheDescriptorsAsASetBelowTheDataDirectoryAndEnds) {
  Recording rec(dir_.get());
  EXPECT_FALSE(rec.recording());
  rec.Start("night/tonight", "rain", false, map_);
  EXPECT_TRUE(rec.recording());
  EXPECT_EQ(rec.name(), "night/tonight");
  rec.Add(Row(1), "");
  rec.Add(Row(2), "");
  EXPECT_EQ(rec.count(), 2);
  const Recording::Saved saved = rec.Save(DistanceMetric::kCosine);
  EXPECT_FALSE(rec.recording());
  EXPECT_EQ(rec.count(), 0);
  EXPECT_EQ(saved.path, dir_->path() + "/night/tonight.yaml");
  EXPECT_EQ(saved.set.name, "night/tonight");
  EXPECT_EQ(saved.set.condition, "rain");
  EXPECT_EQ(saved.set.distance, "cosine");
  EXPECT_EQ(saved.set.size(), 2);
  const ReferenceSet back = LoadReferenceSetFile(*dir_, "night/tonight.yaml", "");
  EXPECT_EQ(back.name, "night/tonight");
  EXPECT_EQ(back.distance, "cosine");
  EXPECT_TRUE(back.descriptors.isApprox(saved.set.descriptors));
  EXPECT_FLOAT_EQ(back.descriptors(1, 2), 2.0f);
}

TEST_F(RecordingTest, StartingTwiceIsRefusedAndKeepsTheFirst) {
  Recording rec(dir_.get());
  rec.Start("first", "", false, map_);
  rec.Add(Row(1), "");
  EXPECT_NE(Refusal([&] { rec.Start("second", "", false, map_); }).find("'first' is running"),
            std::string::npos);
  EXPECT_EQ(rec.name(), "first");
  EXPECT_EQ(rec.count(), 1);
}

TEST_F(RecordingTest, StoppingWithoutARecordingIsRefused) {
  Recording rec(dir_.get());
  EXPECT_NE(Refusal([&] { rec.Save(DistanceMetric::kEuclidean); }).find("no recording"),
            std::string::npos);
  EXPECT_NE(Refusal([&] { rec.Discard(); }).find("no recording"), std::string::npos);
  EXPECT_THROW(rec.Add(Row(1), ""), std::invalid_argument);
  EXPECT_EQ(rec.count(), 0);
}

TEST_F(RecordingTest, AnEmptyRecordingIsNotSavedAndEndsSayingWhatArrived) {
  Recording rec(dir_.get());
  rec.Start("tonight", "", false, map_, RecordingPlaces::kPose);
  rec.NoteLost("no pose: no pose received yet");
  rec.NoteLost("no pose: no pose received yet");
  const std::string why = Refusal([&] { rec.Save(DistanceMetric::kEuclidean); });
  EXPECT_NE(why.find("received 2 descriptor(s), 0 with a pose of the robot, 0 kept (lost: 2 no "
                     "pose: no pose received yet)"),
            std::string::npos)
      << why;
  EXPECT_NE(why.find("ended"), std::string::npos) << why;
  EXPECT_FALSE(rec.recording());  // nothing to keep: a later start is not refused
  EXPECT_FALSE(dir_->Exists("tonight.yaml"));
}

TEST_F(RecordingTest, DiscardEndsTheRecordingAndWritesNothing) {
  Recording rec(dir_.get());
  rec.Start("tonight", "", false, map_);
  rec.Add(Row(1), "");
  rec.Discard();
  EXPECT_FALSE(rec.recording());
  EXPECT_EQ(rec.count(), 0);
  EXPECT_TRUE(fs::is_empty(root_));
  rec.Start("tonight", "", false, map_);  // the name is free again
  EXPECT_EQ(rec.count(), 0);
}

TEST_F(RecordingTest, RefusesBadNamesTakenNamesAndNoDataDirectory) {
  Recording rec(dir_.get());
  for (const std::string bad :
       {"", ".", "..", "a/../b", "../up", "a//b", "a/", "/abs", "line\nbreak", "\xff"}) {
    EXPECT_THROW(rec.Start(bad, "", false, map_), std::invalid_argument) << bad;
    EXPECT_FALSE(rec.recording()) << bad;
  }
  // The rule of every set's name (SetNameProblem), said and shown quoted.
  for (const auto& [bad, expect] : std::vector<std::pair<std::string, std::string>>{
           {"line\nbreak", "'line\\x0abreak' holds a control character"},
           {std::string(200, 'x'), "(200 characters) is too long"},
           {std::string(5000, 'y'), "(5000 characters) is too long"},
           {"a/" + std::string(130, 'z') + "/b", "(134 characters) is too long"}}) {
    const std::string why = Refusal([&, &name = bad] { rec.Start(name, "", false, map_); });
    EXPECT_NE(why.find(expect), std::string::npos) << why;
    EXPECT_NE(why.find("1 to 128 bytes of printable UTF-8"), std::string::npos) << why;
    EXPECT_FALSE(rec.recording());
  }
  EXPECT_NE(Refusal([&] { rec.Start("day", "", true, map_); }).find("already loaded"),
            std::string::npos);
  Recording off(nullptr);
  EXPECT_NE(Refusal([&] { off.Start("tonight", "", false, map_); }).find("data_directory"),
            std::string::npos);
  EXPECT_FALSE(off.recording());
}

TEST_F(RecordingTest, ASetOnDiskIsReplacedOnlyWhenOverwriteWasAsked) {
  SaveReferenceSet(*dir_, MakeReferenceSet("old", RowMatrixXf::Random(7, 3)), "old.yaml", false);
  Recording rec(dir_.get());
  EXPECT_NE(Refusal([&] { rec.Start("old", "", false, map_); }).find("exists"), std::string::npos);
  EXPECT_FALSE(rec.recording());
  rec.Start("old", "", true, map_);
  rec.Add(Row(1), "");
  rec.Save(DistanceMetric::kEuclidean);
  EXPECT_EQ(LoadReferenceSetFile(*dir_, "old.yaml", "").size(), 1);
}

TEST_F(RecordingTest, AFailedSaveKeepsTheRecordingForAnotherTry) {
  Recording rec(dir_.get());
  rec.Start("tonight", "", false, map_);  // without overwrite
  rec.Add(Row(1), "");
  rec.Add(Row(2), "");
  // The YAML appears while recording: not replaced, the recording kept.
  SaveReferenceSet(*dir_, MakeReferenceSet("other", RowMatrixXf::Random(7, 3)), "tonight.yaml",
                   false);
  try {
    rec.Save(DistanceMetric::kEuclidean);
    ADD_FAILURE() << "replaced a set on disk without overwrite";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("received 2 descriptor(s), 2 kept; the recording is kept"),
              std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(rec.recording());
  EXPECT_EQ(rec.count(), 2);
  // Closed: the next drive is not added, and a new start says the recording is pending.
  EXPECT_THROW(rec.Add(Row(3), ""), std::invalid_argument);
  EXPECT_EQ(rec.count(), 2);
  EXPECT_NE(Refusal([&] { rec.Start("next", "", false, map_); }).find("pending"),
            std::string::npos);
  EXPECT_EQ(LoadReferenceSetFile(*dir_, "tonight.yaml", "").name, "other");
  dir_->Remove("tonight.yaml");
  EXPECT_EQ(rec.Save(DistanceMetric::kEuclidean).set.size(), 2);
  EXPECT_FALSE(rec.recording());
}

TEST_F(RecordingTest, KeepsTheDescriptorTypeAndTheMapsDimension) {
  Recording rec(dir_.get());
  rec.Start("tonight", "", false, map_);
  rec.Add(Row(1), "hog_64x32_c8_b9");
  rec.Add(Row(2), "");  // says nothing: the type stays
  // Another dimension than the map's, or a value that is not finite: refused, and its type
  // is not taken.
  EXPECT_THROW(rec.Add(Eigen::VectorXf::Ones(5), "other"), std::invalid_argument);
  EXPECT_THROW(rec.Add(Row(NAN), "other"), std::invalid_argument);
  EXPECT_EQ(rec.count(), 2);
  EXPECT_EQ(rec.Save(DistanceMetric::kEuclidean).set.descriptor_type, "hog_64x32_c8_b9");
  EXPECT_EQ(LoadReferenceSetFile(*dir_, "tonight.yaml", "").descriptor_type, "hog_64x32_c8_b9");
  // A new recording starts without a type; with no set loaded it takes any dimension.
  rec.Start("later", "", false, ReferenceSets());
  rec.Add(Eigen::VectorXf::Ones(5), "");
  EXPECT_EQ(rec.Save(DistanceMetric::kEuclidean).set.descriptor_type, "");
}

TEST_F(RecordingTest, RefusesLoadingTheSetBeingRecordedAndReportsItInDiagnostics) {
  Recording rec(dir_.get());
  diagnostic_updater::DiagnosticStatusWrapper idle;
  rec.Diagnose(idle);
  EXPECT_TRUE(idle.values.empty());
  EXPECT_NO_THROW(rec.CheckNotRecording("tonight"));
  rec.Start("tonight", "", false, map_);
  rec.Add(Row(1), "");
  EXPECT_NE(Refusal([&] { rec.CheckNotRecording("tonight"); }).find("being recorded"),
            std::string::npos);
  EXPECT_NO_THROW(rec.CheckNotRecording("day"));
  diagnostic_updater::DiagnosticStatusWrapper status;
  rec.Diagnose(status);
  ASSERT_EQ(status.values.size(), 2u);
  EXPECT_EQ(status.values[0].key, "recording");
  EXPECT_EQ(status.values[0].value,
            "tonight (places by sequential): received 1 descriptor(s), 1 kept");
  EXPECT_EQ(status.values[1].key, "recording size");
  EXPECT_EQ(status.values[1].value, "1 descriptors of 200000, 0.0 MB of 2000.0 MB");
}

TEST_F(RecordingTest, ByPoseAndByLocalisationOnAMapWithPoses) {
  ReferenceSets posed;
  ReferenceSet summer = MakeReferenceSet("summer", RowMatrixXf::Random(4, 3));
  summer.poses = {{0, 0, 0, 0}, {1, 0, 0, 0}, {2, 0, 0, 0}, {3, 0, 0, 0}};
  posed.Add(summer);
  PlaceIndexOptions options;
  options.association_radius_m = 0.4;
  Recording rec(dir_.get());
  rec.Start("by_pose", "", false, posed, RecordingPlaces::kPose);
  EXPECT_THROW(rec.Add(Row(9), ""), std::invalid_argument);  // no pose: left out
  for (int i = 0; i <= 6; ++i) rec.Add(Row(float(i + 1)), "t", PlacePose{0.5 * i, 0.1, 0, 0});
  const Recording::Saved saved = rec.Save(DistanceMetric::kEuclidean, &posed, options);
  EXPECT_EQ(saved.set.place_ids, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_FLOAT_EQ(saved.set.descriptors(3, 0), 7.0f);  // the descriptor at x = 3
  EXPECT_EQ(saved.set.poses.size(), 4u);
  EXPECT_EQ(saved.set.descriptor_type, "t");
  // A sequential recording whose poses put place 2 at 500 m is refused, and kept.
  rec.Start("elsewhere", "", false, posed);
  for (int i = 0; i < 3; ++i) rec.Add(Row(1), "", PlacePose{i == 2 ? 502.0 : i, 0, 0, 0});
  EXPECT_NE(Refusal([&] {
              rec.Save(DistanceMetric::kEuclidean, &posed, options);
            }).find("puts place 2 500.0 m from where the loaded sets have it"),
            std::string::npos);
  EXPECT_TRUE(rec.recording());
  rec.Discard();
  // By localisation: needs a loaded set; keeps the accepted places.
  ReferenceSets empty;
  EXPECT_NE(Refusal([&] {
              rec.Start("loc", "", false, empty, RecordingPlaces::kLocalized);
            }).find("needs a loaded reference set"),
            std::string::npos);
  rec.Start("loc", "", false, posed, RecordingPlaces::kLocalized);
  rec.Add(Row(1), "", std::nullopt, LocalizedPlace{2, 3.0});
  const Recording::Saved loc = rec.Save(DistanceMetric::kEuclidean, &posed, options);
  EXPECT_EQ(loc.set.place_ids, std::vector<int>{2});
  EXPECT_EQ(loc.set.poses[0].x_m, 2.0);
}

TEST_F(RecordingTest, ARobotPoseNotFiniteOrAbsurdLeavesOutItsDescriptorAndTheRecordingGoesOn) {
  Recording rec(dir_.get());
  for (const RecordingPlaces places : {RecordingPlaces::kPose, RecordingPlaces::kSequential}) {
    rec.Start("drive", "", /*overwrite=*/true, map_, places);
    rec.Add(Row(1), "", PlacePose{0, 0, 0, 0});
    EXPECT_NE(Refusal([&] {
                rec.Add(Row(2), "", PlacePose{NAN, 0, 0, 0});
              }).find("x = nan"),
              std::string::npos);
    EXPECT_NE(Refusal([&] {
                rec.Add(Row(3), "", PlacePose{1, 1e12, 0, 0});
              }).find("y = 1e+12"),
              std::string::npos);
    EXPECT_NE(Refusal([&] {
                rec.Add(Row(4), "", PlacePose{1, 0, 0, INFINITY});
              }).find("yaw"),
              std::string::npos);
    rec.Add(Row(5), "", PlacePose{2, 0, 0, 0});
    EXPECT_EQ(rec.count(), 2);
    // One cause for every bad value: the counts stay a few lines.
    EXPECT_EQ(rec.counts().lost.size(), 1u) << rec.Summary();
    EXPECT_EQ(rec.counts().received, 5);
    const Recording::Saved saved = rec.Save(DistanceMetric::kEuclidean);
    EXPECT_EQ(saved.set.poses.size(), 2u) << ToString(places);
    for (const PlacePose& p : saved.set.poses) EXPECT_EQ(PoseProblem(p), "");
  }
}

}  // namespace
}  // namespace bsf_vpr
