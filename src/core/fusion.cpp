#include "bsf_vpr/core/fusion.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>

#include "bsf_vpr/core/distances.h"
#include "src/core/internal/fusion_parts.h"
#include "src/core/internal/vector_math.h"
#include "src/core/internal/worker_pool.h"

namespace bsf_vpr {
namespace internal {

double Correlation(const Eigen::Ref<const Eigen::ArrayXd>& x,
                   const Eigen::Ref<const Eigen::ArrayXd>& y) {
  double n = 0, sx = 0, sy = 0;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x(i)) || !std::isfinite(y(i))) continue;
    n += 1;
    sx += x(i);
    sy += y(i);
  }
  if (n < 2) return 0;
  const double mx = sx / n, my = sy / n;
  double sxx = 0, syy = 0, sxy = 0;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x(i)) || !std::isfinite(y(i))) continue;
    const double dx = x(i) - mx, dy = y(i) - my;
    sxx += dx * dx;
    syy += dy * dy;
    sxy += dx * dy;
  }
  return sxx > 0 && syy > 0 ? sxy / std::sqrt(sxx * syy) : 0.0;
}

int CheckedPlace(const SetDistances& d, int k, int num_places) {
  const int place = d.PlaceAt(k);
  if (place < 0 || place >= num_places) {
    throw std::invalid_argument("place id " + std::to_string(place) + " is outside 0.." +
                                std::to_string(num_places - 1));
  }
  return place;
}

bool CoversEachPlaceInOrder(const SetDistances& d, int num_places) {
  if (d.count != num_places) return false;
  if (d.place_ids == nullptr) return true;
  for (int k = 0; k < d.count; ++k) {
    if (d.place_ids[k] != k) return false;
  }
  return true;
}

}  // namespace internal

double LogOddsOfBest(const Eigen::VectorXd& log_p, int best) {
  double other_max = -INFINITY;
  for (Eigen::Index i = 0; i < log_p.size(); ++i) {
    if (i != best) other_max = std::max(other_max, log_p(i));
  }
  if (other_max == -INFINITY) return INFINITY;
  double sum = 0;
  for (Eigen::Index i = 0; i < log_p.size(); ++i) {
    if (i != best) sum += std::exp(log_p(i) - other_max);
  }
  return log_p(best) - (other_max + std::log(sum));
}

std::vector<int> TopK(const Eigen::VectorXd& score, int k) {
  const size_t kk =
      std::min(static_cast<size_t>(std::max(k, 0)), static_cast<size_t>(score.size()));
  const auto before = [&score](int a, int b) {  // best first; among equal scores the earlier
    return score(a) > score(b) || (score(a) == score(b) && a < b);
  };
  std::vector<int> top;
  if (kk == 0) return top;
  constexpr size_t kOnePassMax = 64;
  if (kk > kOnePassMax) {  // many: every possible place, then a partial sort
    top.reserve(static_cast<size_t>(score.size()));
    for (Eigen::Index i = 0; i < score.size(); ++i) {
      if (score(i) > -INFINITY) top.push_back(static_cast<int>(i));
    }
    const size_t n = std::min(kk, top.size());
    std::partial_sort(top.begin(), top.begin() + static_cast<long>(n), top.end(), before);
    top.resize(n);
    return top;
  }
  // Few: one pass keeping the best k so far, most places turned away by one comparison with
  // the k-th.
  top.reserve(kk + 1);
  for (Eigen::Index i = 0; i < score.size(); ++i) {
    const double s = score(i);
    if (!(s > -INFINITY)) continue;                              // impossible, or NaN
    if (top.size() == kk && !(s > score(top.back()))) continue;  // a tie: the earlier stays
    auto at = top.end();
    while (at != top.begin() && score(*(at - 1)) < s) --at;
    top.insert(at, static_cast<int>(i));
    if (top.size() > kk) top.pop_back();
  }
  return top;
}

void ValidateLogPrior(const Eigen::VectorXd& log_prior, int num_places) {
  if (log_prior.size() != num_places) {
    throw std::invalid_argument("prior has " + std::to_string(log_prior.size()) +
                                " entries, the map has " + std::to_string(num_places) + " places");
  }
  bool any = false;
  for (Eigen::Index i = 0; i < log_prior.size(); ++i) {
    if (std::isnan(log_prior(i)) || log_prior(i) == INFINITY) {
      throw std::invalid_argument("log prior entry " + std::to_string(i) + " is NaN or +inf");
    }
    any = any || log_prior(i) > -INFINITY;
  }
  if (!any) throw std::invalid_argument("prior gives every place probability zero");
}

