// Reference curation from selection statistics (the paper's future work: which reference
// sets to keep or collect). Input: one record per query of a traversal, as the fusion node
// publishes them in its beliefs.
//
//   redundant    a set that is rarely selected (selected_fraction < rarely_selected_fraction),
//                or that, whenever it is selected, is selected together with another set
//                whose minimum distance is lower (in at least dominated_fraction of its
//                selections): that set already covers it.
//   coverage gap a run of consecutive queries where no set was close: the smallest minimum
//                distance over all sets exceeds gap_factor times its median over the traversal.
//                New reference data of that stretch's condition would help there.
#pragma once

#include <string>
#include <vector>

namespace bsf_vpr {

struct QueryRecord {
  std::vector<std::string> set_names;    // every loaded set
  std::vector<float> set_min_distances;  // min D^u, one per set_names entry
  std::vector<std::string> selected;     // the selected sets S
  std::vector<float> set_weights;        // the weight of each set (Belief.set_weights); may
                                         // be empty (beliefs recorded before it existed)
};

struct CurationOptions {
  double rarely_selected_fraction = 0.05;
  double dominated_fraction = 0.95;
  double gap_factor = 1.5;
  int min_gap_queries = 3;  // shorter runs are not reported

  void Validate() const;  // throws std::invalid_argument naming the bad field
};

struct SetCuration {
  std::string name;
  double selected_fraction = 0;  // of the queries
  double best_fraction = 0;      // of the queries: the set was u* (smallest minimum)
  double mean_weight = -1;       // mean weight the method gave it (-1: not recorded)
  std::string dominated_by;      // the set that covers it, if any
  bool redundant = false;
  std::string reason;
};

struct CoverageGap {
  int first_query = 0, last_query = 0;  // inclusive
  double worst_ratio = 0;               // largest (min distance / median) in the run
};

struct CurationReport {
  int queries = 0;
  double median_best_distance = 0;
  std::vector<SetCuration> sets;
  std::vector<CoverageGap> gaps;
};

// Throws std::invalid_argument for no records or records whose sets disagree in size.
CurationReport Curate(const std::vector<QueryRecord>& records, const CurationOptions& options);

// A table for a terminal: one row per set with its recommendation, then the gaps.
std::string FormatCurationReport(const CurationReport& report);

}  // namespace bsf_vpr
