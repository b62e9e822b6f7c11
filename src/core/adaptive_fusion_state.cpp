// AdaptiveFusion's state from one query to the next (adaptive_fusion.h): the places' means
// (each place's distances corrected by its mean distance to the queries counted so far, and
// the counting), committing a query's hypotheses, and forgetting them.
#include <cmath>
#include <utility>

#include "bsf_vpr/core/adaptive_fusion.h"
#include "src/core/internal/fusion_parts.h"
#include "src/core/internal/vector_math.h"

namespace bsf_vpr {
namespace {

// Pearson's correlation of two profiles of n distances over at most kProfileSample places
// spread evenly over them (enough to tell the same scene from another); 1 where both have no
// spread (no sign that the scene changed), 0 where one has.
constexpr int kProfileSample = 512;
double ProfileCorrelation(const float* x, const float* y, int n) {
  const int stride = (n + kProfileSample - 1) / kProfileSample;
  // Sums about the first values (distances of one scale: no cancellation in double).
  const double x0 = x[0], y0 = y[0];
  double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0, count = 0;
  for (int i = 0; i < n; i += stride) {
    const double dx = x[i] - x0, dy = y[i] - y0;
    sx += dx;
    sy += dy;
    sxx += dx * dx;
    syy += dy * dy;
    sxy += dx * dy;
    count += 1;
  }
  const double vx = sxx - sx * sx / count, vy = syy - sy * sy / count;
  if (vx > 0 && vy > 0) return (sxy - sx * sy / count) / std::sqrt(vx * vy);
  return vx > 0 || vy > 0 ? 0.0 : 1.0;  // one flat and the other not: another scene
}

// out = d - c over n values, and the mean and deviation of out (in eight lanes, added in a
// fixed tree, as ComputeDistanceStats; min and argmin are not needed by the fusion and are
// left as `raw`'s).
DistanceStats CorrectedStats(const float* d, const float* c, int n, float* out,
                             const DistanceStats& raw) {
  DistanceStats s = raw;
  s.mean = kernels::LaneDifferenceSum(d, c, n, out) / n;
  s.stddev = std::sqrt(kernels::LaneSquaredDeviations(out, n, s.mean) / n);
  return s;
}

}  // namespace

void AdaptiveFusion::CorrectByPlaceMeans(const std::vector<SetDistances>& sets,
                                         const std::vector<int>* set_ids, int num_places,
                                         const AdaptiveFusionOptions& options,
                                         std::vector<SetDistances>* corrected,
                                         std::vector<DistanceStats>* corrected_stats,
                                         std::vector<PlaceUpdate>* updates) {
  corrected->assign(sets.begin(), sets.end());
  updates->clear();
  if (!options.place_means) return;
  const bool known_places = num_places == num_places_;  // else the means are another map's
  corrected_values_.resize(sets.size());
  for (size_t u = 0; u < sets.size(); ++u) {
    const SetDistances& d = sets[u];
    if (d.count != num_places || !internal::CoversEachPlaceInOrder(d, num_places)) continue;
    const int id = set_ids ? (*set_ids)[u] : static_cast<int>(u);
    int record = -1;
    for (size_t k = 0; known_places && k < place_means_.size(); ++k) {
      if (place_means_[k].set_id == id) record = static_cast<int>(k);
    }
    const PlaceMeans* m = record >= 0 ? &place_means_[static_cast<size_t>(record)] : nullptr;
    if (m == nullptr || m->recent.empty() ||
        ProfileCorrelation(d.values, m->recent.back().data(), num_places) < kSameScene) {
      updates->push_back({u, record, id});
    }
    if (m == nullptr || m->queries == 0) continue;
    // n0 changed since the correction was made: this query's own (kept at the commit).
    Eigen::ArrayXf changed;
    if (m->prior_queries != options.place_prior_queries) {
      changed = Correction(*m, options.place_prior_queries);
    }
    const float* correction = changed.size() > 0 ? changed.data() : m->correction.data();
    std::vector<float>& v = corrected_values_[u];
    v.resize(static_cast<size_t>(num_places));
    (*corrected_stats)[u] =
        CorrectedStats(d.values, correction, num_places, v.data(), (*corrected_stats)[u]);
    (*corrected)[u].values = v.data();
  }
}

Eigen::ArrayXf AdaptiveFusion::Correction(const PlaceMeans& m, double prior_queries) {
  const double shrink = m.queries / (m.queries + prior_queries);
  const double centre = m.mean.mean();
  return (shrink * (m.mean - centre)).cast<float>();
}

void AdaptiveFusion::CountPlaceMeans(const std::vector<SetDistances>& sets,
                                     const std::vector<PlaceUpdate>& updates,
                                     double prior_queries) {
  for (PlaceMeans& m : place_means_) {  // n0 changed (a live option): the corrections follow
    if (m.queries > 0 && m.prior_queries != prior_queries) {
      m.prior_queries = prior_queries;
      m.correction = Correction(m, prior_queries);
    }
  }
  for (const PlaceUpdate& up : updates) {
    const SetDistances& d = sets[up.set];
    if (up.record < 0) {
      place_means_.emplace_back();
      place_means_.back().set_id = up.set_id;
      place_means_.back().mean = Eigen::ArrayXd::Zero(d.count);
      place_means_.back().prior_queries = prior_queries;
    }
    PlaceMeans& m = up.record < 0 ? place_means_.back()
                                  : place_means_[static_cast<size_t>(up.record)];
    Eigen::ArrayXf oldest;  // the buffer of the query that enters the mean, written over
    if (static_cast<int>(m.recent.size()) >= kPlaceMeansLag) {
      m.queries += 1;
      const double step = 1.0 / m.queries;
      double* mean = m.mean.data();
      const float* f = m.recent.front().data();
      for (Eigen::Index i = 0; i < m.mean.size(); ++i) mean[i] += (f[i] - mean[i]) * step;
      m.prior_queries = prior_queries;
      m.correction = Correction(m, prior_queries);
      oldest.swap(m.recent.front());
      m.recent.pop_front();
    }
    oldest = Eigen::Map<const Eigen::ArrayXf>(d.values, d.count);
    m.recent.push_back(std::move(oldest));
  }
}

void AdaptiveFusion::Reset() {
  num_places_ = -1;
  groups_.clear();
  place_means_.clear();
  corrected_values_.clear();
  log_l_.clear();
  lin_l_.clear();
  mixture_.resize(0);
  product_.resize(0);
  spare_.clear();
}

void AdaptiveFusion::Recycle(std::vector<Hypothesis>* hypotheses) {
  constexpr size_t kMaxSpare = 64;
  for (Hypothesis& h : *hypotheses) {
    if (h.posterior.size() > 0 && spare_.size() < kMaxSpare)
      spare_.push_back(std::move(h.posterior));
  }
  hypotheses->clear();
}

// Keeps what a decided query leaves: its places' means and its groups' hypotheses (those of
// sets missing from it stay, marked stale: back, they start again).
void AdaptiveFusion::Commit(int num_places, const Sources& sources, double prior_queries,
                            std::vector<GroupState>* pending) {
  if (num_places != num_places_) {
    groups_.clear();
    place_means_.clear();
    num_places_ = num_places;
  }
  CountPlaceMeans(sources.raw, sources.updates, prior_queries);
  for (GroupState& next : *pending) {
    GroupState* state = nullptr;
    for (GroupState& s : groups_) {
      if (s.group == next.group) state = &s;
    }
    if (state == nullptr) {
      groups_.push_back(std::move(next));
      continue;
    }
    for (Hypothesis& h : state->hypotheses) {
      const bool present = std::any_of(next.hypotheses.begin(), next.hypotheses.end(),
                                       [&h](const Hypothesis& n) { return n.set_id == h.set_id; });
      if (!present) {
        h.stale = true;
        next.hypotheses.push_back(std::move(h));
      }
    }
    Recycle(&state->hypotheses);
    *state = std::move(next);
  }
}

}  // namespace bsf_vpr