namespace internal {

void StartFromPrior(const Eigen::VectorXd* log_prior, int num_places, PlaceBelief* out) {
  if (log_prior) {
    ValidateLogPrior(*log_prior, num_places);
    out->log_posterior = *log_prior;
  } else {
    out->log_posterior = Eigen::VectorXd::Zero(num_places);
  }
}

void AddAtPlaces(const SetDistances& d, const std::vector<double>& values, int num_places,
                 Eigen::VectorXd* to) {
  if (internal::CoversEachPlaceInOrder(d, num_places)) {
    *to += Eigen::Map<const Eigen::VectorXd>(values.data(), d.count);
  } else {
    for (int k = 0; k < d.count; ++k) {
      (*to)(internal::CheckedPlace(d, k, num_places)) += values[static_cast<size_t>(k)];
    }
  }
}

void NormalizePosterior(PlaceBelief* out) {
  if (out->log_posterior.hasNaN()) {
    // Only values out of range can get here (descriptors are checked on the way in); a NaN
    // belief must never be published, let alone accepted.
    throw std::invalid_argument("fusion produced a NaN posterior");
  }
  Eigen::Index best = 0;
  const double max_l = out->log_posterior.maxCoeff(&best);
  if (!std::isfinite(max_l)) {
    throw std::invalid_argument("fusion gives every place probability zero or infinity");
  }
  out->match = static_cast<int>(best);
  // One pass of exp for both the confidence and the normalisation: with the best place
  // left out, rest = sum_{i != best} exp(l_i - l_best).
  double& l_best = out->log_posterior(best);
  l_best = -INFINITY;
  const double rest = kernels::SumExp(out->log_posterior.data(), out->log_posterior.size(), max_l);
  l_best = max_l;
  // Where the other places lie so far below that the sum underflows, LogOddsOfBest rescales.
  out->confidence = rest > 1e-300 ? -std::log(rest) : LogOddsOfBest(out->log_posterior, out->match);
  // Normalise: log P(X = i | D^S) = l_i - logsumexp(l), logsumexp(l) = l_best + log(1 + rest).
  out->log_posterior.array() -= max_l + std::log1p(rest);
  out->cost = -out->log_posterior;
}

Groups GroupSets(const std::vector<SetDistances>& sets, const std::vector<double>& weights) {
  if (weights.size() != sets.size()) {
    throw std::invalid_argument("fusion: " + std::to_string(weights.size()) + " weights for " +
                                std::to_string(sets.size()) + " sets");
  }
  Groups groups;
  for (size_t u = 0; u < sets.size(); ++u) {
    if (!(weights[u] >= 0 && weights[u] <= 1)) {
      throw std::invalid_argument("fusion: weight " + std::to_string(weights[u]) + " of set " +
                                  std::to_string(u) + " is not in [0, 1]");
    }
    const auto it = std::find(groups.ids.begin(), groups.ids.end(), sets[u].group);
    const size_t g = static_cast<size_t>(it - groups.ids.begin());
    if (it == groups.ids.end()) {
      groups.ids.push_back(sets[u].group);
      groups.members.emplace_back();
      groups.components.emplace_back();
    }
    groups.members[g].push_back(static_cast<int>(u));
    if (weights[u] > 0) groups.components[g].push_back(static_cast<int>(u));
  }
  return groups;
}

}  // namespace internal

