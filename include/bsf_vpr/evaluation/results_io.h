// Output files of an evaluation:
//   DIR/summary.csv            method,auc,r_at_100p,r_at_1,r_at_5,r_at_10,n_queries
//   DIR/matches/<method>.csv   query,match,confidence,accepted,off_map_probability
//                              (':' in a method name becomes '_')
//   DIR/pr/<method>.csv        threshold,precision,recall (the curve behind the AUC; plot_pr)
// All files are written atomically; folders are created as needed.
#pragma once

#include <string>
#include <vector>

#include "bsf_vpr/evaluation/evaluation_runner.h"

namespace bsf_vpr {

// "nn:winter" -> "nn_winter".
std::string MethodFileStem(const std::string& method_name);

void WriteEvaluationOutputs(const std::string& dir, const std::vector<MethodResults>& results);

// A fixed-width table of the metrics, one row per method, for a terminal.
std::string FormatSummaryTable(const std::vector<MethodResults>& results);

}  // namespace bsf_vpr
