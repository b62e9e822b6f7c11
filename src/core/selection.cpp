#include "bsf_vpr/core/selection.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "bsf_vpr/core/distances.h"
#include "src/core/internal/vector_math.h"
#include "src/core/internal/worker_pool.h"

namespace bsf_vpr {

const EnumNames<SelectionRule>& SelectionRuleNames() {
  static const EnumNames<SelectionRule> kNames{{SelectionRule::kRelative, "relative"},
                                               {SelectionRule::kStandardized, "standardized"}};
  return kNames;
}

SelectionRule ParseSelectionRule(const std::string& name) {
  return SelectionRuleNames().Parse(name, "selection");
}

std::string ToString(SelectionRule rule) { return SelectionRuleNames().Name(rule); }

void SelectionOptions::Validate() const { SelectionOptionsTable().CheckValues(*this); }

const OptionTable<SelectionOptions>& SelectionOptionsTable() {
  constexpr bool kLive = true;
  static const OptionTable<SelectionOptions> kTable =
      OptionTable<SelectionOptions>()
          .Add(
              "gamma_fraction", [](auto& o) -> auto& { return o.gamma_fraction; },
              "selection fraction gamma: with selection relative, a set is selected when its "
              "minimum distance is within (1 + gamma) of the best set's (paper, Eq. "
              "reference_selection); with fusion mixture, the scale of the sets' soft weights "
              "(weight e^-1 at that boundary)",
              "", Finite(AtLeast(0)), kLive)
          .AddChoice(
              "selection", [](auto& o) -> auto& { return o.rule; },
              "selection rule: relative (the paper's) or standardized (scale-free, on "
              "each set's standardised minimum)",
              SelectionRuleNames(), kLive);
  return kTable;
}

DistanceStats ComputeDistanceStats(const SetDistances& d) {
  DistanceStats s;
  if (d.count <= 0) throw std::invalid_argument("a reference set has no distances");
  // Eight running sums and minima (lane j takes k = j mod 8), added in a fixed tree, on the
  // vector kernels (the same bits on each). The sum of floats in double is exact for any
  // distances of a modest range, so a constant vector still has its value as its mean and an
  // exact zero variance (two passes).
  constexpr int kLanes = 8;
  const float* v = d.values;
  const int n = d.count;
  float low[kLanes];
  std::fill(low, low + kLanes, v[0]);
  const double sum = kernels::LaneSum(v, n, low);
  s.min = *std::min_element(low, low + kLanes);
  s.argmin = static_cast<int>(std::find(v, v + n, s.min) - v);  // the first at the minimum
  if (s.argmin == n) s.argmin = 0;  // v[0] is NaN: as the scalar scan, index 0 kept
  s.min = v[s.argmin];              // (of -0 and +0, the value found first)
  s.mean = sum / n;
  s.stddev = std::sqrt(kernels::LaneSquaredDeviations(v, n, s.mean) / n);
  return s;
}

namespace {

// The rule's score of a set: lower is better for both rules (relative: min D^u;
// standardized: -s_u).
double Score(const DistanceStats& st, SelectionRule rule) {
  if (rule == SelectionRule::kRelative) return st.min;
  return st.stddev > 0 ? -(st.mean - st.min) / st.stddev : 0.0;
}

// Per set, the index of the best-scoring set of its group (all sets one group when
// `within_groups` is false).
std::vector<size_t> BestOfGroup(const std::vector<SetDistances>& sets,
                                const std::vector<double>& score, bool within_groups) {
  std::vector<size_t> best(sets.size());
  for (size_t u = 0; u < sets.size(); ++u) {
    best[u] = u;
    for (size_t v = 0; v < sets.size(); ++v) {
      const bool same = !within_groups || sets[v].group == sets[u].group;
      if (same && (score[v] < score[best[u]] || (score[v] == score[best[u]] && v < best[u]))) {
        best[u] = v;
      }
    }
  }
  return best;
}

}  // namespace

Selection SelectReferenceSets(const std::vector<SetDistances>& sets,
                              const SelectionOptions& options, bool within_groups) {
  if (sets.empty()) throw std::invalid_argument("selection needs at least one reference set");
  const size_t m = sets.size();
  Selection out;
  std::vector<double> score(m);
  // The sets' statistics, on the worker threads when there are many distances.
  out.set_stats.resize(m);
  int64_t work = 0;
  for (const SetDistances& d : sets) work += d.count;
  RunParallel(static_cast<int>(m), work >= 200000 ? DistanceThreads() : 1, [&](int u) {
    out.set_stats[static_cast<size_t>(u)] = ComputeDistanceStats(sets[static_cast<size_t>(u)]);
  });
  for (size_t u = 0; u < m; ++u) {
    score[u] = Score(out.set_stats[u], options.rule);
    if (std::isnan(score[u])) {
      throw std::invalid_argument("reference set " + std::to_string(u) +
                                  " has NaN distances: it cannot be selected or weighed");
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
  const std::vector<size_t> group_best = BestOfGroup(sets, score, within_groups);
  for (size_t u = 0; u < m; ++u) {
    const double ref = score[group_best[u]];
    if (u == group_best[u] || score[u] - ref <= options.gamma_fraction * std::abs(ref)) {
      out.selected.push_back(static_cast<int>(u));
    }
  }
  return out;
}

std::vector<double> ConditionWeights(const std::vector<SetDistances>& sets,
                                     const std::vector<DistanceStats>& stats,
                                     const SelectionOptions& options) {
  if (stats.size() != sets.size()) {
    throw std::invalid_argument("ConditionWeights: " + std::to_string(stats.size()) +
                                " set statistics for " + std::to_string(sets.size()) + " sets");
  }
  std::vector<double> score(sets.size());
  for (size_t u = 0; u < sets.size(); ++u) {
    score[u] = Score(stats[u], options.rule);
    if (std::isnan(score[u])) {
      throw std::invalid_argument("reference set " + std::to_string(u) +
                                  " has NaN distances: it cannot be weighed");
    }
  }
  const std::vector<size_t> group_best = BestOfGroup(sets, score, true);
  std::vector<double> w(sets.size());
  for (size_t u = 0; u < sets.size(); ++u) {
    const double excess = score[u] - score[group_best[u]];  // >= 0
    const double scale = options.gamma_fraction * std::abs(score[group_best[u]]);
    w[u] = excess <= 0 ? 1.0 : (scale > 0 ? std::exp(-excess / scale) : 0.0);
  }
  return w;
}

}  // namespace bsf_vpr
