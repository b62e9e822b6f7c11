// The reference image of the match image (match_image.h), read and decoded within limits:
// a reference set's YAML may name any file as a row's image, and neither a huge file nor a
// small one that decodes to gigabytes (a PNG's header may claim 100000 x 100000 pixels) may
// stall the beliefs or exhaust the memory. ROS-free (OpenCV only).
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

namespace bsf_vpr {

struct ReferenceImageLimits {
  uint64_t max_bytes = 20ull << 20;  // of the file, refused before it is read
  uint64_t max_pixels = 4096 * 4096;  // width x height from the header, refused before decoding
};

// Width and height from the header of a PNG, JPEG or BMP held in `bytes`, or none when
// `bytes` is none of these or its header is cut short or broken.
std::optional<cv::Size> ImageHeaderSize(const std::string& bytes);

// `bytes` decoded as an 8-bit BGR image. Throws std::runtime_error saying why when it is
// not a PNG, JPEG or BMP (the formats whose size is read before decoding), its header
// claims more than limits.max_pixels pixels (or a zero or negative side), or it cannot be
// decoded.
cv::Mat DecodeReferenceImage(const std::string& bytes, const ReferenceImageLimits& limits);

// The last few reference images shown, by file path, decoded and reduced to at most
// `max_rows` rows (the panel is smaller), or the reason they cannot be shown: the same
// place matched again costs neither a read nor a decode, and a refused file is not read
// again at every belief. An entry is read again once it is older than `max_age`, so a file
// replaced on disk is shown within that time.
class ReferenceImageCache {
 public:
  struct Entry {
    cv::Mat image;      // empty when refused
    std::string error;  // why, when refused
  };

  ReferenceImageCache(size_t capacity, int max_rows, std::chrono::steady_clock::duration max_age)
      : capacity_(capacity), max_rows_(max_rows), max_age_(max_age) {}

  // The entry of `path`, made by `load` (which returns the image or throws) when it is not
  // held or has expired. `now` is injected for tests.
  Entry Get(const std::string& path, const std::function<cv::Mat()>& load,
                   std::chrono::steady_clock::time_point now);

 private:
  struct Held {
    std::string path;
    std::chrono::steady_clock::time_point made;
    Entry entry;
  };
  size_t capacity_;
  int max_rows_;
  std::chrono::steady_clock::duration max_age_;
  std::deque<Held> held_;  // newest first
};

}  // namespace bsf_vpr
