// bsf_evaluate: offline evaluation of place recognition methods (see --help).

#include <chrono>
#include <cstdio>
#include <iostream>

#include "bsf_vpr/core/results_io.h"
#include "evaluate_args.h"
#include "evaluate_inputs.h"

namespace {

constexpr int kExitBadInput = 2;

int Run(int argc, char** argv) {
  using namespace bsf_vpr;
  const tools::EvaluateArgs args = tools::ParseEvaluateArgs(argc, argv);
  if (args.help) {
    std::cout << tools::kEvaluateUsage;
    return 0;
  }
  const auto data = tools::LoadEvaluationData(args);
  const std::vector<Method> methods = ParseMethodList(args.methods, data->input.set_names);
  std::cout << "bsf_evaluate: " << data->description << std::endl;

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
  std::cout << FormatSummaryTable(results);
  if (!args.out_dir.empty()) {
    WriteEvaluationOutputs(args.out_dir, results);
    std::cout << "bsf_evaluate: wrote " << args.out_dir << "/summary.csv and " << args.out_dir
              << "/matches/\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "bsf_evaluate: error: " << e.what() << '\n';
    return kExitBadInput;
  }
}
