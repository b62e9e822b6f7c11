// What reading and saving reference sets share (reference_set_io.cpp, reference_set_save.cpp).
#pragma once

#include <string>

#include "bsf_vpr/io/data_directory.h"

namespace bsf_vpr {
namespace internal {

bool EndsWith(const std::string& s, const std::string& suffix);
// `path` made absolute and lexically normal, without a trailing '/'.
std::string AbsoluteFolder(const std::string& path);
// The path below `dir` of the file a YAML at `yaml` (below dir) names by `field`: an absolute
// field must lie below the directory; a relative one is relative to the YAML's folder and
// may not climb out of the directory. Throws std::invalid_argument otherwise.
std::string ResolveBelow(const DataDirectory& dir, const std::string& yaml,
                         const std::string& field);

}  // namespace internal
}  // namespace bsf_vpr