namespace {

// Each of the sets `use`'s log-likelihoods (ll[i] for set use[i], one entry per value),
// with the statistics stats_of(u); in parallel when there is enough work. `shifted` false
// leaves out the per-set constant where it cancels (a set that covers every place once).
template <typename StatsOf>
std::vector<std::vector<double>> SetLogLikelihoods(const std::vector<SetDistances>& sets,
                                                   const std::vector<int>& use, int num_places,
                                                   const LikelihoodOptions& likelihood,
                                                   const StatsOf& stats_of, bool shifted) {
  std::vector<std::vector<double>> ll(use.size());
  const auto likelihood_of = [&](int i) {
    const int u = use[static_cast<size_t>(i)];
    const SetDistances& d = sets.at(static_cast<size_t>(u));
    std::vector<double>& l = ll[static_cast<size_t>(i)];
    l.resize(static_cast<size_t>(d.count));
    if (!shifted && internal::CoversEachPlaceInOrder(d, num_places)) {
      UnnormalisedPlaceMatchLogLikelihood(d, stats_of(u), likelihood, l.data());
    } else {
      PlaceMatchLogLikelihood(d, stats_of(u), likelihood, l.data());
    }
  };
  int64_t work = 0;
  for (int u : use) work += sets.at(static_cast<size_t>(u)).count;
  RunParallel(static_cast<int>(use.size()), work >= 50000 ? DistanceThreads() : 1, likelihood_of);
  return ll;
}

// The statistics of all the distances of the sets `members` together, from theirs: the
// count-weighted mean, and the variance as the mean of the sets' variances plus the spread
// of their means.
DistanceStats PooledStats(const std::vector<SetDistances>& sets,
                          const std::vector<DistanceStats>& stats,
                          const std::vector<int>& members) {
  double n = 0, sum = 0;
  for (int u : members) {
    n += sets[static_cast<size_t>(u)].count;
    sum += sets[static_cast<size_t>(u)].count * stats[static_cast<size_t>(u)].mean;
  }
  DistanceStats pooled;
  pooled.mean = sum / n;
  double ss = 0;
  for (int u : members) {
    const DistanceStats& st = stats[static_cast<size_t>(u)];
    const double e = st.mean - pooled.mean;
    ss += sets[static_cast<size_t>(u)].count * (st.stddev * st.stddev + e * e);
  }
  pooled.stddev = std::sqrt(ss / n);
  return pooled;
}

}  // namespace

namespace internal {

std::vector<DistanceStats> PooledGroupStats(const std::vector<SetDistances>& sets,
                                            const Groups& groups,
                                            const std::vector<DistanceStats>& set_stats) {
  if (set_stats.size() != sets.size()) {
    throw std::invalid_argument("fusion: " + std::to_string(set_stats.size()) +
                                " set statistics for " + std::to_string(sets.size()) + " sets");
  }
  std::vector<DistanceStats> pooled(sets.size());
  for (size_t g = 0; g < groups.ids.size(); ++g) {
    const DistanceStats p = PooledStats(sets, set_stats, groups.members[g]);
    for (int u : groups.components[g]) pooled[static_cast<size_t>(u)] = p;
  }
  return pooled;
}

std::vector<Eigen::VectorXd> PooledLogLikelihoods(const std::vector<SetDistances>& sets,
                                                  const Groups& groups, int num_places,
                                                  const LikelihoodOptions& likelihood,
                                                  const std::vector<DistanceStats>& set_stats) {
  const std::vector<DistanceStats> pooled = PooledGroupStats(sets, groups, set_stats);
  std::vector<int> use;
  for (const std::vector<int>& c : groups.components) use.insert(use.end(), c.begin(), c.end());
  std::sort(use.begin(), use.end());
  const std::vector<std::vector<double>> ll = SetLogLikelihoods(
      sets, use, num_places, likelihood, [&](int u) { return pooled[static_cast<size_t>(u)]; },
      true);
  std::vector<Eigen::VectorXd> columns(sets.size());
  for (size_t i = 0; i < use.size(); ++i) {
    const size_t u = static_cast<size_t>(use[i]);
    if (CoversEachPlaceInOrder(sets[u], num_places)) {  // the values are the column
      columns[u] = Eigen::Map<const Eigen::VectorXd>(ll[i].data(), num_places);
      continue;
    }
    columns[u] = Eigen::VectorXd::Zero(num_places);
    AddAtPlaces(sets[u], ll[i], num_places, &columns[u]);
  }
  return columns;
}

Eigen::ArrayXd LogMixture(const std::vector<Eigen::VectorXd>& columns,
                          const std::vector<int>& members, const std::vector<double>& weights) {
  double total = 0;
  for (int u : members) total += weights[static_cast<size_t>(u)];
  const Eigen::Index n = columns[static_cast<size_t>(members.front())].size();
  // l_j = log(w_u / W) + log L_u(i) (no weight underflows), formed where it is used.
  std::vector<double> log_w(members.size());
  for (size_t j = 0; j < members.size(); ++j) {
    log_w[j] = std::log(weights[static_cast<size_t>(members[j])] / total);
  }
  const auto l = [&](size_t j) {
    return columns[static_cast<size_t>(members[j])].array() + log_w[j];
  };
  // Per place top + log sum_j exp(l_j - top), a column at a time: vectorised exp and log
  // (a scalar exp per place and set was most of the mixture's time, much of it in the
  // underflow path for components far below the top).
  Eigen::ArrayXd top = l(0);
  for (size_t j = 1; j < members.size(); ++j) top = top.max(l(j));
  Eigen::ArrayXd sum = Eigen::ArrayXd::Zero(n);
  Eigen::ArrayXd below(n);
  for (size_t j = 0; j < members.size(); ++j) {
    below = l(j) - top;
    kernels::Exp(below.data(), n, 0.0, below.data());
    sum += below;
  }
  return top + LogOf(sum);
}

}  // namespace internal

