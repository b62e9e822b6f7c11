// The check every node makes of a sensor_msgs/Image before any conversion reads it
// (descriptor_ingest before describing it, the fusion node before showing or recording it).
#pragma once

#include <sensor_msgs/Image.h>

#include <string>

namespace bsf_vpr {

// Why an image message cannot be converted safely ("" if it can): zero or huge sizes, an
// unknown encoding, a step shorter than a row, or less data than step x height. Computed in
// 64 bits, before any conversion reads the data.
std::string ImageProblem(const sensor_msgs::Image& image);

}  // namespace bsf_vpr
