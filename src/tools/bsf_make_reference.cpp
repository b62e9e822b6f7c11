// bsf_make_reference: describes a folder of images with any of the evaluator's image
// descriptors (or takes a descriptor .npy) and saves it as a reference set (.yaml sidecar +
// .npy) that the fusion node and bsf_evaluate can load (see --help).
#include <algorithm>
#include <cmath>
#include <iostream>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/image/image_describer.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "src/tools/common/cli_util.h"
#include "src/tools/common/describer_flags.h"

namespace {

std::string Usage() {
  return R"(usage: bsf_make_reference (--images DIR | --descriptors PATH.npy) --name NAME --out PATH.yaml [options]

Writes the reference set PATH.yaml and its descriptors beside it as
<stem>.<content hash>.npy (float32), which the YAML names: row k is place k (images
sorted by name). With --images the YAML also names the folder (images:, relative to the
YAML's folder when it lies below it, else absolute) and each row's file (image_files:);
images that show nothing (a covered, black or dazzled camera) are described all the same,
and a warning on stderr counts them and names the first: remove them, or the set holds
places described by noise. The .npy is written first and the YAML replaced last, in one step: a set that existed at
PATH.yaml stays whole until the new one is; its old .npy is then removed.
  --images DIR            describe the images with --image-descriptor (below)
  --descriptors PATH      or take the rows of a descriptor .npy as they are
  --name NAME             name of the reference set
  --out PATH.yaml         the YAML to write (missing folders are created)
  --condition TEXT        optional condition label (e.g. winter, night)
  --distance euclidean|cosine   the distance the set is meant for (recorded in the YAML)
Image descriptor (with --images; the same flags as bsf_evaluate; the descriptor type, e.g.
hog_64x32_c8_b9, is recorded in the YAML):
)" + bsf_vpr::tools::DescriberUsage() +
         R"(  -h, --help              this help
Exit status 2 with one line naming the problem on bad arguments or input.
)";
}

int Run(int argc, char** argv) {
  using namespace bsf_vpr;
  std::string images, descriptors, name, out, condition, distance;
  ImageDescriberOptions describer;
  std::string describer_flag;  // the first image-descriptor flag given, if any
  tools::FlagReader flags(argc, argv);
  for (std::string f, v; flags.Next(&f, &v);) {
    if (f == "--images") {
      images = v;
    } else if (f == "--descriptors") {
      descriptors = v;
    } else if (f == "--name") {
      name = v;
    } else if (f == "--out") {
      out = v;
    } else if (f == "--condition") {
      condition = v;
    } else if (f == "--distance") {
      distance = ToString(tools::ForFlag(f, [&] { return ParseDistanceMetric(v); }));
    } else if (tools::ParseDescriberFlag(f, v, &describer)) {
      if (describer_flag.empty()) describer_flag = f;
    } else {
      throw std::invalid_argument("unknown option '" + f + "' (see --help)");
    }
  }
  if (flags.help()) {
    std::cout << Usage();
    return 0;
  }
  if (images.empty() == descriptors.empty()) {
    throw std::invalid_argument("give exactly one of --images DIR and --descriptors PATH.npy");
  }
  if (name.empty() || out.empty()) throw std::invalid_argument("--name and --out are required");
  if (out.size() < 5 || out.compare(out.size() - 5, 5, ".yaml") != 0) {
    throw std::invalid_argument("--out must name a .yaml file, got '" + out + "'");
  }
  if (!descriptors.empty() && !describer_flag.empty()) {
    throw std::invalid_argument(describer_flag +
                                " describes images: it goes with --images, not --descriptors");
  }
  ReferenceSet set;
  std::vector<std::string> blind;  // per image, BlindImageProblem
  if (!images.empty()) {
    ValidateImageDescriberOptions(describer);
    set = tools::DescribeImageFolderAsSet(images, name, *MakeImageDescriber(describer), &blind);
  } else {
    set = LoadReferenceSetNpy(descriptors, name);
  }
  set.condition = condition;
  set.distance = distance;
  tools::CreateParentFolders(out);
  SaveReferenceSet(set, out);
  std::cout << "bsf_make_reference: wrote " << out << " (" << set.size() << " places, dimension "
            << set.dimension();
  if (!set.descriptor_type.empty()) std::cout << ", " << set.descriptor_type;
  std::cout << ")\n";
  const auto first = std::find_if(blind.begin(), blind.end(), [](auto& b) { return !b.empty(); });
  if (first != blind.end()) {  // written all the same: the user may want the rows as they are
    const size_t row = static_cast<size_t>(first - blind.begin());
    std::cerr << "bsf_make_reference: warning: "
              << std::count_if(blind.begin(), blind.end(), [](auto& b) { return !b.empty(); })
              << " of the " << blind.size()
              << " images show nothing (first: " << set.image_files[row] << ", which " << *first
              << "): their places are described by noise; remove those frames\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return bsf_vpr::tools::RunTool("bsf_make_reference", Run, argc, argv);
}
