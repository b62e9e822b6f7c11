// Tests of the match image's reference image limits: the size read from PNG, JPEG and BMP
// headers, the refusal of an image whose header claims more pixels than allowed (before
// decoding: a small PNG can claim gigapixels), and the cache of decoded images.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <vector>

#include "src/ros/view/reference_image.h"

namespace bsf_vpr {
namespace {

std::string Encoded(const std::string& ext, int w, int h) {
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(10, 120, 200));
  std::vector<unsigned char> bytes;
  EXPECT_TRUE(cv::imencode(ext, img, bytes));
  return std::string(bytes.begin(), bytes.end());
}

void PutBigEndian32(std::string* s, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) (*s)[at + i] = static_cast<char>((v >> (24 - 8 * i)) & 0xFF);
}

// The offset of the first start-of-frame marker (FF C0 or FF C2) of a JPEG.
size_t FrameMarker(const std::string& jpeg) {
  for (size_t i = 2; i + 1 < jpeg.size(); ++i) {
    const auto m = static_cast<unsigned char>(jpeg[i + 1]);
    if (static_cast<unsigned char>(jpeg[i]) == 0xFF && (m == 0xC0 || m == 0xC2)) return i;
  }
  return std::string::npos;
}

std::string Refusal(const std::string& bytes, const ReferenceImageLimits& limits) {
  try {
    DecodeReferenceImage(bytes, limits);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(ReferenceImage, ReadsTheSizeFromPngJpegAndBmpHeaders) {
  EXPECT_EQ(ImageHeaderSize(Encoded(".png", 37, 21)), cv::Size(37, 21));
  EXPECT_EQ(ImageHeaderSize(Encoded(".jpg", 37, 21)), cv::Size(37, 21));
  EXPECT_EQ(ImageHeaderSize(Encoded(".bmp", 37, 21)), cv::Size(37, 21));
  EXPECT_FALSE(ImageHeaderSize(Encoded(".ppm", 37, 21)));
  EXPECT_FALSE(ImageHeaderSize(""));
  EXPECT_FALSE(ImageHeaderSize("\x89PNG\r\n\x1a\n"));  // cut short
  EXPECT_FALSE(ImageHeaderSize("\xFF\xD8\xFF\xE0"));   // a JPEG cut before its frame
  const std::string png = Encoded(".png", 5, 4);
  for (size_t n = 0; n < png.size(); ++n) {  // every cut is refused or reads the size
    const auto size = ImageHeaderSize(png.substr(0, n));
    if (size) {
      EXPECT_EQ(*size, cv::Size(5, 4)) << n;
    }
  }
}

TEST(ReferenceImage, DecodesAnImageWithinTheLimits) {
  const ReferenceImageLimits limits;
  for (const char* ext : {".png", ".jpg", ".bmp"}) {
    const cv::Mat image = DecodeReferenceImage(Encoded(ext, 64, 48), limits);
    EXPECT_EQ(image.size(), cv::Size(64, 48)) << ext;
    EXPECT_EQ(image.type(), CV_8UC3) << ext;
  }
}

// A 100-byte PNG whose header claims 100000 x 100000 pixels (30 GB decoded) is refused
// from its header, without decoding; so is a JPEG claiming 60000 x 60000.
TEST(ReferenceImage, RefusesAnImageWhoseHeaderClaimsTooManyPixels) {
  std::string png = Encoded(".png", 2, 2);
  PutBigEndian32(&png, 16, 100000);
  PutBigEndian32(&png, 20, 100000);
  ASSERT_LT(png.size(), 200u);
  const ReferenceImageLimits limits;  // 16.8 million pixels
  std::string why = Refusal(png, limits);
  EXPECT_NE(why.find("claims 100000 x 100000 = 10000000000 pixels, more than the 16777216 "
                     "allowed (not decoded)"),
            std::string::npos)
      << why;

  std::string jpeg = Encoded(".jpg", 8, 8);
  const size_t frame = FrameMarker(jpeg);
  ASSERT_NE(frame, std::string::npos);
  for (size_t at : {frame + 5, frame + 7}) {  // height, width: 60000 = 0xEA60
    jpeg[at] = static_cast<char>(0xEA);
    jpeg[at + 1] = static_cast<char>(0x60);
  }
  EXPECT_EQ(ImageHeaderSize(jpeg), cv::Size(60000, 60000));
  why = Refusal(jpeg, limits);
  EXPECT_NE(why.find("claims 60000 x 60000"), std::string::npos) << why;

  // The limit is a parameter: a smaller one refuses a real 64 x 48 image.
  ReferenceImageLimits tight;
  tight.max_pixels = 64 * 48 - 1;
  EXPECT_NE(Refusal(Encoded(".png", 64, 48), tight).find("64 x 48 = 3072 pixels"),
            std::string::npos);
  tight.max_pixels = 64 * 48;
  EXPECT_EQ(Refusal(Encoded(".png", 64, 48), tight), "");
}

TEST(ReferenceImage, RefusesFormatsWhoseSizeIsNotCheckedAndBrokenFiles) {
  const ReferenceImageLimits limits;
  EXPECT_NE(Refusal(Encoded(".ppm", 8, 8), limits).find("not a PNG, JPEG or BMP"),
            std::string::npos);
  EXPECT_NE(Refusal("plain text", limits).find("not a PNG, JPEG or BMP"), std::string::npos);
  std::string png = Encoded(".png", 8, 8);
  PutBigEndian32(&png, 16, 0);
  EXPECT_NE(Refusal(png, limits).find("claims 0 x 8 pixels"), std::string::npos);
  const std::string cut = Encoded(".png", 8, 8).substr(0, 40);  // header whole, data cut
  EXPECT_NE(Refusal(cut, limits).find("cannot be decoded"), std::string::npos);
}

TEST(ReferenceImage, CacheLoadsOncePerPathUntilTheEntryExpires) {
  using Clock = std::chrono::steady_clock;
  ReferenceImageCache cache(2, 100, std::chrono::seconds(30));
  int loads = 0;
  const auto image = [&]() {
    ++loads;
    return cv::Mat(400, 600, CV_8UC3, cv::Scalar(1, 2, 3));
  };
  const auto refused = [&]() -> cv::Mat {
    ++loads;
    throw std::runtime_error("reference set 's' row 3: too large");
  };
  const Clock::time_point t0 = Clock::now();
  ReferenceImageCache::Entry e = cache.Get("a", image, t0);
  EXPECT_EQ(e.image.size(), cv::Size(150, 100));  // reduced to 100 rows, aspect kept
  EXPECT_EQ(e.error, "");
  cache.Get("a", image, t0 + std::chrono::seconds(29));
  EXPECT_EQ(loads, 1);
  e = cache.Get("b", refused, t0);  // a refusal is kept too: the file is not read again
  EXPECT_TRUE(e.image.empty());
  EXPECT_EQ(e.error, "reference set 's' row 3: too large");
  cache.Get("b", refused, t0 + std::chrono::seconds(1));
  EXPECT_EQ(loads, 2);
  cache.Get("a", image, t0 + std::chrono::seconds(31));  // expired: read again
  EXPECT_EQ(loads, 3);
  cache.Get("c", image, t0);  // evicts the least recently used, "b"
  cache.Get("b", refused, t0 + std::chrono::seconds(2));
  EXPECT_EQ(loads, 5);
}

}  // namespace
}  // namespace bsf_vpr
