// The ground truth of bsf_evaluate beyond the core's: where --tolerance-m takes the query
// and place poses from, and the line that tells the user which ground truth was used. The
// ground truth by position itself is the core's GroundTruth::FromMetricTolerance (planar
// distance; a place without a pose is never correct), scored by the same code as a ground
// truth by frames.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/evaluation/evaluation.h"
#include "src/tools/evaluate/evaluate_args.h"

namespace bsf_vpr {
namespace tools {

// Query poses for a query without its own (a descriptor .npy or an image folder): a CSV
// whose first line is the header 'query,x,y,z,yaw' or 'timestamp,x,y,z,yaw', then one row
// per query in query order, metres and radians in the frame of the reference sets' poses.
// The query column must count 0, 1, 2, ...; timestamps (seconds) must increase; neither is
// matched to anything else. Latitude/longitude columns are refused: the reference YAMLs
// hold metres in their own frame and no origin to convert from. Throws
// std::invalid_argument naming the file, the line and the problem, or a row count other
// than `num_queries`.
std::vector<PlacePose> ReadQueryPosesCsv(const std::string& path, int num_queries);

// Every place's pose in `map` (from the first set that has one for it; nullopt where no set
// has). Throws std::invalid_argument when no place has a pose.
std::vector<std::optional<PlacePose>> PlacePosesOf(const ReferenceSets& map);

// The place poses a node had during a replay, from the reference-set YAMLs given with
// --results-bag (`references`). Their names must be exactly the node's sets (`set_names`,
// as the beliefs list them); they are loaded in that order, so that a place two sets have
// takes its pose from the same set as in the node; and together they must make the node's
// place index of `num_places` places. Throws std::invalid_argument naming the problem.
std::vector<std::optional<PlacePose>> NodePlacePoses(const std::vector<NamedPath>& references,
                                                     const std::vector<std::string>& set_names,
                                                     int num_places);

// "a match within R m of the query's pose is correct (planar distance, --tolerance-m R);
// query poses from <query_source>; place poses for P of N places". For the summary.
std::string DescribeMetricTruth(double tolerance_m, const std::string& query_source,
                                const std::vector<std::optional<PlacePose>>& place_poses);

// "query q shows place q; a match within K places is correct (--tolerance K)".
std::string DescribeFrameTruth(int tolerance_frames);

// "T of Q queries have a true match".
std::string CountTrueMatches(const GroundTruth& truth);

}  // namespace tools
}  // namespace bsf_vpr
