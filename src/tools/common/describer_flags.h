// The image-descriptor flags shared by the tools that describe image folders (bsf_evaluate
// and bsf_make_reference): --image-descriptor patchnorm|hog|onnx and the options of each,
// the ImageDescriberOptionsTable() that also gives the ingest nodelet its parameters.
#pragma once

#include <string>

#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/image/image_describer.h"

namespace bsf_vpr {
namespace tools {

// Applies `flag` (an option of ImageDescriberOptionsTable() as --name-with-dashes) to
// `options` and returns true; returns false, changing nothing, for any other flag. Throws
// std::invalid_argument naming the flag for a bad value.
bool ParseDescriberFlag(const std::string& flag, const std::string& value,
                        ImageDescriberOptions* options);

// The usage lines of these flags, made from the table (options at column 3, descriptions
// at column 27).
std::string DescriberUsage();

// Describes every image of ListImageFiles(folder) as set `name`, row k = place k, and
// records the descriptor type and the images (the folder made absolute, row k's file name);
// `blind`, if given, receives per row what DescribeImageFolder says of it.
ReferenceSet DescribeImageFolderAsSet(const std::string& folder, const std::string& name,
                                      const ImageDescriber& describer,
                                      std::vector<std::string>* blind = nullptr);

}  // namespace tools
}  // namespace bsf_vpr
