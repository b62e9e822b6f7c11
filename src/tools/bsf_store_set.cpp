// bsf_store_set: a reference set written as a map holds it (int8 or float16), so that the
// fusion node and bsf_evaluate can memory-map it instead of reading it (see --help).
#include <filesystem>
#include <iostream>
#include <limits>
#include <stdexcept>
#include <string>

#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "src/tools/common/cli_util.h"

namespace {

const char kUsage[] =
    R"(usage: bsf_store_set --set FILE --out OUT.yaml [--storage int8|float16|float32]

Writes the reference set FILE (a set's .yaml, or a descriptor .npy) as a map holds it at
--storage (default int8): OUT.<storage>.<content hash>.npy with the encoded rows (int8: one
scale for the set, max |x| / 127, written to OUT.yaml as descriptor_scale), then OUT.yaml
naming it with the set's name, condition, places, poses and images. Writing over an OUT
made before replaces it as one (a kill leaves the old set whole) and removes its old rows;
the temporary files a killed run for the same OUT left are removed at the start. A map that stores sets at that
precision with memory_map (the node's parameter, bsf_evaluate --memory-map) maps the file
instead of reading it: loading then costs the set's norms, not its bytes, and the distances
are bitwise those of FILE loaded and encoded at --storage (docs/performance.md, "Maps larger
than memory"). Each file is written atomically.
  --set FILE        the set to write (.yaml, or .npy whose rows are places 0..N-1)
  --out OUT.yaml    the set's new YAML; its .npy goes beside it
  --storage P       int8 (a quarter of float32's bytes), float16 (half) or float32
  -h, --help        this help
Exit status 2 with one line naming the problem on bad arguments or an unreadable set.
)";

int Run(int argc, char** argv) {
  using namespace bsf_vpr;
  std::string set_path, out, storage = "int8";
  tools::FlagReader flags(argc, argv);
  for (std::string f, v; flags.Next(&f, &v);) {
    if (f == "--set")
      set_path = v;
    else if (f == "--out")
      out = v;
    else if (f == "--storage")
      storage = v;
    else
      throw std::invalid_argument("unknown option '" + f + "' (see --help)");
  }
  if (flags.help()) {
    std::cout << kUsage;
    return 0;
  }
  if (set_path.empty() || out.empty()) throw std::invalid_argument("--set and --out are required");
  const StoragePrecision precision = ParseStoragePrecision(storage);
  // A bare .npy carries no name: the set is named after the output's file.
  const bool npy = set_path.size() > 4 && set_path.compare(set_path.size() - 4, 4, ".npy") == 0;
  std::string name;
  if (npy) {
    name = out.substr(out.find_last_of('/') + 1);
    name = name.substr(0, name.rfind(".yaml"));
  }
  ReferenceSet set = LoadReferenceSetFile(set_path, name);
  // What a killed run of this tool for the same OUT left: its rows' temporary files.
  namespace fs = std::filesystem;
  const fs::path out_path(out);
  const std::string stem = out_path.stem().string();
  const fs::path folder = out_path.has_parent_path() ? out_path.parent_path() : fs::path(".");
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(folder, ec)) {
    const std::string f = e.path().filename().string();
    if (f.rfind("." + stem + "." + storage + ".", 0) == 0 &&
        f.find(".npy.bsf_tmp.") != std::string::npos && e.is_regular_file()) {
      fs::remove(e.path(), ec);
    }
  }
  ReferenceSets map;
  map.SetStoragePrecision(precision);
  map.SetPlacePoseTolerance(std::numeric_limits<double>::infinity());
  map.Add(std::move(set));
  SaveStoredReferenceSet(map.set(0), out);
  const StoredReferenceSet& s = map.set(0);
  std::cout << "bsf_store_set: wrote '" << s.name() << "' (" << s.size() << " x " << s.dimension()
            << ", " << ToString(s.precision()) << ", " << s.data_bytes() << " bytes) to " << out
            << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return bsf_vpr::tools::RunTool("bsf_store_set", Run, argc, argv);
}
