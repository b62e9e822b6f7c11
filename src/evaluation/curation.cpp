#include "bsf_vpr/evaluation/curation.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

namespace bsf_vpr {

void CurationOptions::Validate() const {
  if (!(rarely_selected_fraction >= 0 && rarely_selected_fraction <= 1)) {
    throw std::invalid_argument("rarely_selected_fraction must lie in [0, 1]");
  }
  if (!(dominated_fraction > 0 && dominated_fraction <= 1)) {
    throw std::invalid_argument("dominated_fraction must lie in (0, 1]");
  }
  if (!(gap_factor >= 1)) throw std::invalid_argument("gap_factor must be >= 1");
  if (min_gap_queries < 1) throw std::invalid_argument("min_gap_queries must be >= 1");
}

namespace {

void FindGaps(const std::vector<double>& best, const CurationOptions& o, CurationReport* r) {
  std::vector<double> sorted = best;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2),
                   sorted.end());
  r->median_best_distance = sorted[sorted.size() / 2];
  const double limit = o.gap_factor * r->median_best_distance;
  for (size_t q = 0; q < best.size();) {
    if (!(best[q] > limit)) {
      ++q;
      continue;
    }
    CoverageGap g;
    g.first_query = static_cast<int>(q);
    while (q < best.size() && best[q] > limit) {
      if (r->median_best_distance > 0)
        g.worst_ratio = std::max(g.worst_ratio, best[q] / r->median_best_distance);
      ++q;
    }
    g.last_query = static_cast<int>(q) - 1;
    if (g.last_query - g.first_query + 1 >= o.min_gap_queries) r->gaps.push_back(g);
  }
}

}  // namespace

CurationReport Curate(const std::vector<QueryRecord>& records, const CurationOptions& options) {
  options.Validate();
  if (records.empty()) throw std::invalid_argument("curation needs at least one query record");
  const std::vector<std::string>& names = records.front().set_names;
  const size_t m = names.size();
  std::vector<long> selected(m, 0), best(m, 0);
  std::vector<double> weight(m, 0.0);
  bool weighted = true;
  // together[a][b]: queries where a was selected together with b, and b was closer.
  std::vector<std::vector<long>> covered(m, std::vector<long>(m, 0));
  std::vector<double> best_distance;
  for (const QueryRecord& r : records) {
    if (r.set_names != names || r.set_min_distances.size() != m) {
      throw std::invalid_argument(
          "query records disagree on the loaded sets (were sets loaded "
          "or unloaded during the traversal?)");
    }
    std::vector<bool> sel(m, false);
    for (const std::string& s : r.selected) {
      const auto it = std::find(names.begin(), names.end(), s);
      if (it != names.end()) sel[static_cast<size_t>(it - names.begin())] = true;
    }
    const size_t u_best = static_cast<size_t>(
        std::min_element(r.set_min_distances.begin(), r.set_min_distances.end()) -
        r.set_min_distances.begin());
    ++best[u_best];
    weighted = weighted && r.set_weights.size() == m;
    for (size_t a = 0; weighted && a < m; ++a) weight[a] += r.set_weights[a];
    best_distance.push_back(r.set_min_distances[u_best]);
    for (size_t a = 0; a < m; ++a) {
      if (!sel[a]) continue;
      ++selected[a];
      for (size_t b = 0; b < m; ++b) {
        if (b != a && sel[b] && r.set_min_distances[b] < r.set_min_distances[a]) ++covered[a][b];
      }
    }
  }
  CurationReport report;
  report.queries = static_cast<int>(records.size());
  const double n = static_cast<double>(records.size());
  for (size_t a = 0; a < m; ++a) {
    SetCuration c;
    c.name = names[a];
    c.selected_fraction = selected[a] / n;
    c.best_fraction = best[a] / n;
    if (weighted) c.mean_weight = weight[a] / n;
    if (c.selected_fraction < options.rarely_selected_fraction) {
      c.redundant = true;
      c.reason = "rarely selected";
    } else {
      for (size_t b = 0; b < m; ++b) {
        if (b != a && covered[a][b] >= options.dominated_fraction * selected[a]) {
          c.redundant = true;
          c.dominated_by = names[b];
          c.reason = "always selected with the closer '" + names[b] + "'";
          break;
        }
      }
    }
    if (!c.redundant) c.reason = "keep";
    report.sets.push_back(c);
  }
  FindGaps(best_distance, options, &report);
  return report;
}

std::string FormatCurationReport(const CurationReport& r) {
  std::ostringstream out;
  size_t w = 4;
  for (const SetCuration& s : r.sets) w = std::max(w, s.name.size());
  char line[512];
  const bool weighted = !r.sets.empty() && r.sets.front().mean_weight >= 0;
  std::snprintf(line, sizeof(line), "%-*s  selected   best%s  recommendation\n",
                static_cast<int>(w), "set", weighted ? "  weight" : "");
  out << line;
  for (const SetCuration& s : r.sets) {
    char weight[16] = "";
    if (weighted) std::snprintf(weight, sizeof(weight), "  %6.3f", s.mean_weight);
    std::snprintf(line, sizeof(line), "%-*s  %7.1f%%  %5.1f%%%s  %s%s\n", static_cast<int>(w),
                  s.name.c_str(), 100 * s.selected_fraction, 100 * s.best_fraction, weight,
                  s.redundant ? "redundant: " : "", s.reason.c_str());
    out << line;
  }
  out << r.queries << " queries; median of the closest set's minimum distance "
      << r.median_best_distance << '\n';
  if (r.gaps.empty()) {
    out << "coverage: no stretch of queries without a close reference set\n";
  } else {
    out << "coverage gaps (no set close; record a reference of these conditions):\n";
    for (const CoverageGap& g : r.gaps) {
      std::snprintf(line, sizeof(line), "  queries %d-%d (%d queries, up to %.2fx the median)\n",
                    g.first_query, g.last_query, g.last_query - g.first_query + 1, g.worst_ratio);
      out << line;
    }
  }
  return out.str();
}

}  // namespace bsf_vpr
