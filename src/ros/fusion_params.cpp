#include "fusion_params.h"

#include <ros/param.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <algorithm>
#include <stdexcept>

#include "param_util.h"

namespace bsf_vpr {
namespace {

std::string Member(XmlRpc::XmlRpcValue& entry, const char* key, size_t index, bool required) {
  if (!entry.hasMember(key)) {
    if (required) {
      throw std::invalid_argument("reference_sets[" + std::to_string(index) + "] has no '" + key +
                                  "'");
    }
    return "";
  }
  if (entry[key].getType() != XmlRpc::XmlRpcValue::TypeString) {
    throw std::invalid_argument("reference_sets[" + std::to_string(index) + "]." + key +
                                " must be a string");
  }
  return static_cast<std::string>(entry[key]);
}

std::vector<ReferenceSetEntry> LoadReferenceSetEntries(const ros::NodeHandle& pnh) {
  std::vector<ReferenceSetEntry> out;
  if (!pnh.hasParam("reference_sets")) return out;
  XmlRpc::XmlRpcValue list;
  pnh.getParam("reference_sets", list);
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray) {
    throw std::invalid_argument("reference_sets must be a list of {name, path, condition}");
  }
  for (int i = 0; i < list.size(); ++i) {
    XmlRpc::XmlRpcValue& e = list[i];
    const size_t idx = static_cast<size_t>(i);
    if (e.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
      throw std::invalid_argument("reference_sets[" + std::to_string(idx) + "] is not a mapping");
    }
    for (auto it = e.begin(); it != e.end(); ++it) {
      if (it->first != "name" && it->first != "path" && it->first != "condition") {
        throw std::invalid_argument("reference_sets[" + std::to_string(idx) +
                                    "] has unknown key '" + it->first +
                                    "' (expected name, path, condition)");
      }
    }
    out.push_back({Member(e, "name", idx, false), Member(e, "path", idx, true),
                   Member(e, "condition", idx, false)});
  }
  return out;
}

}  // namespace

const std::vector<std::string>& FusionParamNames() {
  static const std::vector<std::string> kNames = {"reference_sets",
                                                  "data_directory",
                                                  "distance",
                                                  "storage",
                                                  "method",
                                                  "gamma_fraction",
                                                  "selection",
                                                  "likelihood",
                                                  "threshold",
                                                  "threshold_kind",
                                                  "max_match_distance",
                                                  "top_k",
                                                  "belief_top_k",
                                                  "map_frame",
                                                  "place_frame",
                                                  "publish_tf",
                                                  "queue_size",
                                                  "marker_spacing_m",
                                                  "diagnostic_period",
                                                  "sequence_length",
                                                  "sequence_use_partial",
                                                  "sequence_min_velocity",
                                                  "sequence_max_velocity",
                                                  "sequence_velocity_step",
                                                  "filter_step_mean_places",
                                                  "filter_step_std_places",
                                                  "relocalization_probability",
                                                  "odometry_source",
                                                  "odometry_topic",
                                                  "odom_frame",
                                                  "base_frame",
                                                  "place_spacing_m"};
  return kNames;
}


Threshold MakeThreshold(double value, const std::string& kind) {
  Threshold t;
  if (kind == "probability") {
    t.kind = Threshold::Kind::kProbability;
  } else if (kind == "log_odds") {
    t.kind = Threshold::Kind::kLogOdds;
  } else {
    throw std::invalid_argument("threshold_kind must be probability or log_odds, got '" + kind +
                                "'");
  }
  t.value = value;
  t.Validate();
  return t;
}

