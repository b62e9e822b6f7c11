// Topic and service names of the bsf_vpr nodes, in one place. All are relative (resolved in
// the node's namespace) so that launch files can remap them.
#pragma once

namespace bsf_vpr {
namespace names {

// descriptor_ingest
constexpr char kImageTopic[] = "image";                       // sensor_msgs/Image in
constexpr char kExternalDescriptorTopic[] = "descriptor_in";  // bsf_vpr/Descriptor in
constexpr char kDescriptorTopic[] = "descriptor";             // bsf_vpr/Descriptor out
// bsf_vpr/DescriptorFormat, latched: what the ingest sends on kDescriptorTopic.
constexpr char kDescriptorFormatTopic[] = "descriptor_format";
// bsf_vpr/InputDropped out: each input dropped, with why (the fusion node listens).
constexpr char kInputDroppedTopic[] = "input_dropped";
// std_msgs/Float64 out, private namespace: seconds each image took to describe.
constexpr char kDescribeTimeTopic[] = "describe_time";

// fusion
constexpr char kBeliefTopic[] = "belief";                 // bsf_vpr/Belief out
constexpr char kMatchTopic[] = "match";                   // bsf_vpr/Match out
// geometry_msgs/PoseWithCovarianceStamped out: the robot's pose from an accepted match.
constexpr char kPoseTopic[] = "pose";
constexpr char kLocalizationTopic[] = "localization";     // bsf_vpr/Localization out, latched
constexpr char kBeliefMarkersTopic[] = "belief_markers";  // visualization_msgs/MarkerArray
constexpr char kMatchImageTopic[] = "match_image";  // sensor_msgs/Image, private namespace
// The fusion node also subscribes to kImageTopic (the query images) for the match image.

constexpr char kListReferenceSetsService[] = "list_reference_sets";
constexpr char kLoadReferenceSetService[] = "load_reference_set";
constexpr char kUnloadReferenceSetService[] = "unload_reference_set";
constexpr char kQueryPlaceService[] = "query_place";
constexpr char kStartRecordingService[] = "start_recording";
constexpr char kStopRecordingService[] = "stop_recording";
constexpr char kSelectionStatisticsService[] = "get_selection_statistics";

// fusion shard (a shard of a sharded map, shard_node.h), in its private namespace; it
// subscribes to kDescriptorTopic and serves the three reference-set services there too.
constexpr char kShardDistancesTopic[] = "distances";  // bsf_vpr/ShardDistances out
constexpr char kShardInfoTopic[] = "shard_info";      // bsf_vpr/ShardInfo out, latched
constexpr char kShardDistancesService[] = "get_distances";
constexpr char kShardInfoService[] = "get_shard_info";  // bsf_vpr/GetShardInfo

}  // namespace names
}  // namespace bsf_vpr
