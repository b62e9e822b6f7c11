#include "src/tools/evaluate/evaluate_args.h"

#include <cmath>
#include <stdexcept>

#include "src/tools/common/cli_util.h"
#include "src/tools/common/describer_flags.h"

namespace bsf_vpr {
namespace tools {

std::string EvaluateUsage() {
  return R"(usage: bsf_evaluate [options]

Evaluates place recognition methods offline: no ROS master needed.

Inputs (either descriptors, or precomputed per-source matrices):
  --reference NAME=PATH   a reference set: descriptor .npy (N x D), reference-set .yaml,
                          or a folder of images (described with --image-descriptor, below).
                          Repeat for M sets.
  --query PATH            the query traversal, of the same kinds (Q x D); of a folder, an
                          image that shows nothing (a covered, black or dazzled camera) is
                          no observation, as the ingest drops it live: no match, no filter
                          step (the first output line counts them)
  --distances NAME=PATH   a Q x N .npy of distances from every query to every place for
                          one source (lower is better). Repeatable.
  --similarities NAME=PATH  the same with similarities (higher is better); they become
                          distances c - s with c = max(1, largest similarity of all sources)
  --same-descriptor true|false  the --distances/--similarities sources are one descriptor
                          under several reference conditions, on one scale (true), or each
                          its own descriptor or technique (false, the default): bsf's
                          selection and mixture compare sets only within one descriptor
  --distance euclidean|cosine   distance between descriptors (default: the distance the
                          reference-set YAMLs declare when they agree, else euclidean; sets
                          that declare another distance than this are refused)
  --storage float32|float16|int8  precision the reference descriptors are held at
                          (default float32; float16 halves and int8 quarters their bytes)
  --memory-map true       map each reference .npy into memory instead of reading it where it
                          holds the rows at --storage (bsf_store_set writes sets so; other
                          files are read): a set costs its norms, not its bytes
  --results-bag PATH      instead: the beliefs a node published during a replay (recorded by
                          launch/replay.launch), scored exactly as offline for the method the
                          node ran; ground truth from --tolerance/--ground-truth/--tolerance-m
                          or, if none is given, the bsf_vpr/QueryGroundTruth recorded in the
                          bag. With --tolerance-m, --reference NAME=PATH.yaml gives the place
                          poses of each set the node had loaded (its descriptors are not used)
  --belief-topic T, --truth-topic T, --pose-topic T   topics in the results bag (default
                          /bsf_vpr/belief, /vpr/ground_truth, /vpr/query_pose)

Ground truth (one of):
  --tolerance K           query q shows place q; a match within K places is correct
  --ground-truth PATH     a CSV of lines 'query,place place ...' listing the correct
                          places, or a Q x N .npy of 0/1 (bool, integer or float): entry
                          (q, i) is 1 when place i is correct for query q (the VPR
                          tutorial's GThard is N x Q: save GThard.T)
  --tolerance-m R         a match is correct when its place pose lies within R metres of
                          the query's pose (planar distance, x and y); a place without a
                          pose is never correct. Place poses from the reference-set YAMLs;
                          query poses from a query YAML, from --query-poses, or with
                          --results-bag from --pose-topic (matched to each belief by header
                          stamp; a query without a pose is left out of the scores and counted)
  --query-poses CSV       with --tolerance-m or --odometry poses, the poses of a .npy or
                          image-folder query: a header 'query,x,y,z,yaw' or
                          'timestamp,x,y,z,yaw', then one row per query in order (metres,
                          radians, the reference poses' frame; no lat,lon: the sets keep
                          metres and no origin)

Odometry (descriptor inputs; the fusion node's odometry_source and place_spacing_m):
  --odometry none|poses   poses: each +filter step is the robot's progress from the query
                          poses (a query YAML's or --query-poses), as the node takes
                          odometry: the distance moved since the previous seen query (a
                          blind frame is none) over the place spacing (default none: the
                          filter's own step, filter_step_mean_places)
  --place-spacing-m X     with --odometry poses, the distance between places (default: the
                          median spacing of the reference sets' place poses)

Methods:
  --methods LIST          comma-separated: bsf, bayes_full, med, med_selective,
                          nn:<set>, bayes:<set>, the descriptor-level mean_descriptor,
                          union_nn, subspace and discriminant (reference sets of one
                          descriptor that share places), and 'all' (every one of these
                          that applies, with nn: and bayes: for every set; the default).
                          Suffixes over time
                          (queries in traversal order): +filter (temporal filter prior,
                          Bayesian methods) and +seq (sequence matching), e.g. bsf+seq,
                          nn:winter+seq, all,bsf+filter. A repeated method runs once.

Method options (the fusion node's parameters of the same names):
)" + OptionsUsage(MethodOptionsTable().Infos()) +
         R"(
The map's own acceptance rule (descriptor inputs; the fusion node's parameter of the same name):
)" + OptionsUsage(CalibrationOptionsTable().Infos()) +
         R"(
Distances for large maps (descriptor inputs; the fusion node's parameters of the same names):
)" + OptionsUsage(FirstStageOptionsTable().Infos()) +
         R"(
Image descriptor, for image folders (the ingest nodelet's parameters of the same names):
)" + DescriberUsage() +
         R"(
Output (stdout: what was loaded, the ground truth used and how many queries have a true
match, and the table):
  --out DIR               write DIR/summary.csv and DIR/matches/<method>.csv
  --no-progress           do not report progress on stderr
  --timings               report on stderr each phase's wall time and how many cores it
                          kept busy (load; distances, fusion and metrics, with the time of
                          each of the three in brackets; table and files)
  -h, --help              show this help

Exit status: 0 on success, 2 on bad arguments or unreadable/invalid input.
)";
}

namespace {

NamedPath ParseNamedPath(const std::string& flag, const std::string& value) {
  const size_t eq = value.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == value.size()) {
    throw std::invalid_argument(flag + " expects NAME=PATH, got '" + value + "'");
  }
  return {value.substr(0, eq), value.substr(eq + 1)};
}

}  // namespace

EvaluateArgs ParseEvaluateArgs(int argc, char** argv) {
  EvaluateArgs a;
  FlagReader flags(argc, argv, {"--no-progress", "--timings"});
  bool pose_topic_given = false;
  for (std::string flag, value; flags.Next(&flag, &value);) {
    if (flag == "--no-progress") {
      a.progress = false;
    } else if (flag == "--timings") {
      a.timings = true;
    } else if (flag == "--reference") {
      a.references.push_back(ParseNamedPath(flag, value));
    } else if (flag == "--query") {
      a.query = value;
    } else if (flag == "--distances") {
      a.distances.push_back(ParseNamedPath(flag, value));
    } else if (flag == "--similarities") {
      a.similarities.push_back(ParseNamedPath(flag, value));
    } else if (flag == "--same-descriptor") {
      if (value != "true" && value != "false") {
        throw std::invalid_argument("--same-descriptor takes true or false, got '" + value + "'");
      }
      a.same_descriptor = value == "true";
    } else if (flag == "--results-bag") {
      a.results_bag = value;
    } else if (flag == "--belief-topic") {
      a.belief_topic = value;
    } else if (flag == "--truth-topic") {
      a.truth_topic = value;
    } else if (flag == "--pose-topic") {
      a.pose_topic = value;
      pose_topic_given = true;
    } else if (flag == "--distance") {
      a.metric = ForFlag(flag, [&] { return ParseDistanceMetric(value); });
    } else if (flag == "--storage") {
      a.storage = ForFlag(flag, [&] { return ParseStoragePrecision(value); });
    } else if (flag == "--memory-map") {
      if (value != "true" && value != "false") {
        throw std::invalid_argument("--memory-map takes true or false, got '" + value + "'");
      }
      a.memory_map = value == "true";
    } else if (flag == "--tolerance") {
      a.tolerance_frames = ParseInteger(flag, value);
      if (a.tolerance_frames < 0) throw std::invalid_argument("--tolerance must be >= 0");
    } else if (flag == "--tolerance-m") {
      a.tolerance_m = ParseNumber(flag, value);
      if (a.tolerance_m < 0) throw std::invalid_argument("--tolerance-m must be >= 0");
    } else if (flag == "--query-poses") {
      a.query_poses = value;
    } else if (flag == "--odometry") {
      if (value != "none" && value != "poses") {
        throw std::invalid_argument("--odometry takes none or poses, got '" + value + "'");
      }
      a.odometry = value == "poses";
    } else if (flag == "--place-spacing-m") {
      a.place_spacing_m = ParseNumber(flag, value);
      if (!(a.place_spacing_m > 0)) throw std::invalid_argument("--place-spacing-m must be > 0");
    } else if (flag == "--ground-truth") {
      a.ground_truth = value;
    } else if (flag == "--methods") {
      a.methods = value;
    } else if (MethodOptionsTable().SetFromFlag(flag, value, &a.options)) {
      // --gamma-fraction, --threshold, --sequence-*, --filter-*: the method options
    } else if (CalibrationOptionsTable().SetFromFlag(flag, value, &a.calibration)) {
      // --max-false-accept-rate
    } else if (FirstStageOptionsTable().SetFromFlag(flag, value, &a.first_stage)) {
      // --first-stage, --first-stage-dimensions, --rerank-candidates, --first-stage-sample-rows
    } else if (ParseDescriberFlag(flag, value, &a.describer)) {
      // --image-descriptor, --patch-*, --hog-*, --onnx-*: the image descriptor
    } else if (flag == "--out") {
      a.out_dir = value;
    } else {
      throw std::invalid_argument("unknown option '" + flag + "' (see --help)");
    }
  }
  a.help = flags.help();
  if (a.help) return a;
  CheckCombination(a);
  if (pose_topic_given && (a.results_bag.empty() || a.tolerance_m < 0)) {
    throw std::invalid_argument("--pose-topic goes with --results-bag and --tolerance-m");
  }
  return a;
}

void CheckCombination(const EvaluateArgs& a) {
  const bool descriptor_mode = !a.references.empty() || !a.query.empty();
  const bool matrix_mode = !a.distances.empty() || !a.similarities.empty();
  if (a.same_descriptor && !matrix_mode) {
    throw std::invalid_argument(
        "--same-descriptor goes with --distances/--similarities (reference sets compared with "
        "one --query are one descriptor already)");
  }
  const int truths = (a.tolerance_frames >= 0) + (a.tolerance_m >= 0) + !a.ground_truth.empty();
  const ApproximateOptions defaults;
  const ApproximateOptions& approximate = a.first_stage.approximate;
  const FirstStageKind first_stage = a.first_stage.Kind();
  if (first_stage == FirstStageKind::kExact &&
      (approximate.dimensions != defaults.dimensions || approximate.rerank != defaults.rerank ||
       approximate.sample_rows != defaults.sample_rows)) {
    throw std::invalid_argument(
        "--first-stage-dimensions, --rerank-candidates and --first-stage-sample-rows go with "
        "--first-stage pca");
  }
  if (first_stage != FirstStageKind::kExact && (matrix_mode || !a.results_bag.empty())) {
    throw std::invalid_argument(
        "--first-stage pca computes distances from descriptors (--reference/--query): "
        "--distances/--similarities and --results-bag give them already");
  }
  if (!a.query_poses.empty() && a.tolerance_m < 0 && !a.odometry) {
    throw std::invalid_argument("--query-poses goes with --tolerance-m R or --odometry poses");
  }
  if (a.place_spacing_m > 0 && !a.odometry) {
    throw std::invalid_argument("--place-spacing-m goes with --odometry poses");
  }
  if (a.odometry && (!a.results_bag.empty() || matrix_mode)) {
    throw std::invalid_argument(
        "--odometry poses goes with --reference/--query (a results bag's beliefs had the "
        "node's odometry already; distance matrices have no poses)");
  }
  if (!a.results_bag.empty()) {
    if (!a.query.empty() || matrix_mode) {
      throw std::invalid_argument("--results-bag goes without --query/--distances/--similarities");
    }
    if (!a.references.empty() && a.tolerance_m < 0) {
      throw std::invalid_argument(
          "--results-bag goes without --reference except to give the place poses for "
          "--tolerance-m R");
    }
    if (!a.query_poses.empty()) {
      throw std::invalid_argument(
          "--query-poses is for offline queries: with --results-bag the query poses come from "
          "--pose-topic (default /vpr/query_pose)");
    }
    if (truths > 1) {
      throw std::invalid_argument(
          "give at most one of --tolerance K, --tolerance-m R and --ground-truth PATH");
    }
    if (a.tolerance_m >= 0 && a.references.empty()) {
      throw std::invalid_argument(
          "--tolerance-m with --results-bag needs place poses: give --reference NAME=PATH.yaml "
          "for each set the node had loaded");
    }
    a.options.Validate();
    return;
  }
  if (descriptor_mode && matrix_mode) {
    throw std::invalid_argument(
        "give either --reference/--query or --distances/--similarities, not both");
  }
  if (!descriptor_mode && !matrix_mode) {
    throw std::invalid_argument(
        "no input: give --reference NAME=PATH and --query PATH, "
        "--distances NAME=PATH, or --results-bag PATH");
  }
  if (descriptor_mode && a.references.empty()) throw std::invalid_argument("no --reference given");
  if (descriptor_mode && a.query.empty()) throw std::invalid_argument("no --query given");
  if (truths != 1) {
    throw std::invalid_argument(
        "give exactly one of --tolerance K, --tolerance-m R and --ground-truth PATH");
  }
  if (a.tolerance_m >= 0 && !descriptor_mode) {
    throw std::invalid_argument(
        "--tolerance-m needs poses: use --reference YAML files with poses and --query (a YAML "
        "with poses, or any query with --query-poses CSV)");
  }
  a.options.Validate();
  ValidateImageDescriberOptions(a.describer);
}

}  // namespace tools
}  // namespace bsf_vpr
