// bsf_make_reference: describes a folder of images (or takes a descriptor .npy) and saves it
// as a reference set (.yaml sidecar + .npy) that the fusion node can load (see --help).
#include <cmath>
#include <iostream>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/image_descriptor.h"
#include "bsf_vpr/core/reference_set_io.h"
#include "cli_util.h"

namespace {

const char kUsage[] =
    R"(usage: bsf_make_reference (--images DIR | --descriptors PATH.npy) --name NAME --out PATH.yaml [options]

Writes PATH.yaml and PATH.npy (atomically): row k is place k (images sorted by name).
  --images DIR           describe the images with the patch-normalised image descriptor
  --descriptors PATH     or take the rows of a descriptor .npy as they are
  --name NAME            name of the reference set
  --out PATH.yaml        the sidecar to write; the .npy goes next to it (missing
                         folders are created)
  --condition TEXT       optional condition label (e.g. winter, night)
  --distance euclidean|cosine   the distance the set is meant for (recorded in the YAML)
  --patch-width W, --patch-height H, --patch-size P   image descriptor (default 64 32 8)
  -h, --help             this help
Exit status 2 with one line naming the problem on bad arguments or input.
)";

int Run(int argc, char** argv) {
  using namespace bsf_vpr;
  std::string images, descriptors, name, out, condition, distance;
  PatchNormOptions patch;
  tools::FlagReader flags(argc, argv);
  for (std::string f, v; flags.Next(&f, &v);) {
    if (f == "--images")
      images = v;
    else if (f == "--descriptors")
      descriptors = v;
    else if (f == "--name")
      name = v;
    else if (f == "--out")
      out = v;
    else if (f == "--condition")
      condition = v;
    else if (f == "--distance")
      distance = ToString(ParseDistanceMetric(v));
    else if (f == "--patch-width")
      patch.width_px = tools::ParseInteger(f, v);
    else if (f == "--patch-height")
      patch.height_px = tools::ParseInteger(f, v);
    else if (f == "--patch-size")
      patch.patch_size_px = tools::ParseInteger(f, v);
    else
      throw std::invalid_argument("unknown option '" + f + "' (see --help)");
  }
  if (flags.help()) {
    std::cout << kUsage;
    return 0;
  }
  if (images.empty() == descriptors.empty()) {
    throw std::invalid_argument("give exactly one of --images DIR and --descriptors PATH.npy");
  }
  if (name.empty() || out.empty()) throw std::invalid_argument("--name and --out are required");
  if (out.size() < 5 || out.compare(out.size() - 5, 5, ".yaml") != 0) {
    throw std::invalid_argument("--out must name a .yaml file, got '" + out + "'");
  }
  ReferenceSet set;
  if (!images.empty()) {
    patch.Validate();
    set = MakeReferenceSet(name, DescribeImageFolder(images, patch), condition);
    set.descriptor_type = patch.DescriptorType();
  } else {
    set = LoadReferenceSetNpy(descriptors, name);
    set.condition = condition;
  }
  set.distance = distance;
  tools::CreateParentFolders(out);
  SaveReferenceSet(set, out);
  std::cout << "bsf_make_reference: wrote " << out << " (" << set.size() << " places, dimension "
            << set.dimension() << ")\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return bsf_vpr::tools::RunTool("bsf_make_reference", Run, argc, argv);
}
