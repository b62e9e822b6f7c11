#include "src/ros/view/reference_image.h"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace bsf_vpr {
namespace {

uint32_t BigEndian16(const unsigned char* p) { return (uint32_t{p[0]} << 8) | p[1]; }
uint32_t BigEndian32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}
int32_t LittleEndian32(const unsigned char* p) {
  return static_cast<int32_t>(uint32_t{p[0]} | (uint32_t{p[1]} << 8) | (uint32_t{p[2]} << 16) |
                              (uint32_t{p[3]} << 24));
}
uint32_t LittleEndian16(const unsigned char* p) { return uint32_t{p[0]} | (uint32_t{p[1]} << 8); }

// A side as an int, or -1 when it does not fit one (the pixel check refuses it then).
int Side(int64_t v) { return v < 0 || v > INT32_MAX ? -1 : static_cast<int>(v); }

std::optional<cv::Size> PngSize(const unsigned char* b, size_t n) {
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (n < 24 || !std::equal(kSignature, kSignature + 8, b)) return std::nullopt;
  if (!std::equal(b + 12, b + 16, reinterpret_cast<const unsigned char*>("IHDR"))) {
    return std::nullopt;  // the first chunk must be IHDR
  }
  return cv::Size(Side(BigEndian32(b + 16)), Side(BigEndian32(b + 20)));
}

// Walks the markers up to the first start-of-frame, which holds the size.
std::optional<cv::Size> JpegSize(const unsigned char* b, size_t n) {
  if (n < 4 || b[0] != 0xFF || b[1] != 0xD8) return std::nullopt;
  size_t pos = 2;
  while (pos < n) {
    if (b[pos] != 0xFF) return std::nullopt;
    while (pos < n && b[pos] == 0xFF) ++pos;  // fill bytes
    if (pos >= n) return std::nullopt;
    const unsigned char marker = b[pos++];
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8)) continue;  // no length
    if (marker == 0xD9 || marker == 0xDA) return std::nullopt;  // end or scan before a frame
    if (pos + 2 > n) return std::nullopt;
    const uint32_t length = BigEndian16(b + pos);
    if (length < 2) return std::nullopt;
    const bool frame =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (frame) {
      if (length < 7 || pos + 7 > n) return std::nullopt;
      return cv::Size(Side(BigEndian16(b + pos + 5)), Side(BigEndian16(b + pos + 3)));
    }
    pos += length;
  }
  return std::nullopt;
}

std::optional<cv::Size> BmpSize(const unsigned char* b, size_t n) {
  if (n < 26 || b[0] != 'B' || b[1] != 'M') return std::nullopt;
  if (LittleEndian32(b + 14) == 12) {  // OS/2 core header: 16-bit sides
    return cv::Size(Side(LittleEndian16(b + 18)), Side(LittleEndian16(b + 20)));
  }
  const int64_t height = LittleEndian32(b + 22);  // negative: stored top-down
  return cv::Size(Side(LittleEndian32(b + 18)), Side(height < 0 ? -height : height));
}

}  // namespace

std::optional<cv::Size> ImageHeaderSize(const std::string& bytes) {
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const size_t n = bytes.size();
  if (auto size = PngSize(b, n)) return size;
  if (auto size = JpegSize(b, n)) return size;
  return BmpSize(b, n);
}

cv::Mat DecodeReferenceImage(const std::string& bytes, const ReferenceImageLimits& limits) {
  const std::optional<cv::Size> size = ImageHeaderSize(bytes);
  if (!size) {
    throw std::runtime_error(
        "not a PNG, JPEG or BMP file (the formats whose size is checked before decoding), or "
        "its header is broken");
  }
  if (size->width <= 0 || size->height <= 0) {
    throw std::runtime_error("its header claims " + std::to_string(size->width) + " x " +
                             std::to_string(size->height) + " pixels");
  }
  const uint64_t pixels = uint64_t(size->width) * uint64_t(size->height);
  if (pixels > limits.max_pixels) {
    throw std::runtime_error("its header claims " + std::to_string(size->width) + " x " +
                             std::to_string(size->height) + " = " + std::to_string(pixels) +
                             " pixels, more than the " + std::to_string(limits.max_pixels) +
                             " allowed (not decoded)");
  }
  cv::Mat image;
  try {
    image = cv::imdecode(
        cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data())),
        cv::IMREAD_COLOR);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot be decoded: " + std::string(e.what()));
  }
  if (image.empty()) throw std::runtime_error("cannot be decoded (not a readable image)");
  if (image.cols != size->width || image.rows != size->height) {  // cannot happen: a guard
    throw std::runtime_error("decoded as " + std::to_string(image.cols) + " x " +
                             std::to_string(image.rows) + ", not the header's size");
  }
  return image;
}

ReferenceImageCache::Entry ReferenceImageCache::Get(const std::string& path,
                                                    const std::function<cv::Mat()>& load,
                                                    std::chrono::steady_clock::time_point now) {
  const auto it = std::find_if(held_.begin(), held_.end(),
                               [&](const Held& h) { return h.path == path; });
  if (it != held_.end()) {
    Held found = std::move(*it);
    held_.erase(it);
    if (now - found.made < max_age_) {
      held_.push_front(std::move(found));
      return held_.front().entry;
    }
  }
  Held made{path, now, {}};
  try {
    cv::Mat image = load();
    if (image.rows > max_rows_) {
      const double scale = double(max_rows_) / image.rows;
      const int cols = std::max(1, static_cast<int>(image.cols * scale + 0.5));
      cv::resize(image, made.entry.image, cv::Size(cols, max_rows_), 0, 0, cv::INTER_AREA);
    } else {
      made.entry.image = image;
    }
  } catch (const std::exception& e) {
    made.entry.image.release();
    made.entry.error = e.what();
  }
  held_.push_front(std::move(made));
  while (held_.size() > capacity_) held_.pop_back();
  return held_.front().entry;
}

}  // namespace bsf_vpr
