// Ground-truth CSV: one row per query that has correct places, listing them separated by
// spaces. A header line starting with "query" is optional; queries without a row have no
// true match.
//
//   query,correct_places
//   0,0 1 2
//   1,0 1 2 3
#pragma once

#include <string>

#include "bsf_vpr/core/evaluation.h"

namespace bsf_vpr {

// Reads a ground-truth CSV for `num_queries` queries over `num_places` places. Throws
// std::runtime_error naming the file and line of a malformed row, a query or place out of
// range, or a query listed twice.
GroundTruth ReadGroundTruthCsv(const std::string& path, int num_queries, int num_places);

// Writes `truth` in the same format, atomically.
void WriteGroundTruthCsv(const std::string& path, const GroundTruth& truth);

}  // namespace bsf_vpr
