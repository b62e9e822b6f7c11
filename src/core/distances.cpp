#include "bsf_vpr/core/distances.h"

#include <algorithm>
#include <stdexcept>

namespace bsf_vpr {

DistanceMetric ParseDistanceMetric(const std::string& name) {
  if (name == "euclidean") return DistanceMetric::kEuclidean;
  if (name == "cosine") return DistanceMetric::kCosine;
  throw std::invalid_argument("unknown distance '" + name + "' (expected euclidean or cosine)");
}

std::string ToString(DistanceMetric metric) {
  return metric == DistanceMetric::kEuclidean ? "euclidean" : "cosine";
}

namespace {

void CheckQueries(const RowMatrixXf& queries, const ReferenceSet& set) {
  if (queries.cols() != set.descriptors.cols()) {
    throw std::invalid_argument("query descriptors have dimension " +
                                std::to_string(queries.cols()) + ", reference set '" + set.name +
                                "' has dimension " + std::to_string(set.descriptors.cols()));
  }
  if (!queries.allFinite()) {
    for (Eigen::Index q = 0; q < queries.rows(); ++q) {
      if (!queries.row(q).allFinite()) {
        throw std::invalid_argument("query descriptor " + std::to_string(q) +
                                    " holds NaN or infinity");
      }
    }
  }
}

}  // namespace

RowMatrixXf ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                             const ReferenceSet& set) {
  CheckQueries(queries, set);
  const RowMatrixXf& refs = set.descriptors;
  RowMatrixXf out = queries * refs.transpose();  // Q x N_u inner products
  if (metric == DistanceMetric::kEuclidean) {
    const Eigen::VectorXf qn = queries.rowwise().squaredNorm();
    const Eigen::RowVectorXf rn = refs.rowwise().squaredNorm().transpose();
    for (Eigen::Index q = 0; q < out.rows(); ++q) {
      out.row(q) = ((-2.0f * out.row(q) + rn).array() + qn(q)).max(0.0f).sqrt().matrix();
    }
  } else {
    const Eigen::VectorXf qn = queries.rowwise().norm();
    const Eigen::RowVectorXf rn = refs.rowwise().norm().transpose();
    const Eigen::RowVectorXf r_inv = (rn.array() > 0).select(rn.array().inverse(), 0.0f);
    for (Eigen::Index q = 0; q < out.rows(); ++q) {
      const float q_inv = qn(q) > 0 ? 1.0f / qn(q) : 0.0f;
      out.row(q) = (1.0f - (out.row(q).array() * r_inv.array() * q_inv)).max(0.0f).matrix();
    }
  }
  return out;
}

std::vector<RowMatrixXf> ComputeDistances(DistanceMetric metric, const RowMatrixXf& queries,
                                          const ReferenceMap& map) {
  std::vector<RowMatrixXf> out;
  out.reserve(static_cast<size_t>(map.num_sets()));
  for (const ReferenceSet& set : map.sets()) out.push_back(ComputeDistances(metric, queries, set));
  return out;
}

std::vector<SetDistances> QueryRowViews(const std::vector<RowMatrixXf>& per_set, int query,
                                        const std::vector<const std::vector<int>*>& place_ids) {
  std::vector<SetDistances> views(per_set.size());
  for (size_t u = 0; u < per_set.size(); ++u) {
    views[u].values = per_set[u].row(query).data();
    views[u].count = static_cast<int>(per_set[u].cols());
    views[u].place_ids = (u < place_ids.size() && place_ids[u]) ? place_ids[u]->data() : nullptr;
  }
  return views;
}

float SimilarityOffset(const std::vector<const RowMatrixXf*>& similarities) {
  float offset = 1.0f;
  for (const RowMatrixXf* s : similarities) {
    if (s->size() > 0) offset = std::max(offset, s->maxCoeff());
  }
  return offset;
}

void SimilaritiesToDistances(float offset, RowMatrixXf* matrix) {
  matrix->array() = (offset - matrix->array()).max(0.0f);
}

}  // namespace bsf_vpr
