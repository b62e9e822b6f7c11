// Loading the inputs of bsf_evaluate: reference sets and queries (descriptor files or image
// folders), or precomputed distance/similarity matrices, plus the ground truth.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "bsf_vpr/core/first_stage.h"
#include "bsf_vpr/core/joint_representation.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/evaluation/evaluation_runner.h"
#include "src/tools/evaluate/evaluate_args.h"

namespace bsf_vpr {
namespace tools {

// `input.distances` refers to this object's members: it is neither copied nor moved (it is
// made in place, behind a unique_ptr).
struct EvaluationData {
  EvaluationData() = default;
  EvaluationData(const EvaluationData&) = delete;  // no implicit move either
  EvaluationData& operator=(const EvaluationData&) = delete;

  ReferenceSets map;     // descriptor mode
  DistanceMetric metric = DistanceMetric::kEuclidean;  // descriptor mode
  DistanceStage stage;  // descriptor mode: exact or the pca first stage
  RowMatrixXf queries;  // descriptor mode, Q x D
  // descriptor mode with --tolerance-m: from the query YAML or --query-poses (else empty)
  std::vector<PlacePose> query_poses;
  std::vector<RowMatrixXf> matrices;  // matrix mode, one Q x N distance matrix per source
  EvaluationInput input;              // refers to the members above
  // The joint representations the methods need (PrepareJointRepresentations), and why
  // none can be built ("" if they can: descriptor mode, two or more sets sharing places).
  std::vector<JointRepresentation> joints;
  std::string joint_problem;
  GroundTruth truth;
  std::string description;        // one line: what was loaded
  std::string truth_description;  // one line: which ground truth, how many have a true match
};

// Throws std::exception with a message naming the file and the problem.
std::unique_ptr<EvaluationData> LoadEvaluationData(const EvaluateArgs& args);

// Builds the joint representations `methods` need with `options` (Method::JointNeeded) and
// sets input.joint_kinds and input.joint_distances; returns a line saying what was built and
// how long it took ("" if nothing). Throws std::invalid_argument (joint_problem) when a method
// of the joint sources (mean_descriptor, union_nn, subspace, discriminant) is asked for and
// they cannot be built; bsf then fuses the sets alone.
std::string PrepareJointRepresentations(const std::vector<Method>& methods,
                                        const MethodOptions& options, EvaluationData* data);

// The map's acceptance rule of each method (self_calibration.h) for `max_false_accept_rate`,
// into input.acceptance_rules; returns a line per method saying what the map predicts ("on
// this map: ..."). Nothing with a rate of 0; in matrix mode, one line saying why the map
// cannot calibrate itself.
std::vector<std::string> CalibrateMethods(const std::vector<Method>& methods,
                                          const MethodOptions& options,
                                          double max_false_accept_rate, EvaluationData* data);

}  // namespace tools
}  // namespace bsf_vpr
