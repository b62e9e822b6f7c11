#include "src/tools/evaluate/evaluate_results_bag.h"

#include <bsf_vpr/Belief.h>
#include <bsf_vpr/QueryGroundTruth.h>
#include <geometry_msgs/PoseStamped.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <stdexcept>

namespace bsf_vpr {
namespace tools {
namespace {

QueryOutcome ToOutcome(const Belief& b) {
  QueryOutcome o;
  o.match = b.match;
  o.confidence = b.confidence;
  o.accepted = b.accepted;
  o.off_map_probability = b.off_map_probability;
  o.match_distance = b.match_distance;
  if (b.posterior.size() == b.place_ids.size() && !b.posterior.empty()) {
    // Rank by posterior (the message may list every place in place order).
    std::vector<size_t> order(b.place_ids.size());
    std::iota(order.begin(), order.end(), 0);
    const size_t k = std::min<size_t>(order.size(), 10);
    std::partial_sort(order.begin(), order.begin() + static_cast<long>(k), order.end(),
                      [&](size_t x, size_t y) { return b.posterior[x] > b.posterior[y]; });
    for (size_t i = 0; i < k; ++i) o.top_places.push_back(b.place_ids[order[i]]);
  } else {
    o.top_places.assign(b.place_ids.begin(), b.place_ids.end());  // already ranked
  }
  if (o.top_places.empty() || o.top_places.front() != b.match) {
    o.top_places.insert(o.top_places.begin(), b.match);
  }
  return o;
}

PlacePose ToPlacePose(const geometry_msgs::Pose& p) {
  const geometry_msgs::Quaternion& o = p.orientation;
  const double yaw = std::atan2(2 * (o.w * o.z + o.x * o.y), 1 - 2 * (o.y * o.y + o.z * o.z));
  return PlacePose{p.position.x, p.position.y, p.position.z, yaw};
}

// Each stamp's pose from `poses` (nullopt where none has that stamp).
std::vector<std::optional<PlacePose>> PosesAt(const std::vector<ros::Time>& stamps,
                                              const std::vector<geometry_msgs::PoseStamped>& poses,
                                              const std::string& path,
                                              const std::string& pose_topic) {
  std::map<ros::Time, PlacePose> pose_of_stamp;
  for (const geometry_msgs::PoseStamped& p : poses) {
    if (!pose_of_stamp.emplace(p.header.stamp, ToPlacePose(p.pose)).second) {
      throw std::runtime_error("results bag '" + path + "' holds two poses on " + pose_topic +
                               " with the stamp " + std::to_string(p.header.stamp.toSec()));
    }
  }
  std::vector<std::optional<PlacePose>> out;
  for (const ros::Time& t : stamps) {
    const auto it = pose_of_stamp.find(t);
    out.push_back(it == pose_of_stamp.end() ? std::nullopt : std::optional(it->second));
  }
  return out;
}

}  // namespace

ResultsBag ReadResultsBag(const std::string& path, const std::string& belief_topic,
                          const std::string& truth_topic, const std::string& pose_topic) {
  rosbag::Bag bag;
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot read results bag '" + path + "': " + e.what());
  }
  ResultsBag out;
  std::vector<Belief> beliefs;
  std::vector<QueryGroundTruth> truths;
  std::vector<geometry_msgs::PoseStamped> poses;
  std::vector<std::string> topics = {belief_topic, truth_topic};
  if (!pose_topic.empty()) topics.push_back(pose_topic);
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(topics))) {
    if (m.getTopic() == belief_topic) {
      if (const auto b = m.instantiate<Belief>()) beliefs.push_back(*b);
    } else if (m.getTopic() == truth_topic) {
      if (const auto g = m.instantiate<QueryGroundTruth>()) truths.push_back(*g);
    } else if (const auto p = m.instantiate<geometry_msgs::PoseStamped>()) {
      poses.push_back(*p);
    }
  }
  out.num_poses = static_cast<int>(poses.size());
  if (beliefs.empty()) {
    throw std::runtime_error("results bag '" + path + "' holds no bsf_vpr/Belief on " +
                             belief_topic);
  }
  out.method = beliefs.front().method;
  out.set_names = beliefs.front().set_names;
  for (const Belief& b : beliefs) {
    if (b.method != out.method) {
      throw std::runtime_error("results bag '" + path + "' mixes methods '" + out.method +
                               "' and '" + b.method + "' (reconfigured during the replay?)");
    }
    out.num_places = std::max(out.num_places, b.num_places);
  }
  if (truths.empty()) {
    std::vector<ros::Time> stamps;
    for (const Belief& b : beliefs) {
      out.outcomes.push_back(ToOutcome(b));
      stamps.push_back(b.header.stamp);
    }
    if (!pose_topic.empty()) out.query_poses = PosesAt(stamps, poses, path, pose_topic);
    return out;
  }
  std::sort(truths.begin(), truths.end(),
            [](const auto& a, const auto& b) { return a.query_index < b.query_index; });
  const int q = truths.back().query_index + 1;
  std::vector<std::vector<int>> correct(static_cast<size_t>(q));
  std::map<ros::Time, int> query_of_stamp;
  std::vector<ros::Time> stamps(static_cast<size_t>(q));
  for (const QueryGroundTruth& g : truths) {
    if (g.query_index < 0)
      throw std::runtime_error("results bag '" + path + "': negative query_index");
    correct[static_cast<size_t>(g.query_index)].assign(g.correct_places.begin(),
                                                       g.correct_places.end());
    query_of_stamp[g.header.stamp] = g.query_index;
    stamps[static_cast<size_t>(g.query_index)] = g.header.stamp;
  }
  if (!pose_topic.empty()) out.query_poses = PosesAt(stamps, poses, path, pose_topic);
  out.truth = GroundTruth(std::move(correct));
  QueryOutcome none;
  none.confidence = -INFINITY;
  out.outcomes.assign(static_cast<size_t>(q), none);
  std::vector<bool> seen(static_cast<size_t>(q), false);
  for (const Belief& b : beliefs) {
    const auto it = query_of_stamp.find(b.header.stamp);
    if (it == query_of_stamp.end()) continue;  // not a query of this replay
    out.outcomes[static_cast<size_t>(it->second)] = ToOutcome(b);
    seen[static_cast<size_t>(it->second)] = true;
  }
  out.missing = static_cast<int>(std::count(seen.begin(), seen.end(), false));
  return out;
}

}  // namespace tools
}  // namespace bsf_vpr
