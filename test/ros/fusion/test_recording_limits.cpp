// A recording's limits (it warns at 90%, then refuses and counts) and its save in three
// steps (the recording closed while the set is built and written without the node's lock).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <thread>

#include "bsf_vpr/io/reference_set_io.h"
#include "src/ros/fusion/recording.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;

class RecordingLimitsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/bsf_recording_limits_XXXXXX";
    root_ = mkdtemp(tmpl);
    dir_ = std::make_unique<DataDirectory>(root_);
  }
  void TearDown() override { fs::remove_all(root_); }
  static Eigen::VectorXf Row(float value) { return Eigen::VectorXf::Constant(4, value); }

  std::string root_;
  std::unique_ptr<DataDirectory> dir_;
  PlaceLayout none_;
};

TEST_F(RecordingLimitsTest, WarnsOnceAtNinetyPercentThenRefusesAndCountsTheRest) {
  Recording rec(dir_.get(), RecordingLimits{/*max_descriptors=*/10, /*max_bytes=*/1 << 20});
  rec.Start("long", "", false, none_);
  std::vector<std::string> warnings;
  for (int i = 0; i < 10; ++i) {
    const std::string w = rec.Add(Row(static_cast<float>(i + 1)), "");
    if (!w.empty()) warnings.push_back(w);
    EXPECT_EQ(rec.LimitProblem().empty(), i < 8) << i;
  }
  ASSERT_EQ(warnings.size(), 1u);  // at the ninth
  EXPECT_NE(warnings[0].find("90% of its limits"), std::string::npos) << warnings[0];
  EXPECT_NE(rec.LimitProblem().find("full: 10 of recording_max_descriptors 10"), std::string::npos)
      << rec.LimitProblem();
  for (int i = 0; i < 3; ++i) {
    try {
      rec.Add(Row(1), "");
      ADD_FAILURE() << "a descriptor beyond the limit was kept";
    } catch (const RecordingFull& e) {
      EXPECT_NE(std::string(e.what()).find("is full"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(rec.count(), 10);
  EXPECT_NE(rec.Summary().find("3 refused: the recording is full"), std::string::npos)
      << rec.Summary();
  // What it holds is saved; the next recording starts empty.
  EXPECT_EQ(rec.Save(DistanceMetric::kEuclidean).set.size(), 10);
  rec.Start("next", "", false, none_);
  EXPECT_EQ(rec.Add(Row(1), ""), "");
  EXPECT_EQ(rec.LimitProblem(), "");
}

TEST_F(RecordingLimitsTest, TheBytesLimitCountsTheDescriptorsFloats) {
  // 4-d float rows: 16 bytes each; 100 bytes hold 6.
  Recording rec(dir_.get(), RecordingLimits{/*max_descriptors=*/1000, /*max_bytes=*/100});
  rec.Start("wide", "", false, none_);
  for (int i = 0; i < 6; ++i) rec.Add(Row(static_cast<float>(i + 1)), "");
  EXPECT_THROW(rec.Add(Row(1), ""), RecordingFull);
  EXPECT_EQ(rec.count(), 6);
  EXPECT_NE(rec.LimitProblem().find("recording_max_megabytes"), std::string::npos);
}

TEST_F(RecordingLimitsTest, WhileBeingSavedTheRecordingTakesNothingAndRefusesAnotherSave) {
  Recording rec(dir_.get());
  rec.Start("drive", "", false, none_);
  rec.Add(Row(1), "");
  rec.Add(Row(2), "");
  Recording::SaveJob job = rec.BeginSave(DistanceMetric::kEuclidean, nullptr);
  EXPECT_TRUE(rec.saving());
  EXPECT_FALSE(rec.accepting());
  EXPECT_THROW(rec.Add(Row(3), ""), std::invalid_argument);
  EXPECT_THROW(rec.BeginSave(DistanceMetric::kEuclidean, nullptr), std::invalid_argument);
  EXPECT_THROW(rec.Discard(), std::invalid_argument);
  EXPECT_THROW(rec.Start("other", "", false, none_), std::invalid_argument);
  EXPECT_THROW(rec.CheckNotRecording("drive"), std::invalid_argument);  // its name is taken
  // Built and written on another thread, as the fusion node does without its lock.
  std::thread([&] { rec.RunSave(job); }).join();
  EXPECT_TRUE(dir_->Exists("drive.yaml"));  // written before EndSave
  const Recording::Saved saved = rec.EndSave(std::move(job));
  EXPECT_FALSE(rec.recording());
  EXPECT_EQ(saved.set.size(), 2);
  EXPECT_EQ(LoadReferenceSetFile(*dir_, "drive.yaml", "").size(), 2);
}

TEST_F(RecordingLimitsTest, AFailedWriteKeepsTheRecordingPendingAsSaveDoes) {
  Recording rec(dir_.get());
  rec.Start("blocked/drive", "", false, none_);
  rec.Add(Row(1), "");
  // A file where the folder must go: the write fails.
  dir_->WriteAtomically("blocked", "not a folder");
  Recording::SaveJob job = rec.BeginSave(DistanceMetric::kEuclidean, nullptr);
  rec.RunSave(job);
  EXPECT_THROW(rec.EndSave(std::move(job)), std::runtime_error);
  EXPECT_FALSE(rec.saving());
  EXPECT_TRUE(rec.recording());
  EXPECT_FALSE(rec.pending_reason().empty());
  EXPECT_EQ(rec.count(), 1);
  rec.Discard();
  EXPECT_FALSE(rec.recording());
}

}  // namespace
}  // namespace bsf_vpr
