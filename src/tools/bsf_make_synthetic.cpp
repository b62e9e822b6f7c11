// bsf_make_synthetic: writes the seeded multi-condition data of synthetic.h as .npy files,
// for studies that need more conditions than the shipped real data has (see --help).
#include <iostream>
#include <sstream>

#include "bsf_vpr/evaluation/ground_truth_io.h"
#include "bsf_vpr/evaluation/synthetic.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "src/tools/common/cli_util.h"

namespace {

const char kUsage[] = R"(usage: bsf_make_synthetic --out DIR [options]

Writes DIR/c0.npy, c1.npy, ... (one reference set per condition, N x D), DIR/queries.npy
(N x D; query q is at place q), DIR/query_conditions.csv and DIR/ground_truth.csv; DIR is
created if missing.
  --places N             places (default 300)
  --dimension D          descriptor dimension (default 32)
  --set-noise A,B,...    per-set image noise; one value per condition (default 0.3,0.3,0.3)
  --condition-strength S how strongly a condition changes every place (default 1.0)
  --query-noise Q        (default 0.3)
  --query-weights W,...  probability of each condition for a query (default: all condition 0)
  --seed S               (default 1)
  -h, --help             this help
Exit status 2 with one line naming the problem on bad arguments.
)";

std::vector<double> List(const std::string& flag, const std::string& v) {
  std::vector<double> out;
  std::stringstream ss(v);
  for (std::string item; std::getline(ss, item, ',');) {
    out.push_back(bsf_vpr::tools::ParseNumber(flag, item));
  }
  return out;
}

int Run(int argc, char** argv) {
  using namespace bsf_vpr;
  SyntheticOptions o;
  std::string out;
  tools::FlagReader flags(argc, argv);
  for (std::string f, v; flags.Next(&f, &v);) {
    if (f == "--out")
      out = v;
    else if (f == "--places")
      o.num_places = tools::ParseInteger(f, v);
    else if (f == "--dimension")
      o.dimension = tools::ParseInteger(f, v);
    else if (f == "--set-noise")
      o.set_noise = List(f, v);
    else if (f == "--condition-strength")
      o.condition_strength = tools::ParseNumber(f, v);
    else if (f == "--query-noise")
      o.query_noise = tools::ParseNumber(f, v);
    else if (f == "--query-weights")
      o.query_condition_weights = List(f, v);
    else if (f == "--seed")
      o.seed = static_cast<uint64_t>(tools::ParseInteger(f, v));
    else
      throw std::invalid_argument("unknown option '" + f + "' (see --help)");
  }
  if (flags.help()) {
    std::cout << kUsage;
    return 0;
  }
  if (out.empty()) throw std::invalid_argument("no --out DIR given");
  const SyntheticData d = GenerateMultiConditionData(o);
  tools::CreateFolders(out);
  for (const StoredReferenceSet& s : d.map.sets())
    WriteNpyMatrix(out + "/" + s.name() + ".npy", s.ToReferenceSet().descriptors);
  WriteNpyMatrix(out + "/queries.npy", d.queries);
  WriteGroundTruthCsv(out + "/ground_truth.csv", d.truth);
  std::ostringstream conditions;
  conditions << "query,condition\n";
  for (size_t q = 0; q < d.query_condition.size(); ++q)
    conditions << q << ",c" << d.query_condition[q] << '\n';
  WriteFileAtomically(out + "/query_conditions.csv", conditions.str());
  std::cout << "bsf_make_synthetic: wrote " << d.map.num_sets() << " reference sets and "
            << d.queries.rows() << " queries to " << out << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return bsf_vpr::tools::RunTool("bsf_make_synthetic", Run, argc, argv);
}
