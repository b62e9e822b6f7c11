// Ground truth from files, in two formats.
//
// CSV: one row per query that has correct places, listing them separated by spaces. A
// header line starting with "query" is optional; queries without a row have no true match.
//
//   query,correct_places
//   0,0 1 2
//   1,0 1 2 3
//
// .npy: a Q x N matrix of truth values, entry (q, i) true when place i is a correct match
// for query q; a row without a true entry is a query without a true match. Bool, integer
// 0/1 or float 0.0/1.0, in C or Fortran order (npy.h). This is the ground-truth matrix of
// the VPR tutorial code (GThard, or GTsoft to count its soft matches as correct) transposed:
// the tutorial's matrices are places x queries, so save numpy.save(path, GThard.T).
#pragma once

#include <string>

#include "bsf_vpr/evaluation/evaluation.h"

namespace bsf_vpr {

// Reads a ground-truth CSV for `num_queries` queries over `num_places` places. Throws
// std::runtime_error naming the file and line of a malformed row, a query or place out of
// range, or a query listed twice.
GroundTruth ReadGroundTruthCsv(const std::string& path, int num_queries, int num_places);

// Reads a ground-truth .npy for `num_queries` queries over `num_places` places. Throws
// std::runtime_error naming the file and the problem: a shape other than num_queries x
// num_places (checked before the data is decoded), or a value other than 0 and 1 (with its
// row and column).
GroundTruth ReadGroundTruthNpy(const std::string& path, int num_queries, int num_places);

// ReadGroundTruthNpy for a path ending in ".npy", ReadGroundTruthCsv for any other.
GroundTruth ReadGroundTruthFile(const std::string& path, int num_queries, int num_places);

// Writes `truth` as CSV, atomically.
void WriteGroundTruthCsv(const std::string& path, const GroundTruth& truth);

}  // namespace bsf_vpr
