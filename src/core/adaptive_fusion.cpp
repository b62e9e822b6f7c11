#include "bsf_vpr/core/adaptive_fusion.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include "bsf_vpr/core/selection.h"
#include "src/core/internal/fusion_parts.h"
#include "src/core/internal/vector_math.h"
#include "src/core/internal/worker_pool.h"

namespace bsf_vpr {
namespace {

constexpr int kMixture = -1;
constexpr int kProduct = -2;
constexpr int kJoint = -3;  // the joint representation's hypothesis, and its places' means

constexpr double kLikelihoodFloor = 1e-300;
// Below this many values the likelihoods and the filters run on the calling thread alone.
constexpr int64_t kParallelWork = 50000;

// Per-place work in fixed blocks of places, in parallel when there is enough of it: what a
// block computes depends on its places alone, so the bits do not depend on the threads.
constexpr Eigen::Index kPlaceBlock = 8192;
int PlaceBlocks(int num_places) {
  return static_cast<int>((num_places + kPlaceBlock - 1) / kPlaceBlock);
}
// task(b, first place, count) for each block b; `passes`: the arrays it runs over per place
// (for the decision whether threads pay).
template <class Task>
void ForPlaceBlocks(int num_places, size_t passes, const Task& task) {
  const int blocks = PlaceBlocks(num_places);
  const int64_t work = static_cast<int64_t>(num_places) * static_cast<int64_t>(passes);
  RunParallel(blocks, work >= kParallelWork ? DistanceThreads() : 1, [&](int b) {
    const Eigen::Index i0 = b * kPlaceBlock;
    task(b, i0, std::min<Eigen::Index>(kPlaceBlock, num_places - i0));
  });
}

// Linear likelihood values (one per value of d) laid out over the places: 1 where d does not
// cover a place, the product of its values where it covers it more than once.
Eigen::ArrayXd LayOutLinear(const SetDistances& d, const Eigen::ArrayXd& values, int num_places) {
  if (internal::CoversEachPlaceInOrder(d, num_places)) return values;
  Eigen::ArrayXd out = Eigen::ArrayXd::Ones(num_places);
  for (int k = 0; k < d.count; ++k) out(d.PlaceAt(k)) *= values(k);  // ids checked before
  return out;
}

// Per place, the distance of set d's nearest row there (NaN where it has none).
Eigen::ArrayXd DistancesAtPlaces(const SetDistances& d, int num_places) {
  Eigen::ArrayXd out =
      Eigen::ArrayXd::Constant(num_places, std::numeric_limits<double>::quiet_NaN());
  for (int k = 0; k < d.count; ++k) {
    double& v = out(internal::CheckedPlace(d, k, num_places));
    if (!(v <= d.values[k])) v = d.values[k];  // NaN or larger
  }
  return out;
}

// Per set of `members`: 1 / sum_v max(rho_uv, 0), rho the correlation of the two sets'
// distances over the places (rho_uu = 1). Sets that say the same thing (rho near 1) share
// one vote between them; independent ones (rho <= 0) keep a whole vote each.
std::vector<double> IndependenceExponents(const std::vector<SetDistances>& sets,
                                          const std::vector<DistanceStats>& stats,
                                          const std::vector<int>& members, int num_places) {
  const size_t m = members.size();
  bool in_order = true;
  for (int u : members) {
    const SetDistances& d = sets[static_cast<size_t>(u)];
    in_order = in_order && internal::CoversEachPlaceInOrder(d, num_places);
  }
  std::vector<double> effect(m, 1.0);
  const auto add = [&effect](size_t j, size_t k, double rho) {
    const double shared = std::isfinite(rho) ? std::clamp(rho, 0.0, 1.0) : 0.0;
    effect[j] += shared;
    effect[k] += shared;
  };
  if (!in_order) {
    std::vector<Eigen::ArrayXd> at(m);
    for (size_t j = 0; j < m; ++j) {
      at[j] = DistancesAtPlaces(sets[static_cast<size_t>(members[j])], num_places);
    }
    for (size_t j = 0; j < m; ++j) {
      for (size_t k = j + 1; k < m; ++k) add(j, k, internal::Correlation(at[j], at[k]));
    }
    for (double& e : effect) e = 1.0 / e;
    return effect;
  }
  // With every place covered once, rho_uv is the dot product of the standardised columns.
  // They are formed a block of places at a time (in cache for all pairs), the blocks' sums
  // added in block order: the same bits with any number of threads.
  std::vector<double> offset(m), inverse(m);
  for (size_t j = 0; j < m; ++j) {
    const DistanceStats& st = stats[static_cast<size_t>(members[j])];
    const double norm = st.stddev * std::sqrt(static_cast<double>(num_places));
    offset[j] = st.mean;
    inverse[j] = norm > 0 ? 1.0 / norm : 0.0;
  }
  constexpr int kBlock = 2048;
  const int blocks = (num_places + kBlock - 1) / kBlock;
  const size_t pairs = m * (m - 1) / 2;
  std::vector<double> partial(static_cast<size_t>(blocks) * pairs);
  const auto block = [&](int b) {
    const int i0 = b * kBlock, len = std::min(kBlock, num_places - i0);
    Eigen::ArrayXXd z(len, static_cast<Eigen::Index>(m));
    for (size_t j = 0; j < m; ++j) {
      const float* v = sets[static_cast<size_t>(members[j])].values + i0;
      z.col(static_cast<Eigen::Index>(j)) =
          (Eigen::Map<const Eigen::ArrayXf>(v, len).cast<double>() - offset[j]) * inverse[j];
    }
    double* out = partial.data() + static_cast<size_t>(b) * pairs;
    for (Eigen::Index j = 0; j < z.cols(); ++j) {
      for (Eigen::Index k = j + 1; k < z.cols(); ++k) *out++ = (z.col(j) * z.col(k)).sum();
    }
  };
  const int64_t work = static_cast<int64_t>(num_places) * static_cast<int64_t>(pairs);
  RunParallel(blocks, work >= kParallelWork * 4 ? DistanceThreads() : 1, block);
  size_t pair = 0;
  for (size_t j = 0; j < m; ++j) {
    for (size_t k = j + 1; k < m; ++k, ++pair) {
      double rho = 0;
      for (int b = 0; b < blocks; ++b) rho += partial[static_cast<size_t>(b) * pairs + pair];
      add(j, k, rho);
    }
  }
  for (double& e : effect) e = 1.0 / e;
  return effect;
}

// Per source: the sets' non-match statistics pooled over their groups (every set of a group,
// as the singles and the product use them; the mixture's are the same for its sets of
// non-zero weight), then those of the sources after the sets (the joint) as they are.
std::vector<DistanceStats> PooledSourceStats(const std::vector<SetDistances>& sets,
                                             const std::vector<DistanceStats>& set_stats,
                                             const std::vector<DistanceStats>& source_stats,
                                             internal::Groups groups) {
  groups.components = groups.members;
  std::vector<DistanceStats> pooled = internal::PooledGroupStats(sets, groups, set_stats);
  pooled.insert(pooled.end(), source_stats.begin() + static_cast<long>(sets.size()),
                source_stats.end());
  return pooled;
}

// Each source's likelihood with the statistics `pooled` (one per source), each of mean 1 over
// the places, as a log column in (*log_l)[u] (0 where the source does not cover a place) and
// a linear one in (*lin_l)[u] (1 there); the buffers are resized and written over.
void SourceLikelihoods(const std::vector<SetDistances>& sources,
                       const std::vector<DistanceStats>& pooled, int num_places,
                       const LikelihoodOptions& likelihood, std::vector<Eigen::VectorXd>* log_l,
                       std::vector<Eigen::ArrayXd>* lin_l) {
  log_l->resize(sources.size());
  lin_l->resize(sources.size());
  const auto likelihood_of = [&](int k) {
    const size_t u = static_cast<size_t>(k);
    const SetDistances& d = sources[u];
    // With every place covered once in order (the usual case) the values are the columns.
    const bool in_order = internal::CoversEachPlaceInOrder(d, num_places);
    Eigen::VectorXd laid_out;
    Eigen::VectorXd& l = in_order ? (*log_l)[u] : laid_out;
    l.resize(d.count);
    UnnormalisedPlaceMatchLogLikelihood(d, pooled[u], likelihood, l.data());
    const double top = l.maxCoeff();
    Eigen::ArrayXd laid_out_linear;
    Eigen::ArrayXd& e = in_order ? (*lin_l)[u] : laid_out_linear;
    e.resize(d.count);
    const double mean = kernels::Exp(l.data(), d.count, top, e.data()) / d.count;
    e *= 1.0 / mean;
    l.array() -= top + std::log(mean);
    if (!in_order) {
      (*log_l)[u] = Eigen::VectorXd::Zero(num_places);
      internal::AddAtPlaces(d, std::vector<double>(l.data(), l.data() + l.size()), num_places,
                            &(*log_l)[u]);  // checks the place ids
      (*lin_l)[u] = LayOutLinear(d, e, num_places);
    }
  };
  int64_t work = 0;
  for (const SetDistances& d : sources) work += d.count;
  RunParallel(static_cast<int>(sources.size()), work >= kParallelWork ? DistanceThreads() : 1,
              likelihood_of);
}

}  // namespace

std::vector<double> AdaptiveFusion::LastWeights(int group) const {
  for (const GroupState& g : groups_) {
    if (g.group == group) return g.last_weights;
  }
  return {};
}

void AdaptiveFusion::Fuse(const Query& query, const AdaptiveFusionOptions& options,
                          bool update_state, PlaceBelief* out) {
  CheckQuery(query, options);
  // Everything below sees the distances corrected by their places' means. The condition
  // weights, the selection's soft form, are those of the raw distances (the caller's).
  const Sources sources = CorrectedSources(query, options);
  const internal::Groups groups = internal::GroupSets(sources.sets, query.weights);
  // The likelihoods: every source's, with its group's pooled non-match statistics.
  SourceLikelihoods(sources.corrected,
                    PooledSourceStats(sources.sets, sources.set_stats, sources.stats, groups),
                    query.num_places, query.likelihood, &log_l_, &lin_l_);
  // The fusion: per group its hypotheses averaged by their scores; the groups multiply.
  internal::StartFromPrior(query.log_prior, query.num_places, out);
  out->set_weights.assign(sources.sets.size(), 0.0);
  std::vector<GroupState> pending;  // what this query leaves in the state, with update_state
  for (size_t g = 0; g < groups.ids.size(); ++g) {
    const std::vector<int>& members = groups.members[g];
    if (members.size() == 1) {  // one set: the three hypotheses are its likelihood
      out->log_posterior += log_l_[static_cast<size_t>(members[0])];
      out->set_weights[static_cast<size_t>(members[0])] = 1.0;
      continue;
    }
    GroupState next =
        FuseGroup(query, sources, groups.ids[g], members, groups.components[g], options, out);
    if (update_state) {
      pending.push_back(std::move(next));
    } else {
      Recycle(&next.hypotheses);
    }
  }
  for (size_t u = 0; u < sources.sets.size(); ++u) {
    if (out->set_weights[u] > 0) out->used_sets.push_back(static_cast<int>(u));
  }
  // The posterior and its best place (the decision is the caller's: decision.h).
  internal::NormalizePosterior(out);
  // The state changes only once the belief is decided: a query that throws leaves it as it was.
  if (update_state) Commit(query.num_places, sources, options.place_prior_queries, &pending);
}

void AdaptiveFusion::CheckQuery(const Query& query, const AdaptiveFusionOptions& options) {
  const size_t n = query.sets.size();
  if (query.set_ids != nullptr && query.set_ids->size() != n) {
    throw std::invalid_argument("AdaptiveFusion: " + std::to_string(query.set_ids->size()) +
                                " set ids for " + std::to_string(n) + " sets");
  }
  if (!(options.memory_queries >= 1)) {
    throw std::invalid_argument("fusion_memory_queries must be at least 1, got " +
                                std::to_string(options.memory_queries));
  }
  if (!(options.place_prior_queries > 0) || !std::isfinite(options.place_prior_queries)) {
    throw std::invalid_argument("fusion_place_prior_queries must be above 0, got " +
                                std::to_string(options.place_prior_queries));
  }
  if (query.set_stats.size() != n) {
    throw std::invalid_argument("AdaptiveFusion: " + std::to_string(query.set_stats.size()) +
                                " set statistics for " + std::to_string(n) + " sets");
  }
  const SetDistances* joint = query.joint;
  if (joint != nullptr && (joint->count != query.num_places || joint->place_ids != nullptr)) {
    throw std::invalid_argument("AdaptiveFusion: the joint distances cover " +
                                std::to_string(joint->count) + " places of " +
                                std::to_string(query.num_places));
  }
}

AdaptiveFusion::Sources AdaptiveFusion::CorrectedSources(const Query& query,
                                                         const AdaptiveFusionOptions& options) {
  // The joint representation, if given, is one more source after the sets (its places'
  // means kept under the id kJoint), with its own statistics.
  const size_t n = query.sets.size();
  Sources s;
  s.raw = query.sets;
  s.stats = query.set_stats;
  std::vector<int> ids;
  for (size_t u = 0; u < n; ++u)
    ids.push_back(query.set_ids ? (*query.set_ids)[u] : static_cast<int>(u));
  if (query.joint != nullptr) {
    s.raw.push_back(*query.joint);
    s.stats.push_back(ComputeDistanceStats(*query.joint));
    ids.push_back(kJoint);
  }
  CorrectByPlaceMeans(s.raw, &ids, query.num_places, options, &s.corrected, &s.stats, &s.updates);
  s.sets.assign(s.corrected.begin(), s.corrected.begin() + static_cast<long>(n));
  s.set_stats.assign(s.stats.begin(), s.stats.begin() + static_cast<long>(n));
  return s;
}

AdaptiveFusion::GroupState AdaptiveFusion::FuseGroup(const Query& query, const Sources& sources,
                                                     int group, const std::vector<int>& members,
                                                     const std::vector<int>& components,
                                                     const AdaptiveFusionOptions& options,
                                                     PlaceBelief* out) {
  // The joint hypothesis belongs to its sets' group, and needs two of them present.
  const bool with_joint =
      query.joint != nullptr && query.joint->group == group && members.size() >= 2;
  std::vector<int> set_ids;
  for (int u : members)
    set_ids.push_back(query.set_ids ? (*query.set_ids)[static_cast<size_t>(u)] : u);
  GroupState next = StartHypotheses(group, set_ids, with_joint);
  const Records records = RecordsOf(next, query.num_places);
  // The mixture weighs the sets by their condition weights w_u / W; the product counts each
  // set once per independent piece of evidence it carries: set u's log-likelihood is divided
  // by its design effect sum_v max(rho_uv, 0).
  const size_t m = members.size();
  double component_weight = 0;
  for (int u : components) component_weight += query.weights[static_cast<size_t>(u)];
  std::vector<double> mixture_weight(m);
  for (size_t j = 0; j < m; ++j) {  // no weight at all (gamma = 0, no set at 0): equal weights
    const size_t u = static_cast<size_t>(members[j]);
    mixture_weight[j] =
        component_weight > 0 ? query.weights[u] / component_weight : 1.0 / static_cast<double>(m);
  }
  const std::vector<double> exponent =
      IndependenceExponents(sources.sets, sources.set_stats, members, query.num_places);
  const std::vector<const Eigen::ArrayXd*> l = HypothesisLikelihoods(
      members, mixture_weight, exponent,
      with_joint ? std::optional<size_t>(query.sets.size()) : std::nullopt, query.num_places);
  ScoreHypotheses(records, l, options, query.filter, query.step_places, query.num_places, &next);
  std::vector<double> a = AverageHypotheses(next, l, query.num_places, out);
  for (size_t j = 0; j < m; ++j) {
    const size_t u = static_cast<size_t>(members[j]);
    const double as_component =
        component_weight > 0 ? a[m] * query.weights[u] / component_weight : a[m] / m;
    out->set_weights[u] = std::min(1.0, a[j] + as_component + a[m + 1] * exponent[j]);
  }
  if (with_joint) out->joint_weight = a[m + 2];
  next.last_weights = std::move(a);
  return next;
}

// This query's hypotheses: the singles of the sets present, the mixture, the product (and
// the joint), each with a buffer for its belief where one is spare.
AdaptiveFusion::GroupState AdaptiveFusion::StartHypotheses(int group,
                                                           const std::vector<int>& set_ids,
                                                           bool with_joint) {
  GroupState next;
  next.group = group;
  const auto add = [&](int id) {
    next.hypotheses.emplace_back();
    next.hypotheses.back().set_id = id;
    if (!spare_.empty()) {
      next.hypotheses.back().posterior.swap(spare_.back());
      spare_.pop_back();
    }
  };
  for (int id : set_ids) add(id);
  add(kMixture);
  add(kProduct);
  if (with_joint) add(kJoint);
  return next;
}

// Each hypothesis's record from the last query on these places. A hypothesis without one
// (new, or its set was missing from the last query) starts at the mean score of those that
// have one, with a uniform belief.
AdaptiveFusion::Records AdaptiveFusion::RecordsOf(const GroupState& next, int num_places) const {
  const GroupState* state = nullptr;
  for (const GroupState& s : groups_) {
    if (num_places == num_places_ && s.group == next.group) state = &s;
  }
  Records r;
  r.of.assign(next.hypotheses.size(), nullptr);
  int recorded = 0;
  if (state != nullptr) {
    for (const Hypothesis& h : state->hypotheses) {
      if (h.stale) continue;
      r.mean_score += h.score;
      ++recorded;
      for (size_t k = 0; k < next.hypotheses.size(); ++k) {
        if (next.hypotheses[k].set_id == h.set_id) r.of[k] = &h;
      }
    }
  }
  if (recorded > 0) r.mean_score /= recorded;
  return r;
}

// The hypotheses' likelihoods L_h, linear, each of mean 1 over the places, in the order of
// the hypotheses: the singles of `members`, the mixture, the product and (`joint`: its index
// among the sources) the joint. The product's is formed from the logs (a product of many
// small factors underflows) and normalised; the mixture and the product are written to
// mixture_ and product_.
std::vector<const Eigen::ArrayXd*> AdaptiveFusion::HypothesisLikelihoods(
    const std::vector<int>& members, const std::vector<double>& mixture_weight,
    const std::vector<double>& exponent, std::optional<size_t> joint, int num_places) {
  const size_t m = members.size();
  std::vector<const Eigen::ArrayXd*> l(m + (joint ? 3 : 2));
  if (joint) l[m + 2] = &lin_l_[*joint];
  for (size_t j = 0; j < m; ++j) l[j] = &lin_l_[static_cast<size_t>(members[j])];
  Eigen::ArrayXd& mixture = mixture_;
  Eigen::ArrayXd& product = product_;
  mixture.setZero(num_places);
  product.setZero(num_places);
  std::vector<double> block_max(static_cast<size_t>(PlaceBlocks(num_places)));
  // The columns and their weights as the kernels take them (the mixture's of weight 0 left
  // out), summed in the order of the sets.
  std::vector<const double*> mixture_columns, product_columns;
  std::vector<double> mixture_weights;
  for (size_t j = 0; j < m; ++j) {
    const size_t u = static_cast<size_t>(members[j]);
    if (mixture_weight[j] > 0) {
      mixture_columns.push_back(lin_l_[u].data());
      mixture_weights.push_back(mixture_weight[j]);
    }
    product_columns.push_back(log_l_[u].data());
  }
  ForPlaceBlocks(num_places, m, [&](int b, Eigen::Index i0, Eigen::Index len) {
    std::vector<const double*> at(m);
    for (size_t j = 0; j < mixture_columns.size(); ++j) at[j] = mixture_columns[j] + i0;
    kernels::AddScaled(mixture.data() + i0, at.data(), mixture_weights.data(),
                       static_cast<int>(mixture_columns.size()), len);
    for (size_t j = 0; j < m; ++j) at[j] = product_columns[j] + i0;
    kernels::AddScaled(product.data() + i0, at.data(), exponent.data(), static_cast<int>(m), len);
    block_max[static_cast<size_t>(b)] = product.segment(i0, len).maxCoeff();
  });
  l[m] = &mixture;
  const double product_max = *std::max_element(block_max.begin(), block_max.end());
  std::vector<double> block_sum(block_max.size());
  ForPlaceBlocks(num_places, 1, [&](int b, Eigen::Index i0, Eigen::Index len) {
    block_sum[static_cast<size_t>(b)] =
        kernels::Exp(product.data() + i0, len, product_max, product.data() + i0);
  });
  double product_sum = 0;
  for (double v : block_sum) product_sum += v;
  const double uniform = 1.0 / static_cast<double>(num_places);
  product *= 1.0 / (product_sum * uniform);
  l[m + 1] = &product;
  return l;
}

// Each hypothesis's belief moved on from its last query by this query's step (as +filter
// moves it), its predictive likelihood of this query, sum_i prior_h(i) L_h(i), its score,
// and its belief after this query (up to a factor); in parallel when there is enough work
// (the same bits either way).
void AdaptiveFusion::ScoreHypotheses(const Records& records,
                                     const std::vector<const Eigen::ArrayXd*>& likelihoods,
                                     const AdaptiveFusionOptions& options,
                                     const TemporalFilterOptions& filter,
                                     std::optional<double> step_places, int num_places,
                                     GroupState* next) {
  const double lambda = 1.0 - 1.0 / options.memory_queries;
  const double uniform = 1.0 / static_cast<double>(num_places);
  bool any_prior = false;
  for (const Hypothesis* from : records.of) {
    any_prior = any_prior || (from != nullptr && from->posterior.size() == num_places);
  }
  const MotionStep step = any_prior ? MotionStepOf(filter, step_places) : MotionStep{};
  const auto one = [&](int k) {
    const size_t h = static_cast<size_t>(k);
    Hypothesis& to = next->hypotheses[h];
    const Hypothesis* from = records.of[h];
    const double* l = likelihoods[h]->data();
    Eigen::VectorXd& posterior = to.posterior;  // prior * L_h, the prior PredictPrior's
    double predictive;
    if (from != nullptr && from->posterior.size() == num_places) {
      posterior.resize(num_places);
      predictive = PredictPriorTimes(step, from->posterior.data(), num_places, l, posterior.data());
    } else {  // a uniform prior: (0 x + 1 / N) L_h, summed as above
      posterior.setZero(num_places);
      predictive = kernels::ScaleShiftMultiply(posterior.data(), num_places, 0.0, uniform, l);
    }
    to.score = lambda * (from != nullptr ? from->score : records.mean_score) + std::log(predictive);
  };
  const int64_t work = static_cast<int64_t>(likelihoods.size()) * num_places;
  RunParallel(static_cast<int>(likelihoods.size()), work >= kParallelWork ? DistanceThreads() : 1,
              one);
}

// a_h = softmax of the scores; adds the group's log sum_h a_h L_h to out->log_posterior and
// returns a.
std::vector<double> AdaptiveFusion::AverageHypotheses(
    const GroupState& next, const std::vector<const Eigen::ArrayXd*>& likelihoods, int num_places,
    PlaceBelief* out) {
  const size_t count = likelihoods.size();
  double top = -INFINITY;
  for (const Hypothesis& h : next.hypotheses) top = std::max(top, h.score);
  std::vector<double> a(count);
  double total = 0;
  for (size_t h = 0; h < count; ++h) total += a[h] = std::exp(next.hypotheses[h].score - top);
  for (double& v : a) v /= total;
  // Where every hypothesis's likelihood underflowed, a floor keeps the log finite (such
  // places are e^-690 below the mean: no belief or confidence depends on them).
  std::vector<double> fused_weights;
  std::vector<const double*> fused_columns;
  for (size_t h = 0; h < count; ++h) {
    if (a[h] > 0) {
      fused_weights.push_back(a[h]);
      fused_columns.push_back(likelihoods[h]->data());
    }
  }
  ForPlaceBlocks(num_places, count, [&](int, Eigen::Index i0, Eigen::Index len) {
    Eigen::ArrayXd fused = Eigen::ArrayXd::Zero(len);
    std::vector<const double*> at(fused_columns.size());
    for (size_t h = 0; h < at.size(); ++h) at[h] = fused_columns[h] + i0;
    kernels::AddScaled(fused.data(), at.data(), fused_weights.data(), static_cast<int>(at.size()),
                       len);
    fused = fused.max(kLikelihoodFloor);
    kernels::Log(fused.data(), len, fused.data());
    out->log_posterior.array().segment(i0, len) += fused;
  });
  return a;
}

}  // namespace bsf_vpr
