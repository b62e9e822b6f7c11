// Reference set selection (paper, Eq. reference_selection and best_reference).
#pragma once

#include <string>
#include <vector>

#include "bsf_vpr/core/distances.h"

namespace bsf_vpr {

enum class SelectionRule {
  // The paper's rule: u* has the smallest minimum distance; u is selected when
  // (min D^u - min D^u*) <= gamma * min D^u*. (Written without the division, so a zero
  // minimum selects exactly the sets whose minimum is also zero.)
  kRelative,
  // Scale-free rule for sources whose distance scales differ (e.g. different descriptor
  // types): each set scores s_u = (mean D^u - min D^u) / std D^u, how far its minimum lies
  // below its own mean in its own standard deviations (0 when std is 0). u* has the largest
  // score; u is selected when s_u* - s_u <= gamma * s_u*.
  kStandardized,
};

SelectionRule ParseSelectionRule(const std::string& name);  // "relative" | "standardized"
std::string ToString(SelectionRule rule);

struct SelectionOptions {
  double gamma_fraction = 0.04;  // gamma of the paper, a fraction >= 0
  SelectionRule rule = SelectionRule::kRelative;

  // Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

// Summary statistics of one D^u: min, mean and population standard deviation.
struct DistanceStats {
  float min = 0;
  int argmin = 0;  // index k into the set's values (not a place id)
  double mean = 0;
  double stddev = 0;
};
DistanceStats ComputeDistanceStats(const SetDistances& d);

struct Selection {
  int best = -1;                         // u*, an index into the sets passed in
  std::vector<int> selected;             // S, ascending set indices; always contains `best`
  std::vector<DistanceStats> set_stats;  // min D^u, mean, std of every set passed in
};

// Selects among `sets` (each with count > 0). Throws std::invalid_argument if `sets` is
// empty or one of them has no distances.
Selection SelectReferenceSets(const std::vector<SetDistances>& sets,
                              const SelectionOptions& options);

}  // namespace bsf_vpr
