#include "bsf_vpr/evaluation/results_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "bsf_vpr/io/file_util.h"

namespace bsf_vpr {
namespace {

std::string FormatNumber(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.9g", v);
  return buf;
}

std::string Fixed(double v, int decimals) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

}  // namespace

std::string MethodFileStem(const std::string& method_name) {
  std::string stem = method_name;
  for (char& c : stem) {
    if (c == ':' || c == '/') c = '_';
  }
  return stem;
}

void WriteEvaluationOutputs(const std::string& dir, const std::vector<MethodResults>& results) {
  MakeDirectories(dir + "/matches");
  MakeDirectories(dir + "/pr");
  std::ostringstream summary;
  summary << "method,auc,r_at_100p,r_at_1,r_at_5,r_at_10,n_queries,off_map_queries,"
             "off_map_accepted\n";
  for (const MethodResults& r : results) {
    const Metrics& m = r.metrics;
    summary << r.method.Name() << ',' << FormatNumber(m.auc) << ','
            << FormatNumber(m.recall_at_full_precision) << ',' << FormatNumber(m.recall_at_1) << ','
            << FormatNumber(m.recall_at_5) << ',' << FormatNumber(m.recall_at_10) << ','
            << m.num_queries << ',' << m.off_map_queries << ',' << m.off_map_accepted << '\n';
    std::ostringstream matches;
    matches << "query,match,confidence,accepted,off_map_probability,match_distance\n";
    for (size_t q = 0; q < r.outcomes.size(); ++q) {
      const QueryOutcome& o = r.outcomes[q];
      matches << q << ',' << o.match << ',' << FormatNumber(o.confidence) << ','
              << (o.accepted ? 1 : 0) << ',' << FormatNumber(o.off_map_probability) << ','
              << FormatNumber(o.match_distance) << '\n';
    }
    WriteFileAtomically(dir + "/matches/" + MethodFileStem(r.method.Name()) + ".csv",
                        matches.str());
    std::ostringstream pr;
    pr << "threshold,precision,recall\n";
    for (const PrPoint& p : m.curve) {
      pr << FormatNumber(p.threshold) << ',' << FormatNumber(p.precision) << ','
         << FormatNumber(p.recall) << '\n';
    }
    WriteFileAtomically(dir + "/pr/" + MethodFileStem(r.method.Name()) + ".csv", pr.str());
  }
  WriteFileAtomically(dir + "/summary.csv", summary.str());
}

std::string FormatSummaryTable(const std::vector<MethodResults>& results) {
  size_t width = 6;
  for (const MethodResults& r : results) width = std::max(width, r.method.Name().size());
  std::ostringstream out;
  auto pad = [](const std::string& s, size_t w) {
    return s + std::string(w - std::min(w, s.size()), ' ');
  };
  // Where some queries show no place of the map: how many of them had a match accepted.
  const bool off_map = !results.empty() && results.front().metrics.off_map_queries > 0;
  out << pad("method", width) << "    AUC  R@100P    R@1    R@5   R@10  queries"
      << (off_map ? "  off-map accepted" : "") << '\n';
  for (const MethodResults& r : results) {
    const Metrics& m = r.metrics;
    out << pad(r.method.Name(), width) << "  " << Fixed(m.auc, 3) << "   "
        << Fixed(m.recall_at_full_precision, 3) << "  " << Fixed(m.recall_at_1, 3) << "  "
        << Fixed(m.recall_at_5, 3) << "  " << Fixed(m.recall_at_10, 3) << "  " << m.num_queries;
    if (off_map) {  // under its heading, which starts 7 places after "queries"
      const size_t queries_width = std::to_string(m.num_queries).size();
      out << std::string(2 + 7 - std::min<size_t>(7, queries_width), ' ') << m.off_map_accepted
          << " of " << m.off_map_queries;
    }
    out << '\n';
  }
  return out.str();
}

}  // namespace bsf_vpr