const EnumNames<FusionRule>& FusionRuleNames() {
  static const EnumNames<FusionRule> kNames{{FusionRule::kAdaptive, "adaptive"},
                                            {FusionRule::kMixture, "mixture"},
                                            {FusionRule::kProduct, "product"}};
  return kNames;
}

FusionRule ParseFusionRule(const std::string& name) {
  return FusionRuleNames().Parse(name, "fusion");
}

std::string ToString(FusionRule rule) { return FusionRuleNames().Name(rule); }

void FuseBayes(const std::vector<SetDistances>& sets, const std::vector<int>& use, int num_places,
               const LikelihoodOptions& likelihood, const Eigen::VectorXd* log_prior,
               PlaceBelief* out, const std::vector<DistanceStats>* set_stats) {
  if (set_stats != nullptr && set_stats->size() != sets.size()) {
    throw std::invalid_argument("FuseBayes: " + std::to_string(set_stats->size()) +
                                " set statistics for " + std::to_string(sets.size()) + " sets");
  }
  internal::StartFromPrior(log_prior, num_places, out);
  // Added in set order, so the sum is the same on any number of threads.
  const std::vector<std::vector<double>> ll = SetLogLikelihoods(
      sets, use, num_places, likelihood,
      [&](int u) {
        return set_stats ? (*set_stats)[static_cast<size_t>(u)]
                         : ComputeDistanceStats(sets.at(static_cast<size_t>(u)));
      },
      false);
  for (size_t i = 0; i < use.size(); ++i) {
    internal::AddAtPlaces(sets.at(static_cast<size_t>(use[i])), ll[i], num_places,
                          &out->log_posterior);
  }
  internal::NormalizePosterior(out);
}

void FuseMixture(const std::vector<SetDistances>& sets, const std::vector<double>& weights,
                 int num_places, const LikelihoodOptions& likelihood,
                 const Eigen::VectorXd* log_prior, PlaceBelief* out,
                 const std::vector<DistanceStats>& set_stats) {
  const internal::Groups groups = internal::GroupSets(sets, weights);
  const std::vector<Eigen::VectorXd> columns =
      internal::PooledLogLikelihoods(sets, groups, num_places, likelihood, set_stats);
  internal::StartFromPrior(log_prior, num_places, out);
  for (const std::vector<int>& c : groups.components) {
    if (c.empty()) continue;
    if (c.size() == 1) {  // one component: its own likelihood
      out->log_posterior += columns[static_cast<size_t>(c[0])];
    } else {
      out->log_posterior.array() += internal::LogMixture(columns, c, weights);
    }
  }
  internal::NormalizePosterior(out);
}

void FuseMinEnsembleDistance(const std::vector<SetDistances>& sets, const std::vector<int>& use,
                             int num_places, PlaceBelief* out) {
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(num_places);
  Eigen::VectorXi covered = Eigen::VectorXi::Zero(num_places);
  for (int u : use) {
    const SetDistances& d = sets.at(static_cast<size_t>(u));
    for (int k = 0; k < d.count; ++k) {
      const int place = internal::CheckedPlace(d, k, num_places);
      sum(place) += d.values[k];
      covered(place) += 1;
    }
  }
  Eigen::VectorXd neg_mean(num_places);  // higher is better; -inf where nothing covers
  for (int i = 0; i < num_places; ++i) {
    neg_mean(i) = covered(i) > 0 ? -sum(i) / covered(i) : -INFINITY;
  }
  const std::vector<int> best = TopK(neg_mean, 1);
  if (best.empty()) throw std::invalid_argument("no reference set covers any place");
  out->match = best.front();
  out->confidence = neg_mean(out->match);
  out->log_posterior.resize(0);
  out->cost = -neg_mean;
}

}  // namespace bsf_vpr
