// rviz markers that draw the belief along the route: every place as a small grey point
// (at its pose, or on a straight line marker_spacing_m apart when it has none), the places
// of the belief coloured from blue (low) to red (high posterior), and the match as a large
// sphere, green when accepted and orange when not.
#pragma once

#include <bsf_vpr/Belief.h>
#include <visualization_msgs/MarkerArray.h>

#include <string>

#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {

visualization_msgs::MarkerArray MakeBeliefMarkers(const ReferenceMap& map, const Belief& belief,
                                                  const std::string& frame, double spacing_m);

}  // namespace bsf_vpr
