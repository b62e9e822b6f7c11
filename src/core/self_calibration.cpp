#include "bsf_vpr/core/self_calibration.h"

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {
namespace {

// One traversal held out as queries: its rows, their places, and their distances to the
// sets it is queried against (and to their joint representation, when the method needs one).
struct HeldOut {
  std::vector<int> true_place;         // per row
  std::vector<int> sets;               // indices into the map
  std::vector<RowMatrixXf> distances;  // per entry of sets: Q x N_u
  std::optional<JointKind> joint_kind;
  RowMatrixXf joint;  // Q x the map's places (empty: none)
};

HeldOut HoldOut(const ReferenceSets& map, int t, DistanceMetric metric, const Method& method,
                const MethodOptions& options) {
  const StoredReferenceSet& query_set = map.set(t);
  HeldOut h;
  h.true_place = query_set.place_ids();
  RowMatrixXf queries(query_set.size(), query_set.dimension());
  for (int r = 0; r < query_set.size(); ++r) query_set.DecodeRow(r, queries.row(r).data());
  for (int u = 0; u < map.num_sets(); ++u) {
    if (u != t || map.num_sets() == 1) h.sets.push_back(u);
  }
  std::vector<const StoredReferenceSet*> sets;
  for (int u : h.sets) {
    sets.push_back(&map.set(u));
    h.distances.push_back(ComputeDistances(metric, queries, map.set(u)));
  }
  h.joint_kind = method.JointNeeded(options);
  if (h.joint_kind && sets.size() >= 2) {
    try {
      h.joint = JointRepresentation::Build(*h.joint_kind, sets, map.num_places(), options.joint)
                    .Distances(queries);
    } catch (const std::invalid_argument&) {
      h.joint.resize(0, 0);  // the sets share no places: the method fuses them alone
    }
  }
  return h;
}

// The map a stream runs against: the sets `h` is queried against without the places
// `removed` marks, the others renumbered in order (so that the route closes over the gap),
// and rows [begin, end) of the held-out traversal's distances to it.
struct CutMap {
  std::vector<int> renumbered;  // per place of the map: its number here, -1 if not here
  std::vector<int> original;    // per place here: its number in the map
  std::vector<RowMatrixXf> distances;
  std::vector<std::vector<int>> place_ids;
  std::vector<std::string> names;
  RowMatrixXf joint;  // rows x places here (empty: none)
  int places() const { return static_cast<int>(original.size()); }
};

CutMap Cut(const ReferenceSets& map, const HeldOut& h, const std::vector<char>& removed, int begin,
           int end) {
  const int n = map.num_places();
  CutMap cut;
  cut.renumbered.assign(static_cast<size_t>(n), -1);
  std::vector<char> covered(static_cast<size_t>(n), 0);
  for (int u : h.sets) {
    for (int p : map.set(u).place_ids()) covered[static_cast<size_t>(p)] = 1;
  }
  for (int p = 0; p < n; ++p) {
    if (!covered[static_cast<size_t>(p)] || removed[static_cast<size_t>(p)]) continue;
    cut.renumbered[static_cast<size_t>(p)] = cut.places();
    cut.original.push_back(p);
  }
  const int rows = end - begin;
  for (size_t k = 0; k < h.sets.size() && cut.places() > 0; ++k) {
    const std::vector<int>& place_ids = map.set(h.sets[k]).place_ids();
    std::vector<int> cols, kept_ids;
    for (int c = 0; c < static_cast<int>(place_ids.size()); ++c) {
      const int to = cut.renumbered[static_cast<size_t>(place_ids[static_cast<size_t>(c)])];
      if (to < 0) continue;
      cols.push_back(c);
      kept_ids.push_back(to);
    }
    if (cols.empty()) continue;
    RowMatrixXf d(rows, static_cast<int>(cols.size()));
    for (int q = 0; q < rows; ++q) {
      for (size_t c = 0; c < cols.size(); ++c) {
        d(q, static_cast<int>(c)) = h.distances[k](begin + q, cols[c]);
      }
    }
    cut.distances.push_back(std::move(d));
    cut.place_ids.push_back(std::move(kept_ids));
    cut.names.push_back(map.set(h.sets[k]).name());
  }
  if (h.joint.size() > 0 && !cut.distances.empty()) {
    cut.joint.resize(rows, cut.places());
    for (int q = 0; q < rows; ++q) {
      for (int i = 0; i < cut.places(); ++i) cut.joint(q, i) = h.joint(begin + q, cut.original[i]);
    }
  }
  return cut;
}

// Rows [begin, end) of `h` run in order through `method_name` against the map without the
// places `removed` marks (Cut); the rows from sample_begin on are sampled, on the map if
// their place is still in it, else off it.
void RunStream(const ReferenceSets& map, const HeldOut& h, const std::string& method_name,
               const MethodOptions& options, const std::vector<char>& removed, int begin,
               int sample_begin, int end, int traversal, MapCalibration* out) {
  const CutMap cut = Cut(map, h, removed, begin, end);
  if (cut.distances.empty()) return;
  const int rows = end - begin, kept_places = cut.places();
  const std::vector<RowMatrixXf>& dist = cut.distances;
  const std::vector<std::vector<int>>& ids = cut.place_ids;
  const std::vector<int>&renumbered = cut.renumbered, &original = cut.original;
  const RowMatrixXf& joint = cut.joint;
  const std::vector<std::string>& names = cut.names;
  const Method method = ParseMethod(method_name, names);  // throws: a set it names is held out
  MethodRunner runner(method, options);
  const double h_log_odds = options.decision.threshold.LogOdds();
  std::vector<SetDistances> views(dist.size());
  std::vector<JointDistances> joint_view(joint.size() > 0 ? 1 : 0);
  for (int q = 0; q < rows; ++q) {
    for (size_t k = 0; k < dist.size(); ++k) {
      views[k].values = dist[k].row(q).data();
      views[k].place_ids = ids[k].data();
      views[k].count = static_cast<int>(ids[k].size());
    }
    if (!joint_view.empty()) {
      joint_view[0].kind = *h.joint_kind;
      joint_view[0].distances.values = joint.row(q).data();
      joint_view[0].distances.count = kept_places;
    }
    const PlaceBelief b = runner.Step(views, kept_places, nullptr, std::nullopt, true, nullptr,
                                      joint_view.empty() ? nullptr : &joint_view);
    if (begin + q < sample_begin) continue;
    CalibrationSample s;
    s.traversal = traversal;
    s.confidence = b.confidence;
    s.match_distance = b.match_distance;
    s.passes_threshold =
        method.IsBayesian() || method.sequence ? b.confidence > h_log_odds : b.accepted;
    const int place = h.true_place[static_cast<size_t>(begin + q)];
    if (renumbered[static_cast<size_t>(place)] >= 0) {
      const int match = b.match >= 0 ? original[static_cast<size_t>(b.match)] : -1;
      s.right = match >= 0 && std::abs(match - place) <= kCalibrationTolerancePlaces;
      out->on_map.push_back(s);
    } else {
      out->off_map.push_back(s);
    }
  }
}

// Logistic regression of `right` on (confidence, distance), the classes weighed equally and
// the weights (not the bias) held near 0 by a small ridge, in standardised features; returns
// the rule's weights and bias in the features' own units (cut left to the caller). nullopt
// when the fit does not make a larger distance count against the match.
std::optional<AcceptanceRule> FitScore(const std::vector<const CalibrationSample*>& samples,
                                       double confidence_limit) {
  const int n = static_cast<int>(samples.size());
  Eigen::MatrixXd x(n, 3);
  Eigen::VectorXd y(n), w(n);
  int positives = 0;
  for (int i = 0; i < n; ++i) {
    const CalibrationSample& s = *samples[static_cast<size_t>(i)];
    x(i, 0) = std::clamp(s.confidence, -confidence_limit, confidence_limit);
    x(i, 1) = s.match_distance;
    x(i, 2) = 1;
    y(i) = s.right ? 1 : 0;
    positives += s.right ? 1 : 0;
  }
  if (positives == 0 || positives == n) return std::nullopt;
  for (int i = 0; i < n; ++i) {
    w(i) = y(i) > 0 ? 0.5 / positives : 0.5 / (n - positives);
  }
  Eigen::Vector2d mean, scale;
  for (int j = 0; j < 2; ++j) {
    mean(j) = x.col(j).mean();
    scale(j) = std::sqrt((x.col(j).array() - mean(j)).square().mean());
    if (!(scale(j) > 0)) scale(j) = 1;
    x.col(j) = (x.col(j).array() - mean(j)) / scale(j);
  }
  constexpr double kRidge = 1e-3;
  Eigen::Vector3d beta = Eigen::Vector3d::Zero();
  for (int iteration = 0; iteration < 100; ++iteration) {
    const Eigen::VectorXd p = ((-(x * beta).array()).exp() + 1).inverse().matrix();
    const Eigen::VectorXd r = p.array() * (1 - p.array()) * w.array();
    Eigen::Matrix3d hessian = x.transpose() * r.asDiagonal() * x;
    Eigen::Vector3d gradient = x.transpose() * (w.array() * (y - p).array()).matrix();
    hessian(0, 0) += kRidge;
    hessian(1, 1) += kRidge;
    gradient.head<2>() -= kRidge * beta.head<2>();
    const Eigen::Vector3d delta = hessian.ldlt().solve(gradient);
    if (!delta.allFinite()) return std::nullopt;
    beta += delta;
    if (delta.norm() < 1e-10) break;
  }
  AcceptanceRule rule;
  rule.confidence_limit = confidence_limit;
  rule.w_confidence = beta(0) / scale(0);
  rule.w_distance = beta(1) / scale(1);
  rule.bias = beta(2) - rule.w_confidence * mean(0) - rule.w_distance * mean(1);
  if (!(rule.w_distance < 0) || !(rule.w_confidence >= 0) || !std::isfinite(rule.bias)) {
    return std::nullopt;
  }
  return rule;
}

// The score fitted on the samples of every traversal but `exclude` (-1: all), where there are
// enough of them to fit; nullopt where there are not or the fit is not usable.
std::optional<AcceptanceRule> FitExcluding(const MapCalibration& c, int exclude,
                                           double confidence_limit) {
  std::vector<const CalibrationSample*> fit;
  int right = 0, wrong = 0;
  for (const std::vector<CalibrationSample>* samples : {&c.on_map, &c.off_map}) {
    for (const CalibrationSample& s : *samples) {
      if (s.traversal == exclude || !std::isfinite(s.match_distance) || std::isnan(s.confidence)) {
        continue;
      }
      fit.push_back(&s);
      (s.right ? right : wrong) += 1;
    }
  }
  if (right < kCalibrationMinSamples || wrong < kCalibrationMinSamples) return std::nullopt;
  return FitScore(fit, confidence_limit);
}

void FitRule(MapCalibration* c, double confidence_limit) {
  // Cross-fitted: the off-map rows of traversal t are scored by a fit made without t, so
  // that the rows which set the cut played no part in the score (a score fitted on them
  // would rank them too low, and the rate predicted too low with it). The rule in force is
  // the fit on every traversal, with that cut.
  std::vector<int> traversals;
  for (const CalibrationSample& s : c->off_map) {
    if (std::find(traversals.begin(), traversals.end(), s.traversal) == traversals.end()) {
      traversals.push_back(s.traversal);
    }
  }
  AcceptanceRule alone;  // the confidence alone
  alone.confidence_limit = confidence_limit;
  std::optional<AcceptanceRule> all = FitExcluding(*c, -1, confidence_limit);
  std::vector<std::optional<AcceptanceRule>> folds;
  for (int t : traversals) {
    folds.push_back(all ? FitExcluding(*c, t, confidence_limit) : std::nullopt);
    if (!folds.back()) all.reset();  // a fold without its fit: the confidence alone for all
  }
  c->rule = all ? *all : alone;
  c->uses_distance = all.has_value();
  std::vector<double> scores;
  for (const CalibrationSample& x : c->off_map) {
    const size_t fold =
        std::find(traversals.begin(), traversals.end(), x.traversal) - traversals.begin();
    const AcceptanceRule& by = all ? *folds[fold] : alone;
    scores.push_back(x.passes_threshold ? by.Score(x.confidence, x.match_distance)
                                        : -std::numeric_limits<double>::infinity());
  }
  std::sort(scores.begin(), scores.end());
  const int n = static_cast<int>(scores.size());
  const double k = std::ceil((1 - c->target_rate) * (n + 1));
  c->rule.cut = k > n ? std::numeric_limits<double>::infinity()
                      : scores[static_cast<size_t>(std::max(k, 1.0)) - 1];
  c->off_map_accepted = 0;
  for (double s : scores) c->off_map_accepted += s > c->rule.cut ? 1 : 0;
  c->predicted_false_accept_rate = std::isinf(c->rule.cut) && c->rule.cut > 0
                                       ? 0.0
                                       : std::min(1.0, (c->off_map_accepted + 1.0) / (n + 1.0));
  int accepted_right = 0;
  for (const CalibrationSample& s : c->on_map) {
    accepted_right += s.right && s.passes_threshold &&
                      c->rule.Score(s.confidence, s.match_distance) > c->rule.cut;
  }
  c->recall = c->on_map.empty() ? std::numeric_limits<double>::quiet_NaN()
                                : static_cast<double>(accepted_right) / c->on_map.size();
}

}  // namespace

std::string MapCalibration::Summary() const {
  char line[512];
  const int n = static_cast<int>(off_map.size());
  std::string s = "on this map (" + method + "): ";
  if (n == 0) return s + "not calibrated: " + note;
  if (std::isinf(rule.cut) && rule.cut > 0) {
    std::snprintf(line, sizeof line,
                  "nothing is accepted: %d held-out off-map rows cannot vouch for a rate of "
                  "%.3g%% (%d needed)",
                  n, 100 * target_rate, static_cast<int>(std::ceil(1 / target_rate)) - 1);
    s += line;
  } else {
    std::snprintf(line, sizeof line, "false acceptances %.2g%% (%d of %d held-out off-map rows)",
                  100 * predicted_false_accept_rate, off_map_accepted, n);
    s += line;
  }
  if (traversals_held_out == 0) {
    s += "; not applied: with one traversal its look-alikes are its own rows, of its own "
         "condition, and recall is not measured";
  } else if (on_map.empty()) {
    s += "; not applied: no other traversal shows the held-out traversals' places, so "
         "recall is not measured";
  } else {
    std::snprintf(line, sizeof line, " at recall %.0f%% on %d held-out traversal rows",
                  100 * recall, static_cast<int>(on_map.size()));
    s += line;
  }
  s += uses_distance ? "; the match's distance weighed" : "; the confidence alone";
  if (!note.empty()) s += "; " + note;
  return s;
}

void CalibrationOptions::Validate() const { CalibrationOptionsTable().CheckValues(*this); }

const OptionTable<CalibrationOptions>& CalibrationOptionsTable() {
  static const OptionTable<CalibrationOptions> kTable = OptionTable<CalibrationOptions>().Add(
      "max_false_accept_rate", [](auto& o) -> auto& { return o.max_false_accept_rate; },
      "the map's own acceptance rule, learnt by holding its traversals and places out "
      "(docs/method.md, 'What the map knows of itself'): at most this fraction of the queries "
      "that show no place of the map are accepted; a match must pass it besides the "
      "threshold; 0: the threshold alone. Not applied where the map holds one traversal "
      "(reported only) or is sharded",
      "", {0, 1, false, true}, /*live=*/true);
  return kTable;
}

MapCalibration CalibrateMap(const ReferenceSets& map, DistanceMetric metric,
                            const std::string& method_name, const MethodOptions& options,
                            double max_false_accept_rate, const std::atomic<bool>* cancel) {
  const auto start = std::chrono::steady_clock::now();
  const double alpha = max_false_accept_rate;
  if (!(alpha > 0 && alpha < 1)) {
    throw std::invalid_argument("max_false_accept_rate must lie in (0, 1) to calibrate, got " +
                                std::to_string(alpha));
  }
  if (map.num_sets() == 0) throw std::invalid_argument("cannot calibrate an empty map");
  const Method method = ParseMethod(method_name, map.SetNames());
  MapCalibration c;
  c.method = method.Name();
  c.target_rate = alpha;
  const auto cancelled = [cancel] {
    if (cancel && cancel->load()) throw CalibrationCancelled();
  };
  const auto note = [&c](const std::string& what) {
    c.note += (c.note.empty() ? "" : "; ") + what;
  };
  const int n = map.num_places();
  int64_t rows = 0;  // of every set, for the distances' budget
  for (const StoredReferenceSet& s : map.sets()) rows += s.size();
  for (int t = 0; t < map.num_sets(); ++t) {
    cancelled();
    const std::string name = "'" + map.set(t).name() + "'";
    const int64_t others = map.num_sets() > 1 ? rows - map.set(t).size() : rows;
    if (int64_t{map.set(t).size()} * others > kCalibrationMaxDistances) {
      note(name + " not held out: its " + std::to_string(map.set(t).size()) + " rows against " +
           std::to_string(others) + " exceed the calibration's distances (" +
           std::to_string(kCalibrationMaxDistances) + ")");
      continue;
    }
    std::optional<HeldOut> h;
    try {
      h = HoldOut(map, t, metric, method, options);
    } catch (const std::invalid_argument& e) {
      note(name + " not held out: " + e.what());
      continue;
    }
    const int q = static_cast<int>(h->true_place.size());
    std::vector<char> removed(static_cast<size_t>(n), 0);
    // Each stream on its own: one the method cannot run (nn:<set> of a set it holds out, a
    // stretch that takes every row of the set the method names) is left out and named.
    const auto stream = [&](const std::string& what, int begin, int sample_begin, int end) {
      cancelled();
      try {
        RunStream(map, *h, method_name, options, removed, begin, sample_begin, end, t, &c);
        return true;
      } catch (const std::invalid_argument& e) {
        note(name + " " + what + " not held out: " + e.what());
        return false;
      }
    };
    if (map.num_sets() > 1 && stream("against the others", 0, 0, q)) ++c.traversals_held_out;
    for (int b = 0; b < kCalibrationBlocks; ++b) {
      const int first = b * q / kCalibrationBlocks, last = (b + 1) * q / kCalibrationBlocks;
      if (first >= last) continue;
      std::fill(removed.begin(), removed.end(), 0);
      for (int r = first; r < last; ++r) {
        const int p = h->true_place[static_cast<size_t>(r)];
        for (int i = std::max(0, p - kCalibrationTolerancePlaces);
             i <= std::min(n - 1, p + kCalibrationTolerancePlaces); ++i) {
          removed[static_cast<size_t>(i)] = 1;
        }
      }
      stream("stretch " + std::to_string(b + 1), std::max(0, first - kCalibrationLeadIn), first,
             last);
    }
  }
  // A distance method's confidence is minus its distance: scored as it is, not clamped.
  FitRule(&c, method.IsBayesian() || method.sequence ? kMaxScoredConfidence
                                                     : std::numeric_limits<double>::infinity());
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return c;
}

}  // namespace bsf_vpr
