#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/image/image_descriptor.h"

namespace bsf_vpr {
namespace {

TEST(PatchNorm, EveryPatchHasZeroMeanAndUnitVariance) {
  cv::Mat img(48, 100, CV_8UC3);
  cv::randu(img, cv::Scalar::all(0), cv::Scalar::all(255));
  PatchNormOptions opt;  // 64 x 32, patch 8
  const Eigen::VectorXf d = DescribePatchNormalized(img, opt);
  ASSERT_EQ(d.size(), 64 * 32);
  for (int py = 0; py < 4; ++py) {
    for (int px = 0; px < 8; ++px) {
      double sum = 0, sq = 0;
      for (int y = 0; y < 8; ++y) {
        for (int x = 0; x < 8; ++x) {
          const float v = d((py * 8 + y) * 64 + px * 8 + x);
          sum += v;
          sq += v * v;
        }
      }
      EXPECT_NEAR(sum / 64, 0.0, 1e-5);
      EXPECT_NEAR(sq / 64, 1.0, 1e-4);
    }
  }
}

TEST(PatchNorm, ConstantImagesGiveZerosAndBrightnessIsRemoved) {
  const cv::Mat black = cv::Mat::zeros(32, 64, CV_8UC1);
  EXPECT_EQ(DescribePatchNormalized(black, {}).norm(), 0.0f);
  cv::Mat img(32, 64, CV_8UC1);
  cv::randu(img, 0, 100);
  cv::Mat brighter = img + 60;
  EXPECT_TRUE(
      DescribePatchNormalized(img, {}).isApprox(DescribePatchNormalized(brighter, {}), 1e-5f));
}

TEST(PatchNorm, RefusesBadImagesAndOptions) {
  EXPECT_THROW(DescribePatchNormalized(cv::Mat(), {}), std::invalid_argument);
  EXPECT_THROW(DescribePatchNormalized(cv::Mat::zeros(8, 8, CV_32FC1), {}), std::invalid_argument);
  EXPECT_THROW(DescribePatchNormalized(cv::Mat::zeros(8, 8, CV_8UC2), {}), std::invalid_argument);
  PatchNormOptions bad;
  bad.patch_size_px = 0;
  try {
    bad.Validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("patch_size_px"), std::string::npos);
  }
}

TEST(PatchNorm, MatchesRealNordlandSummerToWinterFarAboveChance) {
  // Shipped real data: 1500 frame-aligned frames per season (NRK Nordlandsbanen).
  const std::string root = std::string(BSF_SOURCE_DIR) + "/data/nordland_64x32/";
  const RowMatrixXf summer = DescribeImageFolder(root + "summer", {});
  const RowMatrixXf winter = DescribeImageFolder(root + "winter", {});
  ASSERT_EQ(summer.rows(), 1500);
  ASSERT_EQ(winter.rows(), 1500);
  const RowMatrixXf d =
      ComputeDistances(DistanceMetric::kEuclidean, summer, MakeReferenceSet("winter", winter));
  int correct = 0;
  for (int q = 0; q < d.rows(); ++q) {
    Eigen::Index m;
    d.row(q).minCoeff(&m);
    correct += std::abs(static_cast<int>(m) - q) <= 2 ? 1 : 0;
  }
  // Chance is 5/1500; nearest neighbour on this descriptor gets a sizeable fraction right.
  EXPECT_GT(correct, 150) << correct << " of 1500";
}

}  // namespace
}  // namespace bsf_vpr
