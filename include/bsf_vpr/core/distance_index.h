// How a query's distances to the rows of the sets are found, in the manner of faiss's
// Index: every row exactly (ExactIndex), or through the pca first stage with exact
// re-ranking (ApproximateIndex). A map holds one (DistanceStage::Current) and asks it,
// whichever it is.
#pragma once

#include <vector>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

class DistanceIndex {
 public:
  virtual ~DistanceIndex() = default;
  // Q x N_u per set of `sets`, as ComputeDistances gives them (exact, or as the index's
  // first stage makes them). A set the index holds nothing of is left out: its element is
  // empty and (*covered)[u] false (true for the sets answered); with `covered` null that
  // throws std::invalid_argument. Throws std::invalid_argument for queries of another
  // dimension or holding NaN or infinity.
  virtual std::vector<RowMatrixXf> Search(DistanceMetric metric, const RowMatrixXf& queries,
                                          const ReferenceSets& sets,
                                          std::vector<bool>* covered) const = 0;
};

// Every stored row, exactly (ComputeDistances): holds nothing, answers for every set.
class ExactIndex final : public DistanceIndex {
 public:
  static const ExactIndex& Instance();
  std::vector<RowMatrixXf> Search(DistanceMetric metric, const RowMatrixXf& queries,
                                  const ReferenceSets& sets,
                                  std::vector<bool>* covered) const override;
};

}  // namespace bsf_vpr
