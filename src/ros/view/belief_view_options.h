// Options of what rviz shows of the belief (belief_markers.h, belief_view.h), read from the
// fusion parameters of the same names (fusion_params.cpp documents them).
#pragma once

#include <string>

namespace bsf_vpr {

struct BeliefViewOptions {
  std::string map_frame = "map";            // frame of the place poses and the markers
  std::string view_frame = "bsf_vpr_view";  // tf child of map_frame the rviz view follows
  double marker_spacing_m = 0;  // places without poses: spacing; 0: spread over view_size_m
  double view_size_m = 100;     // metres the shipped rviz view frames (> 0)
  bool log_scale = false;       // bar heights: log10 of the posterior instead of linear
  // The match image's reference image: larger files, and images whose header claims more
  // pixels, are not read (decoded) but named in a warning (reference_image.h).
  double match_image_max_file_mb = 20;      // MiB (> 0)
  double match_image_max_megapixels = 16;   // million pixels, width x height (> 0)
};

// Decades of posterior the log scale spans: a place 10^-4 as probable as the best has height 0.
constexpr double kLogDecades = 4;
}  // namespace bsf_vpr
