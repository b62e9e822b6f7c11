// bsf_import's command line: the dataset layout, the traversals to import as reference sets
// and as query bags, and the options (one table, ImportOptionsTable(), for the flags and
// their usage text).
#pragma once

#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "bsf_vpr/core/options.h"
#include "bsf_vpr/core/place_index.h"
#include "bsf_vpr/image/image_describer.h"
#include "src/tools/import/import_traversal.h"

namespace bsf_vpr {
namespace tools {

struct ImportOptions {
  std::string camera = ReadOptions().camera;
  double frame_rate_hz = ReadOptions().frame_rate_hz;
  PlaceIndexOptions place_index;  // PlaceIndexOptionsTable(): spacing, association, yaw
  double tolerance_m = 10;        // the paper's Oxford RobotCar protocol
  int tolerance = 2;              // frame-aligned (Nordland without GPS): +-places, as bsf_evaluate
  double rate_hz = 0;             // 0: the original timestamps
  bool query_descriptors = false;
};
const OptionTable<ImportOptions>& ImportOptionsTable();

struct NamedSpec {
  std::string name, spec;
};

struct ImportArgs {
  DatasetFolders layout = DatasetFolders::kGeneric;
  std::vector<NamedSpec> references, queries;
  std::map<std::string, std::string> conditions;  // reference name -> condition label
  std::string out_dir;
  std::string distance;  // "" | euclidean | cosine, recorded in the sets
  cv::Size resize;       // empty: as they are
  ImageDescriberOptions describer;
  std::string describer_flag;  // the first image-descriptor flag given, if any
  ImportOptions options;
  std::vector<std::string> flags_given;  // names of the table's options given
  bool help = false;

  bool Given(const std::string& option_name) const;
};

// Parses and checks the command line. Throws std::invalid_argument naming the flag.
ImportArgs ParseImportArgs(int argc, char** argv);
std::string ImportUsage();

}  // namespace tools
}  // namespace bsf_vpr
