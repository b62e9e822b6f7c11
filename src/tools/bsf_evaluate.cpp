// bsf_evaluate: offline evaluation of place recognition methods (see --help).

#include <chrono>
#include <cstdio>
#include <iostream>

#include "bsf_vpr/core/ground_truth_io.h"
#include "bsf_vpr/core/results_io.h"
#include "cli_util.h"
#include "evaluate_args.h"
#include "evaluate_ground_truth.h"
#include "evaluate_inputs.h"
#include "evaluate_results_bag.h"

namespace {

void Report(const std::vector<bsf_vpr::MethodResults>& results, const std::string& out_dir) {
  std::cout << bsf_vpr::FormatSummaryTable(results);
  if (!out_dir.empty()) {
    bsf_vpr::WriteEvaluationOutputs(out_dir, results);
    std::cout << "bsf_evaluate: wrote " << out_dir << "/summary.csv and " << out_dir
              << "/matches/\n";
  }
}

// Scores the beliefs recorded during a replay exactly as the offline mode scores a method.
int RunResultsBag(const bsf_vpr::tools::EvaluateArgs& args) {
  using namespace bsf_vpr;
  tools::ResultsBag bag =
      tools::ReadResultsBag(args.results_bag, args.belief_topic, args.truth_topic);
  const int q = static_cast<int>(bag.outcomes.size());
  GroundTruth truth;
  std::string truth_description;
  if (args.tolerance_frames >= 0) {
    truth = GroundTruth::FromFrameTolerance(q, bag.num_places, args.tolerance_frames);
    truth_description = tools::DescribeFrameTruth(args.tolerance_frames);
  } else if (!args.ground_truth.empty()) {
    truth = ReadGroundTruthFile(args.ground_truth, q, bag.num_places);
    truth_description = "the correct places listed in '" + args.ground_truth + "'";
  } else if (bag.truth) {
    truth = *bag.truth;
    truth_description = "the correct places recorded on " + args.truth_topic;
  } else {
    throw std::invalid_argument("no ground truth: give --tolerance or --ground-truth, or record " +
                                args.truth_topic + " in the results bag");
  }
  MethodResults r;
  r.method = ParseMethod(bag.method, bag.set_names);
  r.outcomes = std::move(bag.outcomes);
  r.metrics = ScoreOutcomes(r.outcomes, truth);
  std::cout << "bsf_evaluate: results bag " << args.results_bag << ": " << q << " queries, method "
            << bag.method;
  if (bag.missing > 0) std::cout << ", " << bag.missing << " without a belief (counted as wrong)";
  std::cout << "\nbsf_evaluate: ground truth: " << truth_description << "; "
            << tools::CountTrueMatches(truth) << std::endl;
  Report({r}, args.out_dir);
  return 0;
}

int Run(int argc, char** argv) {
  using namespace bsf_vpr;
  const tools::EvaluateArgs args = tools::ParseEvaluateArgs(argc, argv);
  if (args.help) {
    std::cout << tools::EvaluateUsage();
    return 0;
  }
  if (!args.results_bag.empty()) return RunResultsBag(args);
  const auto data = tools::LoadEvaluationData(args);
  const std::vector<Method> methods = ParseMethodList(args.methods, data->input.set_names);
  std::cout << "bsf_evaluate: " << data->description
            << "\nbsf_evaluate: ground truth: " << data->truth_description << std::endl;

  const auto start = std::chrono::steady_clock::now();
  auto last_report = start;
  std::function<void(int, int)> progress;
  if (args.progress) {
    progress = [&](int done, int total) {
      const auto now = std::chrono::steady_clock::now();
      if (done < total && now - last_report < std::chrono::seconds(2)) return;
      last_report = now;
      std::fprintf(stderr, "bsf_evaluate: %d/%d queries (%.1f s)\n", done, total,
                   std::chrono::duration<double>(now - start).count());
    };
  }
  const std::vector<MethodResults> results =
      EvaluateMethods(data->input, methods, args.options, data->truth, progress);
  Report(results, args.out_dir);
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return bsf_vpr::tools::RunTool("bsf_evaluate", Run, argc, argv); }
