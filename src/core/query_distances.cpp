#include "bsf_vpr/core/query_distances.h"

#include <stdexcept>
#include <string>

namespace bsf_vpr {

QueryDistances QueryDistances::AllPresent(std::vector<RowMatrixXf> distances) {
  QueryDistances out(static_cast<int>(distances.size()));
  for (size_t u = 0; u < distances.size(); ++u) out.sets_[u] = std::move(distances[u]);
  return out;
}

const RowMatrixXf& QueryDistances::of(int u) const {
  const std::optional<RowMatrixXf>& d = sets_.at(static_cast<size_t>(u));
  if (!d) throw std::logic_error("the distances to set " + std::to_string(u) + " are absent");
  return *d;
}

RowMatrixXf QueryDistances::Take(int u) {
  std::optional<RowMatrixXf>& d = sets_.at(static_cast<size_t>(u));
  if (!d) throw std::logic_error("the distances to set " + std::to_string(u) + " are absent");
  RowMatrixXf out = std::move(*d);
  d.reset();
  return out;
}

std::vector<int> QueryDistances::Absent() const {
  std::vector<int> out;
  for (size_t u = 0; u < sets_.size(); ++u) {
    if (!sets_[u]) out.push_back(static_cast<int>(u));
  }
  return out;
}

int QueryDistances::num_present() const {
  int n = 0;
  for (const std::optional<RowMatrixXf>& d : sets_) n += d.has_value();
  return n;
}

}  // namespace bsf_vpr
