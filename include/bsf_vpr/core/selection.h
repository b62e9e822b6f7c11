// Reference set selection (paper, Eq. reference_selection and best_reference).
#pragma once

#include <string>
#include <vector>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/enum_names.h"
#include "bsf_vpr/core/options.h"

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

// The rules' names (selection).
const EnumNames<SelectionRule>& SelectionRuleNames();
SelectionRule ParseSelectionRule(const std::string& name);  // throws naming the choices
std::string ToString(SelectionRule rule);

struct SelectionOptions {
  // gamma of the paper, a fraction >= 0: the selection boundary, and the scale of the
  // mixture fusion's soft weights (ConditionWeights)
  double gamma_fraction = 0.04;
  SelectionRule rule = SelectionRule::kRelative;

  // Throws std::invalid_argument naming the bad field (the bounds of SelectionOptionsTable).
  void Validate() const;
};

// gamma_fraction and selection (part of MethodOptionsTable, methods.h).
const OptionTable<SelectionOptions>& SelectionOptionsTable();

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
// empty or one of them has no distances. `within_groups` false: the paper's rule over all
// sets, groups ignored. true: the rule within each group of sets (SetDistances::group):
// minimum distances of different descriptors are not compared; `best` is still the best
// set overall.
Selection SelectReferenceSets(const std::vector<SetDistances>& sets,
                              const SelectionOptions& options, bool within_groups = false);

// The soft form of selection that the mixture fusion weights sets by: within each group,
// set u gets w_u = exp(-(score_u - score*) / (gamma |score*|)), with score the rule's (the
// minimum distance for relative, minus s_u for standardized) and score* the group's best.
// The best set of a group gets 1 and a set on the paper's selection boundary e^-1, so the
// sets with w_u >= e^-1 are exactly those SelectReferenceSets(..., true) selects. With
// gamma = 0 or score* = 0 the weights are 1 for the sets that tie with the best, else 0.
// `stats` holds ComputeDistanceStats of every set (as Selection::set_stats).
std::vector<double> ConditionWeights(const std::vector<SetDistances>& sets,
                                     const std::vector<DistanceStats>& stats,
                                     const SelectionOptions& options);

}  // namespace bsf_vpr
