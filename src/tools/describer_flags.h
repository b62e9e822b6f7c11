// The image-descriptor flags shared by the tools that describe image folders (bsf_evaluate
// and bsf_make_reference): --descriptor patchnorm|hog|onnx and the options of each, parsed
// into the ImageDescriberOptions that the ingest nodelet fills from its parameters. The
// usage text is made from the options' defaults, so that it cannot drift from them.
#pragma once

#include <string>
#include <vector>

#include "bsf_vpr/core/image_describer.h"
#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {
namespace tools {

// The flags among these that take no value: --onnx-bgr, --onnx-no-l2.
const std::vector<std::string>& DescriberSwitches();

// Applies `flag` to `options` and returns true if it is one of DescriberSwitches().
bool ParseDescriberSwitch(const std::string& flag, ImageDescriberOptions* options);

// Parses `value` into `options` and returns true if `flag` is one of the image-descriptor
// flags that take a value; returns false (and changes nothing) for any other flag. Throws
// std::invalid_argument naming the flag for a value that is not of its kind.
bool ParseDescriberFlag(const std::string& flag, const std::string& value,
                        ImageDescriberOptions* options);

// Checks the descriptor name and the options of the chosen descriptor (and the
// patch-normalised options, which are always checked). Throws std::invalid_argument naming
// the bad field. A missing ONNX model is found later, by MakeImageDescriber.
void ValidateDescriberOptions(const ImageDescriberOptions& options);

// The usage lines of these flags, indented for the tools' --help (options at column 3,
// descriptions at column 27).
std::string DescriberUsage();

// Describes every image of ListImageFiles(folder) as set `name`, row k = place k, and
// records the descriptor type.
ReferenceSet DescribeImageFolderAsSet(const std::string& folder, const std::string& name,
                                      const ImageDescriber& describer);

}  // namespace tools
}  // namespace bsf_vpr
