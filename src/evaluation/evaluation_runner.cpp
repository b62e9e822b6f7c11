#include "bsf_vpr/evaluation/evaluation_runner.h"

#include <time.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/method_runner.h"
#include "src/core/internal/worker_pool.h"

namespace bsf_vpr {

namespace {

// Adds the wall and process CPU time since the last Lap (or construction) to a phase.
class PhaseClock {
 public:
  void Lap(EvaluationPhaseTimes::Phase* phase) {
    const double wall = Wall(), cpu = Cpu();
    if (phase != nullptr) {
      phase->wall_s += wall - wall_;
      phase->cpu_s += cpu - cpu_;
    }
    wall_ = wall;
    cpu_ = cpu;
  }

 private:
  static double Wall() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }
  static double Cpu() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
  }
  double wall_ = Wall(), cpu_ = Cpu();
};

}  // namespace

std::vector<MethodResults> EvaluateMethods(const EvaluationInput& input,
                                           const std::vector<Method>& methods,
                                           const MethodOptions& options, const GroundTruth& truth,
                                           const std::function<void(int, int)>& progress,
                                           int block_size, EvaluationPhaseTimes* times) {
  PhaseClock clock;
  options.Validate();
  if (truth.num_queries() != input.num_queries) {
    throw std::invalid_argument("ground truth describes " + std::to_string(truth.num_queries()) +
                                " queries, the evaluation has " +
                                std::to_string(input.num_queries));
  }
  const size_t m = input.set_names.size();
  std::vector<const std::vector<int>*> ids(m, nullptr);
  for (size_t u = 0; u < m && u < input.place_ids.size(); ++u) {
    if (!input.place_ids[u].empty()) ids[u] = &input.place_ids[u];
  }
  std::vector<MethodResults> results(methods.size());
  std::vector<MethodRunner> runners;
  if (!input.acceptance_rules.empty() && input.acceptance_rules.size() != methods.size()) {
    throw std::invalid_argument("acceptance rules given for " +
                                std::to_string(input.acceptance_rules.size()) + " methods of " +
                                std::to_string(methods.size()));
  }
  const auto rule_of = [&input](size_t k) {
    return input.acceptance_rules.empty() ? std::nullopt : input.acceptance_rules[k];
  };
  for (size_t k = 0; k < methods.size(); ++k) {
    runners.emplace_back(methods[k], options);
    runners.back().SetAcceptanceRule(rule_of(k));
    results[k].method = methods[k];
    results[k].outcomes.resize(static_cast<size_t>(input.num_queries));
  }
  for (const auto& [what, size] : {std::pair<const char*, size_t>{"unseen", input.unseen.size()},
                                   {"odometry steps", input.odometry_steps.size()}}) {
    if (size != 0 && size != static_cast<size_t>(input.num_queries)) {
      throw std::invalid_argument(std::string(what) + " given for " + std::to_string(size) +
                                  " queries of " + std::to_string(input.num_queries));
    }
  }
  const auto step_of = [&input](int q) -> std::optional<double> {
    if (input.odometry_steps.empty()) return std::nullopt;
    const double s = input.odometry_steps[static_cast<size_t>(q)];
    return std::isfinite(s) ? std::optional<double>(s) : std::nullopt;
  };
  std::vector<RowMatrixXf> block(m), joint_block(input.joint_kinds.size());
  for (int begin = 0; begin < input.num_queries; begin += block_size) {
    const int end = std::min(input.num_queries, begin + block_size);
    clock.Lap(nullptr);
    input.distances(begin, end, &block);
    if (!input.joint_kinds.empty()) input.joint_distances(begin, end, &joint_block);
    clock.Lap(times ? &times->distances : nullptr);
    for (const RowMatrixXf& j : joint_block) {
      if (j.rows() != end - begin || j.cols() != input.num_places) {
        throw std::logic_error("joint distance block has the wrong shape");
      }
    }
    for (size_t u = 0; u < m; ++u) {
      if (block[u].rows() != end - begin) {
        throw std::logic_error("distance block has the wrong number of rows");
      }
    }
    for (size_t k = 0; k < methods.size(); ++k) {
      const auto run = [&](MethodRunner& runner, int q) {
        QueryOutcome& o = results[k].outcomes[static_cast<size_t>(q)];
        if (!input.unseen.empty() && input.unseen[static_cast<size_t>(q)]) {
          o.confidence = -std::numeric_limits<double>::infinity();  // no observation
          o.off_map_probability = std::numeric_limits<double>::quiet_NaN();
          return;
        }
        const std::vector<SetDistances> views = QueryRowViews(block, q - begin, ids, input.groups);
        std::vector<JointDistances> joint(joint_block.size());
        for (size_t j = 0; j < joint.size(); ++j) {
          joint[j].kind = input.joint_kinds[j];
          joint[j].distances.values = joint_block[j].row(q - begin).data();
          joint[j].distances.count = input.num_places;
        }
        const PlaceBelief b =
            runner.Step(views, input.num_places, nullptr, step_of(q), true, nullptr, &joint);
        o.match = b.match;
        o.confidence = b.confidence;
        o.accepted = b.accepted;
        o.off_map_probability = b.off_map_probability;
        o.match_distance = b.match_distance;
        o.top_places = b.top_places;
      };
      if (methods[k].CarriesState(options)) {
        for (int q = begin; q < end; ++q) run(runners[k], q);  // carries state: in order
        continue;
      }
      // Without state every query stands alone: the cores take them in turn, a few at a time
      // (queries differ in cost: the sets selected), one runner each.
      const int threads = std::min(DistanceThreads(), end - begin);
      constexpr int kQueriesATurn = 8;
      std::atomic<int> next{begin};
      RunParallel(threads, threads, [&](int) {
        MethodRunner runner(methods[k], options);
        runner.SetAcceptanceRule(rule_of(k));
        for (int q0; (q0 = next.fetch_add(kQueriesATurn)) < end;) {
          for (int q = q0; q < std::min(end, q0 + kQueriesATurn); ++q) run(runner, q);
        }
      });
    }
    clock.Lap(times ? &times->methods : nullptr);
    if (progress) progress(end, input.num_queries);
  }
  clock.Lap(nullptr);
  for (MethodResults& r : results) r.metrics = ScoreOutcomes(r.outcomes, truth);
  clock.Lap(times ? &times->metrics : nullptr);
  return results;
}

Metrics ScoreOutcomes(const std::vector<QueryOutcome>& outcomes, const GroundTruth& truth) {
  std::vector<int> matches;
  std::vector<double> confidence;
  std::vector<std::vector<int>> ranked;
  for (const QueryOutcome& o : outcomes) {
    matches.push_back(o.match);
    confidence.push_back(o.confidence);
    ranked.push_back(o.top_places);
  }
  Metrics m = ComputeMetrics(matches, confidence, ranked, truth);
  for (size_t q = 0; q < outcomes.size(); ++q) {
    if (outcomes[q].accepted && !truth.HasTrueMatch(static_cast<int>(q))) ++m.off_map_accepted;
  }
  return m;
}

}  // namespace bsf_vpr
