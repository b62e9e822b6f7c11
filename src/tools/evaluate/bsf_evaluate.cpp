// bsf_evaluate: offline evaluation of place recognition methods (see --help).

#include <malloc.h>
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include "bsf_vpr/evaluation/ground_truth_io.h"
#include "bsf_vpr/evaluation/results_io.h"
#include "src/tools/common/cli_util.h"
#include "src/tools/evaluate/evaluate_args.h"
#include "src/tools/evaluate/evaluate_ground_truth.h"
#include "src/tools/evaluate/evaluate_inputs.h"
#include "src/tools/evaluate/evaluate_results_bag.h"

namespace {

// --timings: wall time and cores busy (CPU time of all threads / wall time) per phase.
class PhaseTimes {
 public:
  // `parts`: the phase's parts, timed where they ran, in brackets after it.
  void End(const std::string& phase, const std::string& parts = "") {
    const Point now = Now();
    text_ += (text_.empty() ? "" : ", ") + Phase(phase, now.wall - last_.wall, now.cpu - last_.cpu);
    if (!parts.empty()) text_ += " [" + parts + "]";
    last_ = now;
  }
  static std::string Phase(const std::string& phase, double wall, double cpu) {
    return phase + " " + Format(wall, 3) + " s (" + Format(wall > 0 ? cpu / wall : 0.0, 2) +
           " cores)";
  }
  std::string text() const { return text_; }

 private:
  struct Point {
    double wall = 0, cpu = 0;
  };
  static Point Now() {
    return {
        std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(),
        bsf_vpr::tools::CpuSeconds(RUSAGE_SELF)};
  }
  static std::string Format(double v, int decimals) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    return buf;
  }
  Point last_ = Now();
  std::string text_;
};

void Report(const std::vector<bsf_vpr::MethodResults>& results, const std::string& out_dir) {
  std::cout << bsf_vpr::FormatSummaryTable(results);
  if (!out_dir.empty()) {
    bsf_vpr::WriteEvaluationOutputs(out_dir, results);
    std::cout << "bsf_evaluate: wrote " << out_dir << "/summary.csv and " << out_dir
              << "/matches/\n";
  }
}

// The ground truth by position of a replay's queries that have a pose (`scored`, in query
// order; the others are left out of the scores: where they were is unknown).
struct BagMetricTruth {
  bsf_vpr::GroundTruth truth;  // over the scored queries only
  std::vector<int> scored;
  std::string description;
};

BagMetricTruth MetricTruthOfBag(const bsf_vpr::tools::EvaluateArgs& args,
                                const bsf_vpr::tools::ResultsBag& bag) {
  using namespace bsf_vpr;
  if (bag.num_poses == 0) {
    throw std::invalid_argument("results bag '" + args.results_bag +
                                "' holds no geometry_msgs/PoseStamped on " + args.pose_topic +
                                ": --tolerance-m needs the query poses (bsf_make_bag --poses)");
  }
  const std::vector<std::optional<PlacePose>> place_poses =
      tools::NodePlacePoses(args.references, bag.set_names, bag.num_places);
  BagMetricTruth out;
  std::vector<PlacePose> query_poses;
  for (size_t k = 0; k < bag.query_poses.size(); ++k) {
    if (!bag.query_poses[k]) continue;
    out.scored.push_back(static_cast<int>(k));
    query_poses.push_back(*bag.query_poses[k]);
  }
  if (out.scored.empty()) {
    throw std::invalid_argument("no belief in '" + args.results_bag + "' has a pose on " +
                                args.pose_topic + " with its header stamp (" +
                                std::to_string(bag.num_poses) +
                                " poses there): a query's pose must carry the query's stamp");
  }
  out.truth = GroundTruth::FromMetricTolerance(query_poses, place_poses, args.tolerance_m);
  out.description = tools::DescribeMetricTruth(args.tolerance_m, args.pose_topic, place_poses);
  return out;
}

