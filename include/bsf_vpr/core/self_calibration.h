// The map calibrates itself (docs/method.md, "What the map knows of itself"). A map of two or
// more traversals of one route is labelled data about itself: held out as queries against
// the other sets, each traversal's rows show known places, and with the neighbourhood of
// their places held out of the map as well they show none. Run through the method exactly
// as live queries are (in the traversal's order, the filter, the sequence and the off-map
// tracker carried from one to the next), they give what the evidence of a right match looks
// like and what that of a look-alike does: its confidence and its absolute distance.
//
//   on the map    each traversal t in turn against the other sets (needs two or more sets);
//                 a row whose place no other set shows counts as off the map
//   off the map   each of kCalibrationBlocks stretches of t's rows, with every place they
//                 show (and kCalibrationTolerancePlaces either side) taken out of the map,
//                 entered after kCalibrationLeadIn rows on the map; with one set, t is
//                 queried against itself so held out (reported, not enforced: usable())
//
// From these: the score, the log-odds that a match is right from its confidence and its
// distance (a logistic fit on the right matches against the wrong and off-map ones; the
// confidence alone when there are fewer than kCalibrationMinSamples of either), and the
// cut, the ceil((1 - alpha)(n + 1))-th smallest of the n off-map rows' scores (a row that
// fails the threshold scores -infinity), each row scored by a fit made without its own
// traversal (cross-fitting). Were the rows exchangeable with new off-map queries, a new one
// would pass with probability at most alpha (the conformal bound); they are not quite (the
// rows of a stream share its state, the live map holds one traversal more), so the rate is
// a prediction, measured against held-back routes in docs/results.md. Nothing is fitted on
// live queries.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bsf_vpr/core/decision.h"
#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/methods.h"
#include "bsf_vpr/core/options.h"

namespace bsf_vpr {

class ReferenceSets;

// Stretches of a traversal held out of the map in turn.
constexpr int kCalibrationBlocks = 5;
// Rows queried on the map before a held-out stretch (the filter's state entering it).
constexpr int kCalibrationLeadIn = 20;
// A match within this many places of the row's place is right; the places this far either
// side of a held-out stretch go with it (their images look alike).
constexpr int kCalibrationTolerancePlaces = 2;
// Fewer right matches or wrong ones than this: the score is the confidence alone.
constexpr int kCalibrationMinSamples = 20;
// At most this many distances of one held-out traversal to the sets it is queried against
// (4 bytes each: 1 GiB): a larger traversal is not held out, and the calibration says so.
constexpr int64_t kCalibrationMaxDistances = int64_t{1} << 28;

struct CalibrationOptions {
  // The rate of false acceptances of queries that show no place of the map the rule is
  // made for; 0: no rule (the threshold alone).
  double max_false_accept_rate = 0;

  void Validate() const;  // throws std::invalid_argument naming the bad field
};
const OptionTable<CalibrationOptions>& CalibrationOptionsTable();

// One held-out row's outcome.
struct CalibrationSample {
  int traversal = 0;  // the set held out as queries
  double confidence = 0;
  double match_distance = 0;  // NaN: no used set covers the match
  bool passes_threshold = false;
  bool right = false;  // on the map and within kCalibrationTolerancePlaces (false off it)
};

struct MapCalibration {
  std::string method;           // the method's name, as calibrated
  double target_rate = 0;       // max_false_accept_rate asked for
  int traversals_held_out = 0;  // sets queried against the others (0 with one set)
  std::vector<CalibrationSample> on_map, off_map;
  AcceptanceRule rule;
  bool uses_distance = false;  // the score weighs the match's distance
  // Off-map rows the rule (with the threshold) accepts, and the rate it predicts for new
  // off-map queries: (accepted + 1) / (n + 1), the conformal bound's estimate.
  int off_map_accepted = 0;
  double predicted_false_accept_rate = 0;
  // On-map rows accepted and right, over all on-map rows (NaN without any).
  double recall = 0;
  double seconds = 0;
  std::string note;  // what it could not measure ("" if nothing)

  // Whether the rule vouches for new queries: off-map and on-map rows were measured with a
  // traversal held out (on-map rows: another traversal shows its places). With one traversal the
  // only look-alikes are its own rows against itself, of its own condition: closer than a query of
  // another condition ever comes, so a cut set on them turns down right matches too (measured:
  // docs/results.md, Study 8). The rate is then reported, not enforced.
  bool usable() const { return !off_map.empty() && !on_map.empty() && traversals_held_out > 0; }

  // One line: "on this map: false acceptances x% at recall y% on held-out traversals ...".
  std::string Summary() const;
};

// Calibrates `method` with `options` on the sets of `map` (descriptors of one dimension),
// the distance `metric`, for `max_false_accept_rate`. Throws std::invalid_argument when the
// map is empty or the rate is not in (0, 1), and CalibrationCancelled once `cancel` (if
// given) is set, checked between streams.
// What CalibrateMap throws when `cancel` was set.
struct CalibrationCancelled : std::runtime_error {
  CalibrationCancelled() : std::runtime_error("calibration cancelled") {}
};

MapCalibration CalibrateMap(const ReferenceSets& map, DistanceMetric metric,
                            const std::string& method, const MethodOptions& options,
                            double max_false_accept_rate,
                            const std::atomic<bool>* cancel = nullptr);

}  // namespace bsf_vpr