FusionParams LoadFusionParams(const ros::NodeHandle& pnh) {
  for (const char* retired : {"carry_prior", "prior_uniform_fraction"}) {
    if (pnh.hasParam(retired)) {
      throw std::invalid_argument(
          std::string("parameter ") + retired +
          " was removed: the +filter suffix carries the belief between queries (e.g. method: "
          "bsf+filter, with filter_step_mean_places 0 for the former carry_prior)");
    }
  }
  RefuseUnknownParams(pnh, FusionParamNames());
  FusionParams p;
  RecognizerOptions& r = p.recognizer;
  p.reference_sets = LoadReferenceSetEntries(pnh);
  p.data_directory = GetParam<std::string>(pnh, "data_directory", "");
  const std::string distance = GetParam<std::string>(pnh, "distance", "");
  p.distance_given = !distance.empty();
  r.metric = ParseDistanceMetric(p.distance_given ? distance : "euclidean");
  p.storage = ParseStoragePrecision(GetParam<std::string>(pnh, "storage", "float32"));
  r.method = GetParam<std::string>(pnh, "method", r.method);
  r.method_options.selection.gamma_fraction =
      GetParam<double>(pnh, "gamma_fraction", r.method_options.selection.gamma_fraction);
  r.method_options.selection.rule =
      ParseSelectionRule(GetParam<std::string>(pnh, "selection", "relative"));
  r.method_options.likelihood.variant =
      ParseLikelihoodVariant(GetParam<std::string>(pnh, "likelihood", "one_sided"));
  r.method_options.threshold =
      MakeThreshold(GetParam<double>(pnh, "threshold", 0.9),
                    GetParam<std::string>(pnh, "threshold_kind", "probability"));
  r.method_options.max_match_distance =
      GetParam<double>(pnh, "max_match_distance", r.method_options.max_match_distance);
  r.method_options.top_k = GetParam<int>(pnh, "top_k", r.method_options.top_k);
  SequenceOptions& seq = r.method_options.sequence;
  seq.length = GetParam<int>(pnh, "sequence_length", seq.length);
  seq.use_partial_sequences =
      GetParam<bool>(pnh, "sequence_use_partial", seq.use_partial_sequences);
  seq.min_velocity = GetParam<double>(pnh, "sequence_min_velocity", seq.min_velocity);
  seq.max_velocity = GetParam<double>(pnh, "sequence_max_velocity", seq.max_velocity);
  seq.velocity_step = GetParam<double>(pnh, "sequence_velocity_step", seq.velocity_step);
  TemporalFilterOptions& f = r.method_options.filter;
  f.step_mean_places = GetParam<double>(pnh, "filter_step_mean_places", f.step_mean_places);
  f.step_std_places = GetParam<double>(pnh, "filter_step_std_places", f.step_std_places);
  f.relocalization_probability =
      GetParam<double>(pnh, "relocalization_probability", f.relocalization_probability);
  r.Validate();
  p.odometry_source =
      ParseOdometrySource(GetParam<std::string>(pnh, "odometry_source", "none"));
  p.odometry_topic = GetParam<std::string>(pnh, "odometry_topic", p.odometry_topic);
  p.odom_frame = GetParam<std::string>(pnh, "odom_frame", p.odom_frame);
  p.base_frame = GetParam<std::string>(pnh, "base_frame", p.base_frame);
  p.place_spacing_m = GetParam<double>(pnh, "place_spacing_m", p.place_spacing_m);
  if (!(p.place_spacing_m >= 0)) throw std::invalid_argument("place_spacing_m must be >= 0");
  p.belief_top_k = GetParam<int>(pnh, "belief_top_k", p.belief_top_k);
  p.map_frame = GetParam<std::string>(pnh, "map_frame", p.map_frame);
  p.place_frame = GetParam<std::string>(pnh, "place_frame", p.place_frame);
  p.publish_tf = GetParam<bool>(pnh, "publish_tf", p.publish_tf);
  p.queue_size = GetParam<int>(pnh, "queue_size", p.queue_size);
  p.marker_spacing_m = GetParam<double>(pnh, "marker_spacing_m", p.marker_spacing_m);
  if (p.belief_top_k < 0) throw std::invalid_argument("belief_top_k must be >= 0");
  if (p.queue_size < 1) throw std::invalid_argument("queue_size must be >= 1");
  if (!(p.marker_spacing_m > 0)) throw std::invalid_argument("marker_spacing_m must be > 0");
  if (p.map_frame.empty() || p.place_frame.empty()) {
    throw std::invalid_argument("map_frame and place_frame must not be empty");
  }
  return p;
}

}  // namespace bsf_vpr
