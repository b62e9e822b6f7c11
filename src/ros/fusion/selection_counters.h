// How often each reference set was selected, was the closest set (u*) and supplied the
// matched image, and the mean weight the method gave it, over the queries since start or the last
// reset: what get_selection_statistics answers and diagnostics report.
//
// Not thread-safe: the fusion node holds its lock.
#pragma once

#include <bsf_vpr/ReferenceSetUsage.h>

#include <map>
#include <string>

#include "bsf_vpr/core/place_decider.h"

namespace bsf_vpr {

class SelectionCounters {
 public:
  // Counts one query's recognition against the map it was made with.
  void Count(const Recognition& r, const PlaceLayout& layout);
  // Drops the counts of an unloaded set.
  void Forget(const std::string& set_name);
  void Reset();

  long queries() const { return queries_; }
  // The counts of one set (zero if it was never counted), with its selected fraction.
  ReferenceSetUsage Usage(const std::string& set_name) const;

 private:
  std::map<std::string, long> selected_, best_, supplied_;
  std::map<std::string, double> weight_;  // sum over the queries of Belief.set_weights
  long queries_ = 0;
};

}  // namespace bsf_vpr
