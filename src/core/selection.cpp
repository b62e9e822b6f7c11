#include "bsf_vpr/core/selection.h"

#include <cmath>
#include <stdexcept>

namespace bsf_vpr {

SelectionRule ParseSelectionRule(const std::string& name) {
  if (name == "relative") return SelectionRule::kRelative;
  if (name == "standardized") return SelectionRule::kStandardized;
  throw std::invalid_argument("unknown selection rule '" + name +
                              "' (expected relative or standardized)");
}

std::string ToString(SelectionRule rule) {
  return rule == SelectionRule::kRelative ? "relative" : "standardized";
}

void SelectionOptions::Validate() const {
  if (!(gamma_fraction >= 0) || !std::isfinite(gamma_fraction)) {
    throw std::invalid_argument("gamma_fraction must be a finite number >= 0, got " +
                                std::to_string(gamma_fraction));
  }
}

DistanceStats ComputeDistanceStats(const SetDistances& d) {
  DistanceStats s;
  if (d.count <= 0) throw std::invalid_argument("a reference set has no distances");
  s.min = d.values[0];
  double sum = 0;
  for (int k = 0; k < d.count; ++k) {
    sum += d.values[k];
    if (d.values[k] < s.min) {
      s.min = d.values[k];
      s.argmin = k;
    }
  }
  s.mean = sum / d.count;
  double ss = 0;  // two passes: exact zero variance for constant vectors
  for (int k = 0; k < d.count; ++k) {
    const double e = d.values[k] - s.mean;
    ss += e * e;
  }
  s.stddev = std::sqrt(ss / d.count);
  return s;
}

Selection SelectReferenceSets(const std::vector<SetDistances>& sets,
                              const SelectionOptions& options) {
  if (sets.empty()) throw std::invalid_argument("selection needs at least one reference set");
  const size_t m = sets.size();
  Selection out;
  std::vector<double> score(m);  // lower is better for both rules
  for (size_t u = 0; u < m; ++u) {
    const DistanceStats st = ComputeDistanceStats(sets[u]);
    out.set_stats.push_back(st);
    if (options.rule == SelectionRule::kRelative) {
      score[u] = st.min;
    } else {
      score[u] = st.stddev > 0 ? -(st.mean - st.min) / st.stddev : 0.0;
    }
  }
  size_t best = 0;
  for (size_t u = 1; u < m; ++u) {
    if (score[u] < score[best]) best = u;
  }
  out.best = static_cast<int>(best);
  // Relative: score = min, reference |score*| = min*. Standardized: score = -s_u, and
  // s_u* - s_u = score_u - score*, reference s_u* = -score*. Both: score_u - score* <=
  // gamma*|score*|.
  const double slack = options.gamma_fraction * std::abs(score[best]);
  for (size_t u = 0; u < m; ++u) {
    if (u == best || score[u] - score[best] <= slack) out.selected.push_back(static_cast<int>(u));
  }
  return out;
}

}  // namespace bsf_vpr
