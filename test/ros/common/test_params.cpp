// Parameter loading and dynamic_reconfigure through the options tables, without a master:
// the parameters come as the XmlRpc struct the parameter server would give.
#include <bsf_vpr/FusionConfig.h>
#include <gtest/gtest.h>

#include <stdexcept>

#include "src/ros/fusion/fusion_params.h"
#include "src/ros/fusion/reconfigure_options.h"
#include "src/ros/ingest/descriptor_ingest.h"
#include "src/ros/shard/shard_params.h"
#include "test/core/enum_names_check.h"

namespace bsf_vpr {
namespace {

std::string LoadError(XmlRpc::XmlRpcValue params) {
  try {
    RosParamSource source(params, "/bsf_vpr");
    LoadFusionParams(source);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// A shard reads its own small table: the map's, the first stage's and the queue's
// parameters, by the fusion node's names; the decision's are the combiner's and refused.
TEST(ShardParams, AShardReadsItsMapAndRefusesTheDecisionsParameters) {
  XmlRpc::XmlRpcValue v;
  v["distance"] = "cosine";
  v["storage"] = "int8";
  v["first_stage"] = "pca";
  v["queue_size"] = 7;
  RosParamSource source(v, "/bsf_vpr/shard_0");
  const ShardParams p = LoadShardParams(source);
  EXPECT_EQ(p.distance, DistanceMetric::kCosine);
  EXPECT_EQ(p.storage, StoragePrecision::kInt8);
  EXPECT_EQ(p.first_stage.Kind(), FirstStageKind::kPca);
  EXPECT_EQ(p.queue_size, 7);
  for (const char* decision : {"method", "gamma_fraction", "map_frame", "shard_timeout"}) {
    XmlRpc::XmlRpcValue bad;
    bad[decision] =
        decision == std::string("method") ? XmlRpc::XmlRpcValue("bsf") : XmlRpc::XmlRpcValue(1.0);
    RosParamSource s(bad, "/bsf_vpr/shard_0");
    try {
      LoadShardParams(s);
      ADD_FAILURE() << decision << " taken by a shard";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(decision), std::string::npos) << e.what();
    }
  }
  XmlRpc::XmlRpcValue combiner;
  combiner["shards"][0] = "shard_1";
  RosParamSource s(combiner, "/bsf_vpr/shard_0");
  EXPECT_THROW(LoadShardParams(s), std::invalid_argument);
}

TEST(FusionParams, DefaultsAreTheTables) {
  RosParamSource none(XmlRpc::XmlRpcValue(), "/bsf_vpr");
  const FusionParams p = LoadFusionParams(none);
  EXPECT_EQ(p.recognizer.method, "bsf");
  EXPECT_EQ(p.recognizer.method_options.decision.threshold.value, 0.9);
  EXPECT_EQ(p.recognizer.metric, DistanceMetric::kEuclidean);
  EXPECT_FALSE(p.distance_given());
  EXPECT_EQ(p.queue_size, 100);
  EXPECT_TRUE(p.reference_sets.empty());
}

TEST(FusionParams, ReadsEveryKind) {
  XmlRpc::XmlRpcValue v;
  v["method"] = "bsf+filter";
  v["gamma_fraction"] = 1;  // a whole number for a double
  v["selection"] = "standardized";
  v["threshold"] = 8.0;
  v["threshold_kind"] = "log_odds";
  v["sequence_use_partial"] = false;
  v["top_k"] = 3;
  v["distance"] = "cosine";
  v["storage"] = "int8";
  v["odometry_source"] = "tf";
  v["reference_sets"][0]["name"] = "winter";
  v["reference_sets"][0]["path"] = "winter.yaml";
  v["diagnostic_period"] = 2.0;
  RosParamSource source(v, "/bsf_vpr");
  const FusionParams p = LoadFusionParams(source);
  const MethodOptions& m = p.recognizer.method_options;
  EXPECT_EQ(p.recognizer.method, "bsf+filter");
  EXPECT_EQ(m.selection.gamma_fraction, 1.0);
  EXPECT_EQ(m.selection.rule, SelectionRule::kStandardized);
  EXPECT_EQ(m.decision.threshold.kind, Threshold::Kind::kLogOdds);
  EXPECT_EQ(m.decision.threshold.value, 8.0);
  EXPECT_FALSE(m.sequence.use_partial_sequences);
  EXPECT_EQ(m.decision.top_k, 3);
  EXPECT_TRUE(p.distance_given());
  EXPECT_EQ(p.recognizer.metric, DistanceMetric::kCosine);
  EXPECT_EQ(p.storage, StoragePrecision::kInt8);
  EXPECT_EQ(p.odometry_source, OdometrySource::kTf);
  ASSERT_EQ(p.reference_sets.size(), 1u);
  EXPECT_EQ(p.reference_sets[0].path, "winter.yaml");
  EXPECT_EQ(p.diagnostic_period, 2.0);
}

TEST(FusionParams, RefusesWhatNoTableRead) {
  XmlRpc::XmlRpcValue v;
  v["gama_fraction"] = 0.1;
  EXPECT_NE(LoadError(v).find("unknown parameter(s): /bsf_vpr/gama_fraction"), std::string::npos)
      << LoadError(v);
  XmlRpc::XmlRpcValue wrong_type;
  wrong_type["threshold"] = "high";
  EXPECT_NE(LoadError(wrong_type).find("/bsf_vpr/threshold' must be a number"), std::string::npos)
      << LoadError(wrong_type);
  XmlRpc::XmlRpcValue bad;
  bad["selection"] = "best";
  EXPECT_NE(LoadError(bad).find("/bsf_vpr/selection must be relative | standardized"),
            std::string::npos)
      << LoadError(bad);
  XmlRpc::XmlRpcValue probability;
  probability["threshold"] = 8.0;  // a probability of 8
  EXPECT_NE(LoadError(probability).find("threshold as a probability"), std::string::npos);
  XmlRpc::XmlRpcValue retired;
  retired["carry_prior"] = true;
  EXPECT_NE(LoadError(retired).find("carry_prior was removed"), std::string::npos);
  XmlRpc::XmlRpcValue sets;
  sets["reference_sets"][0]["path"] = "a.yaml";
  sets["reference_sets"][0]["conditon"] = "winter";
  EXPECT_NE(LoadError(sets).find("reference_sets[0] has unknown key 'conditon'"),
            std::string::npos);
}

// The nodes' enumerations have one table of names each, which the parameters read.
TEST(FusionParams, EveryEnumerationsNamesRoundTrip) {
  using testing::ExpectNamesRoundTrip;
  ExpectNamesRoundTrip(OdometrySourceNames(), ParseOdometrySource, "odometry_source");
  ExpectNamesRoundTrip(PoseSourceNames(), ParsePoseSource, "pose_source");
  ExpectNamesRoundTrip<PoseLoss>(PoseLossNames(), nullptr, "pose loss");
  ExpectNamesRoundTrip(IngestInputNames(), ParseIngestInput, "input");
  EXPECT_EQ(ToString(PoseLoss::kNotYet), "no pose received yet");
  EXPECT_EQ(FusionParamsTable().Find("pose_source")->info.choices, PoseSourceNames().Choices());
  EXPECT_EQ(IngestParamsTable().Find("input")->info.choices, IngestInputNames().Choices());
  // distance is optional: "" (shown first) leaves it to the sets.
  const OptionInfo& distance = FusionParamsTable().Find("distance")->info;
  EXPECT_EQ(distance.choices, (std::vector<std::string>{"", "euclidean", "cosine"}));
  EXPECT_EQ(distance.default_value, OptionValue(std::string()));
  XmlRpc::XmlRpcValue v;
  v["distance"] = "cosine";
  RosParamSource cosine(v, "/bsf_vpr");
  const FusionParams p = LoadFusionParams(cosine);
  EXPECT_EQ(p.distance, DistanceMetric::kCosine);
  EXPECT_EQ(p.recognizer.metric, DistanceMetric::kCosine);
  EXPECT_EQ(FusionParamsTable().Find("distance")->get(p), OptionValue(std::string("cosine")));
  v["distance"] = "";
  RosParamSource none(v, "/bsf_vpr");
  EXPECT_FALSE(LoadFusionParams(none).distance_given());
  v["distance"] = "manhattan";
  EXPECT_NE(
      LoadError(v).find("/bsf_vpr/distance must be \"\" | euclidean | cosine, got 'manhattan'"),
      std::string::npos)
      << LoadError(v);
}

TEST(IngestParams, ReadsTheDescriberTable) {
  XmlRpc::XmlRpcValue v;
  v["input"] = "image";
  v["image_descriptor"] = "hog";
  v["hog_cell_px"] = 4;
  v["onnx_mean"][0] = 0.5;
  v["onnx_mean"][1] = 1;
  v["onnx_mean"][2] = 0.25;
  v["onnx_rgb"] = false;
  v["image_transport"] = "compressed";
  RosParamSource source(v, "/ingest");
  const IngestParams p = LoadIngestParams(source);
  EXPECT_EQ(p.describer.kind, ImageDescriberKind::kHog);
  EXPECT_EQ(p.describer.hog.cell_px, 4);
  EXPECT_EQ(p.describer.onnx.mean, (std::vector<float>{0.5f, 1.0f, 0.25f}));
  EXPECT_FALSE(p.describer.onnx.rgb);
  EXPECT_EQ(p.image_transport, "compressed");

  XmlRpc::XmlRpcValue unknown;
  unknown["descriptor"] = "hog";  // the tools' old flag name, not a parameter
  RosParamSource unknown_source(unknown, "/ingest");
  EXPECT_THROW(LoadIngestParams(unknown_source), std::invalid_argument);
  XmlRpc::XmlRpcValue list;
  list["onnx_std"][0] = "a";
  RosParamSource list_source(list, "/ingest");
  EXPECT_THROW(LoadIngestParams(list_source), std::invalid_argument);
}

// cfg/Fusion.cfg is written from the table: its defaults and names are the table's (its
// bounds are left to the node's check),
// and a reconfiguration goes through the table both ways.
TEST(Reconfigure, TheCfgIsTheTable) {
  const OptionTable<RecognizerOptions>& table = RecognizerOptionsTable();
  dynamic_reconfigure::Config defaults, mins, maxs;
  FusionConfig::__getDefault__().__toMessage__(defaults);
  FusionConfig::__getMin__().__toMessage__(mins);
  FusionConfig::__getMax__().__toMessage__(maxs);
  EXPECT_EQ(ValuesFromConfig(defaults).size(), table.Infos(true).size());
  for (const auto& [name, value] : ValuesFromConfig(defaults)) {
    const auto* spec = table.Find(name);
    ASSERT_NE(spec, nullptr) << name;
    EXPECT_TRUE(spec->info.live) << name;
    EXPECT_EQ(value, spec->info.default_value) << name;
  }
  // No bounds in the cfg: dynamic_reconfigure's server clamps to them before the node sees
  // a value (gamma_fraction -0.5 would be taken as 0); the node refuses what the table's
  // bounds refuse instead.
  for (const auto& config : {mins, maxs}) {
    for (const auto& [name, value] : ValuesFromConfig(config)) {
      if (const double* d = std::get_if<double>(&value)) {
        EXPECT_FALSE(std::isfinite(*d)) << name;
      } else if (const long long* i = std::get_if<long long>(&value)) {
        EXPECT_TRUE(*i <= -2147483647 || *i >= 2147483647) << name << " " << *i;
      }
    }
  }

  FusionConfig config = FusionConfig::__getDefault__();
  config.threshold = 5;
  config.threshold_kind = "log_odds";
  config.sequence_length = 7;
  dynamic_reconfigure::Config request;
  config.__toMessage__(request);
  NamedValueSource source(ValuesFromConfig(request));
  RecognizerOptions o;
  table.Apply(source, &o, /*live_only=*/true);
  EXPECT_TRUE(source.Unread().empty());
  EXPECT_EQ(o.method_options.decision.threshold.value, 5);
  EXPECT_EQ(o.method_options.decision.threshold.kind, Threshold::Kind::kLogOdds);
  EXPECT_EQ(o.method_options.sequence.length, 7);
  dynamic_reconfigure::Config back = ConfigFromValues(table.Values(o, true));
  FusionConfig shown;
  EXPECT_TRUE(shown.__fromMessage__(back));
  EXPECT_EQ(shown.threshold_kind, "log_odds");
  EXPECT_EQ(shown.sequence_length, 7);
}

}  // namespace
}  // namespace bsf_vpr
