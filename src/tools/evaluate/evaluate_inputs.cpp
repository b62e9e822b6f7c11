#include "src/tools/evaluate/evaluate_inputs.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <thread>

#include "bsf_vpr/core/self_calibration.h"
#include "bsf_vpr/evaluation/ground_truth_io.h"
#include "bsf_vpr/image/image_describer.h"
#include "bsf_vpr/io/npy.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "src/tools/common/describer_flags.h"
#include "src/tools/evaluate/evaluate_ground_truth.h"

namespace bsf_vpr {
namespace tools {
namespace {

bool IsFolder(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_directory(path, ec);
}

// Image folders are described with `describer`, built on first use (an ONNX model is then
// loaded once for all the folders one loading thread describes, see LoadAllSets).
// `blind` receives per row of an image folder BlindImageProblem (left empty for a file).
ReferenceSet LoadAnySet(const std::string& path, const std::string& name,
                        const ImageDescriberOptions& options, const ReadSetOptions& read,
                        std::unique_ptr<ImageDescriber>* describer,
                        std::vector<std::string>* blind) {
  if (IsFolder(path)) {
    if (!*describer) *describer = MakeImageDescriber(options);
    return DescribeImageFolderAsSet(path, name, **describer, blind);
  }
  return LoadReferenceSetFile(path, name, read);
}

// A distance declared by a reference-set (or query) YAML, and who declared it.
struct DeclaredDistance {
  std::string who;  // e.g. "reference set 'winter' (winter.yaml)"
  std::string distance;
};

// Records the distance `set` declares, if any (a set without a declaration fits any
// distance). Refuses a set meant for another distance than --distance, or, without
// --distance, than the first declaration.
void NoteDeclaredDistance(const EvaluateArgs& args, const std::string& who, const ReferenceSet& set,
                          std::vector<DeclaredDistance>* declared) {
  if (set.distance.empty()) return;
  if (args.metric && set.distance != ToString(*args.metric)) {
    throw std::invalid_argument(who + " is meant for " + set.distance +
                                " distance but --distance is " + ToString(*args.metric));
  }
  if (!declared->empty() && set.distance != declared->front().distance) {
    throw std::invalid_argument(declared->front().who + " declares " + declared->front().distance +
                                " distance but " + who + " declares " + set.distance +
                                ": give --distance euclidean|cosine");
  }
  declared->push_back({who, set.distance});
}

// The distance to compute: --distance, else the one the inputs declare, else euclidean;
// `*how` says where it came from (for the description line).
DistanceMetric ChooseMetric(const EvaluateArgs& args, const std::vector<DeclaredDistance>& declared,
                            std::string* how) {
  if (args.metric) return *args.metric;
  if (declared.empty()) {
    *how = " (the default: --distance not given and no input declares one)";
    return DistanceMetric::kEuclidean;
  }
  const size_t more = declared.size() - 1;
  *how = " (--distance not given: declared by " + declared[0].who +
         (more > 0 ? " and " + std::to_string(more) + " more" : "") + ")";
  return ParseDistanceMetric(declared[0].distance);
}

// The reference sets, then the query, loaded (read, decoded and validated) on up to two
// threads at once; the first failure in argument order is thrown.
// What the description says of blind frames (BlindImageProblem) in image folders: the
// query's are no observations (`*unseen`, left empty if there are none), as the ingest drops
// them live; a reference folder's are places described by noise, named so the user can
// remove them. "" if there are none.
std::string BlindFramesNote(const EvaluateArgs& args,
                            const std::vector<std::vector<std::string>>& blind,
                            std::vector<bool>* unseen) {
  std::string note;
  for (size_t i = 0; i < blind.size(); ++i) {
    const std::vector<std::string>& rows = blind[i];
    std::vector<size_t> found;
    for (size_t r = 0; r < rows.size(); ++r) {
      if (!rows[r].empty()) found.push_back(r);
    }
    if (found.empty()) continue;
    const bool query = i + 1 == blind.size();
    if (query) {
      unseen->assign(rows.size(), false);
      for (size_t r : found) (*unseen)[r] = true;
    }
    note +=
        "; " + std::to_string(found.size()) + " of the " + std::to_string(rows.size()) +
        (query ? " query images" : " images of reference set '" + args.references[i].name + "'") +
        " show nothing (first: row " + std::to_string(found[0]) + ", which " + blind[i][found[0]] +
        ")" +
        (query ? ": no observation, as the ingest drops them live (no match, no step of "
                 "any filter)"
               : ": places described by noise; remove those frames");
  }
  return note;
}

// The reference sets and, last, the query; `blind` as LoadAnySet says, per set.
std::vector<ReferenceSet> LoadAllSets(const EvaluateArgs& args,
                                      std::vector<std::vector<std::string>>* blind) {
  std::vector<NamedPath> inputs = args.references;
  inputs.push_back({"query", args.query});
  std::vector<ReferenceSet> sets(inputs.size());
  blind->assign(inputs.size(), {});
  std::vector<std::exception_ptr> errors(inputs.size());
  std::atomic<size_t> next{0};
  const auto work = [&] {
    std::unique_ptr<ImageDescriber> describer;  // one per thread: describers are not shared
    for (size_t i = next++; i < inputs.size(); i = next++) {
      try {
        // --memory-map: the reference sets' files mapped at --storage; the queries read.
        ReadSetOptions read;
        if (args.memory_map && i < args.references.size()) read.memory_map = args.storage;
        sets[i] = LoadAnySet(inputs[i].path, inputs[i].name, args.describer, read, &describer,
                             &(*blind)[i]);
      } catch (...) {
        errors[i] = std::current_exception();
      }
    }
  };
  std::thread second(work);
  work();
  second.join();
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  return sets;
}

void LoadDescriptors(const EvaluateArgs& args, EvaluationData* data) {
  data->map.SetStoragePrecision(args.storage);
  std::vector<DeclaredDistance> declared;
  std::vector<std::vector<std::string>> blind;
  std::vector<ReferenceSet> sets = LoadAllSets(args, &blind);
  const std::string blind_note = BlindFramesNote(args, blind, &data->input.unseen);
  ReferenceSet query = std::move(sets.back());
  sets.pop_back();
  for (size_t u = 0; u < sets.size(); ++u) {
    const NamedPath& r = args.references[u];
    NoteDeclaredDistance(args, "reference set '" + r.name + "' (" + r.path + ")", sets[u],
                         &declared);
    data->map.Add(std::move(sets[u]));
  }
  NoteDeclaredDistance(args, "query '" + args.query + "'", query, &declared);
  std::string how;
  const DistanceMetric metric = ChooseMetric(args, declared, &how);
  data->metric = metric;
  if (query.dimension() != data->map.dimension()) {
    throw std::invalid_argument("query '" + args.query + "' has dimension " +
                                std::to_string(query.dimension()) + ", the reference sets have " +
                                std::to_string(data->map.dimension()));
  }
  data->queries = std::move(query.descriptors);
  data->query_poses = std::move(query.poses);
  data->input.num_queries = static_cast<int>(data->queries.rows());
  data->input.num_places = data->map.num_places();
  for (const StoredReferenceSet& s : data->map.sets()) {
    data->input.set_names.push_back(s.name());
    data->input.place_ids.push_back(s.place_ids());
  }
  data->stage.SetOptions(args.first_stage);
  data->stage.Prepare(data->map);  // the pca index, built once for the whole evaluation
  data->input.distances = [data, metric](int begin, int end, std::vector<RowMatrixXf>* block) {
    const RowMatrixXf q = data->queries.middleRows(begin, end - begin);
    *block = data->stage.Distances(metric, q, data->map);
  };
  try {  // the joint representations need sets that share places
    std::vector<const StoredReferenceSet*> sets;
    for (const StoredReferenceSet& s : data->map.sets()) sets.push_back(&s);
    CheckJointSets(sets, data->map.num_places());
  } catch (const std::invalid_argument& e) {
    data->joint_problem = e.what();
  }
  data->description = std::to_string(data->map.num_sets()) + " reference set(s), " +
                      std::to_string(data->map.num_places()) + " places, " +
                      std::to_string(data->input.num_queries) + " queries, dimension " +
                      std::to_string(data->map.dimension()) + ", " + ToString(args.storage) +
                      " storage, " + ToString(metric) + " distance" + how +
                      (data->stage.index() ? ", first stage " + data->stage.Summary() : "") +
                      blind_note;
}

void LoadMatrices(const EvaluateArgs& args, EvaluationData* data) {
  std::vector<NamedPath> sources;
  for (const NamedPath& p : args.distances) sources.push_back(p);
  for (const NamedPath& p : args.similarities) sources.push_back(p);
  for (const NamedPath& p : sources) {
    for (const std::string& n : data->input.set_names) {
      if (n == p.name) throw std::invalid_argument("source name '" + p.name + "' is given twice");
    }
    RowMatrixXf m = ReadNpyMatrix(p.path);
    if (m.size() == 0) throw std::invalid_argument("'" + p.path + "' is an empty matrix");
    if (!m.allFinite()) throw std::invalid_argument("'" + p.path + "' holds NaN or infinity");
    if (!data->matrices.empty() &&
        (m.rows() != data->matrices[0].rows() || m.cols() != data->matrices[0].cols())) {
      throw std::invalid_argument("'" + p.path + "' is " + std::to_string(m.rows()) + " x " +
                                  std::to_string(m.cols()) + ", the first source is " +
                                  std::to_string(data->matrices[0].rows()) + " x " +
                                  std::to_string(data->matrices[0].cols()));
    }
    data->matrices.push_back(std::move(m));
    data->input.set_names.push_back(p.name);
  }
  const size_t num_dist = args.distances.size();
  for (size_t u = 0; u < num_dist; ++u) {
    if (data->matrices[u].minCoeff() < 0) {
      throw std::invalid_argument("'" + args.distances[u].path +
                                  "' holds negative distances (use --similarities for scores)");
    }
  }
  std::vector<const RowMatrixXf*> sims;
  for (size_t u = num_dist; u < data->matrices.size(); ++u) sims.push_back(&data->matrices[u]);
  if (!sims.empty()) {
    const float offset = SimilarityOffset(sims);
    for (size_t u = num_dist; u < data->matrices.size(); ++u) {
      SimilaritiesToDistances(offset, &data->matrices[u]);
    }
  }
  data->input.num_queries = static_cast<int>(data->matrices[0].rows());
  data->input.num_places = static_cast<int>(data->matrices[0].cols());
  data->input.place_ids.assign(data->matrices.size(), {});
  // Matrices of different techniques are different descriptors, each its own group.
  data->input.groups.assign(data->matrices.size(), 0);
  if (!args.same_descriptor) std::iota(data->input.groups.begin(), data->input.groups.end(), 0);
  data->input.distances = [data](int begin, int end, std::vector<RowMatrixXf>* block) {
    block->resize(data->matrices.size());
    for (size_t u = 0; u < data->matrices.size(); ++u) {
      (*block)[u] = data->matrices[u].middleRows(begin, end - begin);
    }
  };
  data->joint_problem =
      "the joint representations of the sets need their descriptors (--reference), not "
      "distance or similarity matrices";
  data->description = std::to_string(data->matrices.size()) + " source matri" +
                      (data->matrices.size() == 1 ? "x" : "ces") + ", " +
                      std::to_string(data->input.num_places) + " places, " +
                      std::to_string(data->input.num_queries) + " queries";
}

// --tolerance-m offline: query poses from --query-poses or the query YAML, place poses from
// the reference sets.
// --query-poses, read once for --tolerance-m and --odometry poses: refused for a query with
// poses of its own.
void ReadQueryPosesArg(const EvaluateArgs& args, EvaluationData* data) {
  if (!data->query_poses.empty()) {
    throw std::invalid_argument("query '" + args.query +
                                "' has poses of its own: --query-poses is for a query "
                                "without (a .npy or an image folder)");
  }
  data->query_poses = ReadQueryPosesCsv(args.query_poses, data->input.num_queries);
}

// Where the query poses came from, for the output lines.
std::string QueryPoseSource(const EvaluateArgs& args) {
  return args.query_poses.empty() ? "query '" + args.query + "'" : "'" + args.query_poses + "'";
}

void LoadMetricTruth(const EvaluateArgs& args, EvaluationData* data) {
  const std::string query_source = QueryPoseSource(args);
  if (data->query_poses.empty()) {
    throw std::invalid_argument(
        "--tolerance-m needs query poses: give --query-poses CSV, or the query as a YAML with "
        "'poses'");
  }
  const std::vector<std::optional<PlacePose>> place_poses = PlacePosesOf(data->map);
  data->truth = GroundTruth::FromMetricTolerance(data->query_poses, place_poses, args.tolerance_m);
  data->truth_description = DescribeMetricTruth(args.tolerance_m, query_source, place_poses);
}

// --odometry poses: each query's step from the query poses (as the node's OdometryProgress
// takes them: the distance moved since the previous seen query over the place spacing;
// none at the first seen query and at a blind one), and a line of the description.
void LoadOdometry(const EvaluateArgs& args, EvaluationData* data) {
  const std::string source = QueryPoseSource(args);
  if (data->query_poses.empty()) {
    throw std::invalid_argument(
        "--odometry poses needs query poses: give --query-poses CSV, or the query as a YAML "
        "with 'poses'");
  }
  double spacing = args.place_spacing_m;
  std::string how = " (--place-spacing-m)";
  if (!(spacing > 0)) {
    const std::optional<double> median = ReferenceSets::MedianSpacing(data->map.place_poses());
    if (!median || !(*median > 0)) {
      throw std::invalid_argument(
          "--odometry poses needs the place spacing: give --place-spacing-m, or reference "
          "sets with 'poses'");
    }
    spacing = *median;
    how = " (the median spacing of the places' poses)";
  }
  const std::vector<bool>& unseen = data->input.unseen;
  std::vector<double>& steps = data->input.odometry_steps;
  steps.assign(static_cast<size_t>(data->input.num_queries), std::nan(""));
  std::optional<Eigen::Vector3d> last;  // the pose at the previous seen query
  for (size_t q = 0; q < steps.size(); ++q) {
    if (!unseen.empty() && unseen[q]) continue;
    const PlacePose& p = data->query_poses[q];
    const Eigen::Vector3d at(p.x_m, p.y_m, p.z_m);
    if (last) steps[q] = (at - *last).norm() / spacing;
    last = at;
  }
  char metres[32];
  std::snprintf(metres, sizeof(metres), "%.3g", spacing);
  data->description +=
      "; odometry from the poses of " + source + ", a place every " + metres + " m" + how;
}

}  // namespace

std::unique_ptr<EvaluationData> LoadEvaluationData(const EvaluateArgs& args) {
  auto data = std::make_unique<EvaluationData>();
  if (!args.references.empty()) {
    LoadDescriptors(args, data.get());
  } else {
    LoadMatrices(args, data.get());
  }
  if (!args.query_poses.empty()) ReadQueryPosesArg(args, data.get());
  if (args.tolerance_frames >= 0) {
    data->truth = GroundTruth::FromFrameTolerance(data->input.num_queries, data->input.num_places,
                                                  args.tolerance_frames);
    data->truth_description = DescribeFrameTruth(args.tolerance_frames);
  } else if (args.tolerance_m >= 0) {
    LoadMetricTruth(args, data.get());
  } else {
    data->truth =
        ReadGroundTruthFile(args.ground_truth, data->input.num_queries, data->input.num_places);
    data->truth_description = "the correct places listed in '" + args.ground_truth + "'";
  }
  data->truth_description += "; " + CountTrueMatches(data->truth);
  if (args.odometry) LoadOdometry(args, data.get());
  return data;
}

}  // namespace tools
}  // namespace bsf_vpr

