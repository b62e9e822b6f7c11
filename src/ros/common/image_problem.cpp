#include "src/ros/common/image_problem.h"

#include <sensor_msgs/image_encodings.h>

#include <cstdint>

namespace bsf_vpr {

std::string ImageProblem(const sensor_msgs::Image& m) {
  constexpr uint64_t kMaxSide = 1 << 15;
  if (m.width == 0 || m.height == 0)
    return "empty image (" + std::to_string(m.width) + " x " + std::to_string(m.height) + ")";
  if (m.width > kMaxSide || m.height > kMaxSide) {
    return "image of " + std::to_string(m.width) + " x " + std::to_string(m.height) +
           " pixels is larger than " + std::to_string(kMaxSide) + " a side";
  }
  uint64_t channels = 0, bits = 0;
  try {
    channels = static_cast<uint64_t>(sensor_msgs::image_encodings::numChannels(m.encoding));
    bits = static_cast<uint64_t>(sensor_msgs::image_encodings::bitDepth(m.encoding));
  } catch (const std::exception&) {
    return "unknown image encoding '" + m.encoding.substr(0, 40) + "'";
  }
  const uint64_t row_bytes = static_cast<uint64_t>(m.width) * channels * ((bits + 7) / 8);
  if (row_bytes == 0) return "unknown image encoding '" + m.encoding.substr(0, 40) + "'";
  if (static_cast<uint64_t>(m.step) < row_bytes) {
    return "step " + std::to_string(m.step) + " is shorter than a row of " +
           std::to_string(m.width) + " " + m.encoding + " pixels (" + std::to_string(row_bytes) +
           " bytes)";
  }
  const uint64_t need = static_cast<uint64_t>(m.step) * m.height;
  if (need > m.data.size()) {
    return "image data holds " + std::to_string(m.data.size()) + " bytes, step x height needs " +
           std::to_string(need);
  }
  return "";
}

}  // namespace bsf_vpr
