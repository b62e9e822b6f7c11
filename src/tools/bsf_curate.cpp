// bsf_curate: reads the beliefs of a replay (a results bag recorded by replay.launch) and
// recommends which reference sets are redundant and where coverage is missing (see --help).
#include <bsf_vpr/Belief.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <iostream>

#include "bsf_vpr/evaluation/curation.h"
#include "src/tools/common/cli_util.h"

namespace {

const char kUsage[] = R"(usage: bsf_curate --results-bag PATH [options]

Reads bsf_vpr/Belief messages (each carries every set's minimum distance and the selected
sets) and prints, per reference set, how often it was selected and was the closest, with a
recommendation: keep, or redundant (rarely selected, or always selected together with a
closer set); then the stretches of queries where no set was close (coverage gaps). The
report goes to standard output; no file is written.
  --results-bag PATH     results bag of a replay (launch/replay.launch)
  --belief-topic T       default /bsf_vpr/belief
  --rarely F             'rarely selected' below this fraction of queries (default 0.05)
  --dominated F          'always selected with a closer set' in this fraction (default 0.95)
  --gap-factor F         a gap: closest distance above F x its median (default 1.5)
  --min-gap N            shortest gap reported, in queries (default 3)
  -h, --help             this help
Exit status 2 with one line naming the problem on bad arguments or input.
)";

int Run(int argc, char** argv) {
  using namespace bsf_vpr;
  std::string bag_path, topic = "/bsf_vpr/belief";
  CurationOptions options;
  tools::FlagReader flags(argc, argv);
  for (std::string f, v; flags.Next(&f, &v);) {
    if (f == "--results-bag") {
      bag_path = v;
    } else if (f == "--belief-topic") {
      topic = v;
    } else if (f == "--rarely") {
      options.rarely_selected_fraction = tools::ParseNumber(f, v);
    } else if (f == "--dominated") {
      options.dominated_fraction = tools::ParseNumber(f, v);
    } else if (f == "--gap-factor") {
      options.gap_factor = tools::ParseNumber(f, v);
    } else if (f == "--min-gap") {
      options.min_gap_queries = tools::ParseInteger(f, v);
    } else {
      throw std::invalid_argument("unknown option '" + f + "' (see --help)");
    }
  }
  if (flags.help()) {
    std::cout << kUsage;
    return 0;
  }
  if (bag_path.empty()) throw std::invalid_argument("no --results-bag PATH given");
  options.Validate();
  rosbag::Bag bag;
  try {
    bag.open(bag_path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot read results bag '" + bag_path + "': " + e.what());
  }
  std::vector<QueryRecord> records;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(topic))) {
    if (const auto b = m.instantiate<Belief>()) {
      records.push_back({b->set_names, b->set_min_distances, b->selected_sets, b->set_weights});
    }
  }
  if (records.empty()) {
    throw std::runtime_error("results bag '" + bag_path + "' holds no bsf_vpr/Belief on " + topic);
  }
  std::cout << FormatCurationReport(Curate(records, options));
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return bsf_vpr::tools::RunTool("bsf_curate", Run, argc, argv); }
