// Loading the inputs of bsf_evaluate: reference sets and queries (descriptor files or image
// folders), or precomputed distance/similarity matrices, plus the ground truth.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "bsf_vpr/core/first_stage.h"
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

  ReferenceMap map;     // descriptor mode
  DistanceStage stage;  // descriptor mode: exact or the pca first stage
  RowMatrixXf queries;  // descriptor mode, Q x D
  // descriptor mode with --tolerance-m: from the query YAML or --query-poses (else empty)
  std::vector<PlacePose> query_poses;
  std::vector<RowMatrixXf> matrices;  // matrix mode, one Q x N distance matrix per source
  EvaluationInput input;              // refers to the members above
  GroundTruth truth;
  std::string description;        // one line: what was loaded
  std::string truth_description;  // one line: which ground truth, how many have a true match
};

// Throws std::exception with a message naming the file and the problem.
std::unique_ptr<EvaluationData> LoadEvaluationData(const EvaluateArgs& args);

}  // namespace tools
}  // namespace bsf_vpr
