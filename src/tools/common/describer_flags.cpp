#include "src/tools/common/describer_flags.h"

#include <filesystem>

#include "bsf_vpr/io/file_util.h"

namespace bsf_vpr {
namespace tools {

bool ParseDescriberFlag(const std::string& flag, const std::string& value,
                        ImageDescriberOptions* options) {
  return ImageDescriberOptionsTable().SetFromFlag(flag, value, options);
}

std::string DescriberUsage() { return OptionsUsage(ImageDescriberOptionsTable().Infos()); }

ReferenceSet DescribeImageFolderAsSet(const std::string& folder, const std::string& name,
                                      const ImageDescriber& describer,
                                      std::vector<std::string>* blind) {
  ReferenceSet set = MakeReferenceSet(name, DescribeImageFolder(folder, describer, blind));
  set.descriptor_type = describer.descriptor_type();
  set.images = std::filesystem::absolute(folder).lexically_normal().string();
  for (const std::string& file : ListImageFiles(folder)) set.image_files.push_back(BaseName(file));
  return set;
}

}  // namespace tools
}  // namespace bsf_vpr
