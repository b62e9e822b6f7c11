// The "match image" the fusion node publishes for rviz, one per query: the query image beside
// the matched reference image, a text block, and a plot of the posterior over places below.
// Pure rendering (OpenCV core/imgproc, no ROS): the node converts the result to a
// sensor_msgs/Image.
//
//   [ query panel ]      [# reference panel #]   frame: green (accepted) / orange (not)
//      query_note            reference_note
//   label_lines[0]                                headline, in the frame colour
//   label_lines[1..]                              white on dark
//                       v 70                      match marker and place number
//         .            .|||.                      bars per place: P / max P, log10 P, or rank
//   ______:____________|||||___________           (a column shows its tallest place)
//                    ^                            cyan tick: a true place
//   0     place (bars: P, top 0.97, cyan: true)     99
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "src/ros/view/belief_view_options.h"  // kLogDecades, shared with the markers

namespace bsf_vpr {

// What one match image shows. Images are CV_8UC3 BGR or CV_8UC1 (drawn as grey), any size;
// the caller keeps ownership (they are only read).
struct MatchImageContent {
  cv::Mat query;                         // empty when no query image arrived
  std::string query_note;                // one line under the query panel, e.g. "query";
                                         // written inside the placeholder when no image
  cv::Mat reference;                     // empty when the set names no images
  std::string reference_note;            // e.g. "summer, place 812"
  std::vector<std::string> label_lines;  // text block; [0] is the headline
  bool accepted = false;                 // frame and headline green when accepted, else orange
  int num_places = 0;                    // N >= 1: the plot's x axis is place 0..N-1
  std::vector<int> place_ids;            // places of the posterior (all N or top K), best first
  std::vector<float> posterior;          // P per place_ids entry (finite, >= 0), or empty for
                                         // distance methods: then bars show the rank of
                                         // place_ids (best = tallest)
  int match = -1;                        // matched place in [0, N), or -1 for none
  std::vector<int> true_places;          // ground-truth places in [0, N); may be empty
};

struct MatchImageOptions {
  int panel_height_px = 240;     // height the query and reference are scaled to (aspect kept)
  int max_panel_width_px = 960;  // a wider image is scaled down to this width instead
  int plot_height_px = 120;      // whole plot strip: marker row, bars, axis, tick labels
  int text_height_px = 14;       // height of label text (FONT_HERSHEY_SIMPLEX); notes and
                                 // ticks are drawn at 6/7 of it
  bool log_scale = false;  // bars show log10 P over the kLogDecades below the max, not P / max
  void Validate() const;   // throws std::invalid_argument naming the bad field
};

// Where the parts lie in a rendered image (pixels, image coordinates).
struct MatchImageLayout {
  cv::Size image;      // the whole rendered image
  cv::Rect query;      // the scaled query, or its placeholder
  cv::Rect reference;  // the scaled reference, or its placeholder; the frame lies outside it
  cv::Rect label;      // the text block (height 0 without label_lines)
  cv::Rect plot;       // data area: place p fills columns [x + p*w/N, x + (p+1)*w/N) (at
                       // least one), bars rise from its bottom row; the true-place ticks and
                       // tick labels lie below it, the match marker above it
};

// Throws std::invalid_argument for bad options, a bad content (N < 1, a place id outside
// [0, N), posterior length != place_ids length, a negative or non-finite P, an image that
// is neither CV_8UC3 nor CV_8UC1) with a message naming the problem.
MatchImageLayout MatchImageLayoutFor(const MatchImageContent& content,
                                     const MatchImageOptions& options);

// The match image, CV_8UC3 BGR, of size MatchImageLayoutFor(content, options).image. Images
// smaller than the panel are enlarged with INTER_NEAREST (thumbnails stay crisp), larger ones
// shrunk with INTER_AREA; an empty image becomes a dark grey 4:3 placeholder with its note
// written in it. Same errors as MatchImageLayoutFor.
cv::Mat RenderMatchImage(const MatchImageContent& content, const MatchImageOptions& options);

}  // namespace bsf_vpr