// Scores the beliefs recorded during a replay exactly as the offline mode scores a method.
int RunResultsBag(const bsf_vpr::tools::EvaluateArgs& args) {
  using namespace bsf_vpr;
  tools::ResultsBag bag =
      tools::ReadResultsBag(args.results_bag, args.belief_topic, args.truth_topic,
                            args.tolerance_m >= 0 ? args.pose_topic : "");
  const int q = static_cast<int>(bag.outcomes.size());
  GroundTruth truth;
  std::string truth_description;
  std::vector<QueryOutcome> scored = bag.outcomes;
  if (args.tolerance_frames >= 0) {
    truth = GroundTruth::FromFrameTolerance(q, bag.num_places, args.tolerance_frames);
    truth_description = tools::DescribeFrameTruth(args.tolerance_frames);
  } else if (args.tolerance_m >= 0) {
    BagMetricTruth metric = MetricTruthOfBag(args, bag);
    scored.clear();
    for (int k : metric.scored) scored.push_back(bag.outcomes[static_cast<size_t>(k)]);
    truth = std::move(metric.truth);
    truth_description = metric.description;
  } else if (!args.ground_truth.empty()) {
    truth = ReadGroundTruthFile(args.ground_truth, q, bag.num_places);
    truth_description = "the correct places listed in '" + args.ground_truth + "'";
  } else if (bag.truth) {
    truth = *bag.truth;
    truth_description = "the correct places recorded on " + args.truth_topic;
  } else {
    throw std::invalid_argument(
        "no ground truth: give --tolerance, --tolerance-m or --ground-truth, or record " +
        args.truth_topic + " in the results bag");
  }
  MethodResults r;
  r.method = ParseMethod(bag.method, bag.set_names);
  r.metrics = ScoreOutcomes(scored, truth);
  r.outcomes = std::move(bag.outcomes);  // all of them, for matches/<method>.csv
  std::cout << "bsf_evaluate: results bag " << args.results_bag << ": " << q << " queries, method "
            << bag.method;
  if (bag.missing > 0) std::cout << ", " << bag.missing << " without a belief (counted as wrong)";
  if (static_cast<int>(scored.size()) < q) {
    std::cout << ", " << q - static_cast<int>(scored.size()) << " without a query pose on "
              << args.pose_topic << " (left out of the scores)";
  }
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
  PhaseTimes times;
  const auto data = tools::LoadEvaluationData(args);
  times.End("load");
  const std::vector<Method> methods =
      ParseMethodList(args.methods, data->input.set_names, data->joint_problem.empty());
  const std::string joint = tools::PrepareJointRepresentations(methods, args.options, data.get());
  times.End("joint representations");
  std::cout << "bsf_evaluate: " << data->description
            << "\nbsf_evaluate: ground truth: " << data->truth_description << std::endl;
  if (!joint.empty()) std::cout << "bsf_evaluate: " << joint << std::endl;
  for (const std::string& line : tools::CalibrateMethods(methods, args.options, args.calibration.max_false_accept_rate, data.get())) {
    std::cout << "bsf_evaluate: " << line << std::endl;
  }
  times.End("calibration");

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
  EvaluationPhaseTimes parts;
  const std::vector<MethodResults> results =
      EvaluateMethods(data->input, methods, args.options, data->truth, progress, 256, &parts);
  const auto part = [](const std::string& name, const EvaluationPhaseTimes::Phase& p) {
    return PhaseTimes::Phase(name, p.wall_s, p.cpu_s);
  };
  times.End("distances, fusion and metrics", part("distances", parts.distances) + "; " +
                                                 part("fusion", parts.methods) + "; " +
                                                 part("metrics", parts.metrics));
  Report(results, args.out_dir);
  times.End("table and files");
  if (args.timings) std::fprintf(stderr, "bsf_evaluate: timings: %s\n", times.text().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Each block of queries allocates its distances and buffers of a few MB (on the main
  // thread and the workers) and frees them before the next: glibc would map each afresh and
  // unmap it after (above its mmap threshold) or trim the heap, and every block would fault
  // in and zero the same pages again (a third of the process's page faults, 0.1-0.2 s of
  // system time at 3000 queries of 3 x 3000 x 4096). Blocks up to 32 MB (glibc's largest
  // threshold) come from the heap, and freed memory stays there for the next block (the
  // worker threads' heaps too: their trimming keeps the top pad).
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  mallopt(M_TOP_PAD, 64 << 20);
  return bsf_vpr::tools::RunTool("bsf_evaluate", Run, argc, argv);
}