namespace bsf_vpr {
namespace tools {

std::string PrepareJointRepresentations(const std::vector<Method>& methods,
                                        const MethodOptions& options, EvaluationData* data) {
  std::vector<JointKind> kinds;
  for (const Method& m : methods) {
    if (m.NeedsSharedPlaces() && !data->joint_problem.empty()) {
      throw std::invalid_argument("method '" + m.Name() + "': " + data->joint_problem);
    }
    const std::optional<JointKind> k = m.JointNeeded(options);
    if (!k || !data->joint_problem.empty()) continue;  // bsf: the sets alone
    if (std::find(kinds.begin(), kinds.end(), *k) == kinds.end()) kinds.push_back(*k);
  }
  if (kinds.empty()) return "";
  std::vector<const StoredReferenceSet*> sets;
  for (const StoredReferenceSet& s : data->map.sets()) sets.push_back(&s);
  std::string line;
  for (JointKind k : kinds) {
    const auto start = std::chrono::steady_clock::now();
    data->joints.push_back(
        JointRepresentation::Build(k, sets, data->map.num_places(), options.joint));
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    char took[32];
    std::snprintf(took, sizeof took, "%.2f s", seconds);
    line +=
        (line.empty() ? "" : ", ") + ToString(k) +
        (k == JointKind::kDiscriminant
             ? " (" + std::to_string(data->joints.back().discriminant_dimensions()) + " dimensions)"
             : std::string()) +
        " in " + took;
  }
  data->input.joint_kinds = kinds;
  data->input.joint_distances = [data](int begin, int end, std::vector<RowMatrixXf>* block) {
    const RowMatrixXf q = data->queries.middleRows(begin, end - begin);
    block->resize(data->joints.size());
    for (size_t j = 0; j < data->joints.size(); ++j) (*block)[j] = data->joints[j].Distances(q);
  };
  return "joint representations of the sets built: " + line;
}

std::vector<std::string> CalibrateMethods(const std::vector<Method>& methods,
                                          const MethodOptions& options,
                                          double max_false_accept_rate, EvaluationData* data) {
  std::vector<std::string> lines;
  if (max_false_accept_rate == 0) return lines;
  if (data->map.num_sets() == 0) {
    return {
        "the map is not calibrated: its sources are distance or similarity matrices, not "
        "descriptors (the threshold alone accepts)"};
  }
  data->input.acceptance_rules.assign(methods.size(), std::nullopt);
  for (size_t k = 0; k < methods.size(); ++k) {
    const MapCalibration c =
        CalibrateMap(data->map, data->metric, methods[k].Name(), options, max_false_accept_rate);
    if (c.usable()) data->input.acceptance_rules[k] = c.rule;
    char took[32];
    std::snprintf(took, sizeof took, " (%.2f s)", c.seconds);
    lines.push_back(c.Summary() + took);
  }
  return lines;
}

}  // namespace tools
}  // namespace bsf_vpr
