// Saving reference sets: the sidecar YAML, the descriptors and the images, each save with
// its journal (save_journal.h), and which files of a data directory belong to sets.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "src/io/internal/posix_file.h"
#include "src/io/internal/save_journal.h"
#include "src/io/internal/saved_descriptors.h"
#include "src/io/internal/set_files.h"

namespace bsf_vpr {
namespace {

using internal::AbsoluteFolder;
using internal::EndsWith;

// Marks a save's own image folders: "<stem>_images.<8 characters>".
constexpr char kSavedImagesMarker[] = "_images.";

// How a sidecar in `yaml_folder` (absolute, links resolved: a data directory's path) names
// the folder `images`: relative to yaml_folder when it lies below it (or is it), else
// absolute. `images` is compared as given and with its links resolved.
std::string ImagesField(const std::string& images, const std::string& yaml_folder) {
  namespace fs = std::filesystem;
  const std::string absolute = AbsoluteFolder(images);
  std::error_code ec;
  for (const fs::path& p : {fs::path(absolute), fs::weakly_canonical(absolute, ec)}) {
    const fs::path relative = p.lexically_relative(yaml_folder);
    if (!relative.empty() && *relative.begin() != "..") return relative.string();
  }
  return absolute;
}

std::string SidecarText(const ReferenceSet& set, const std::string& npy_name,
                        const std::string& yaml_folder, const std::string& images,
                        const std::vector<std::string>& image_files) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << set.name;
  if (!set.condition.empty()) out << YAML::Key << "condition" << YAML::Value << set.condition;
  if (!set.descriptor_type.empty()) {
    out << YAML::Key << "descriptor_type" << YAML::Value << set.descriptor_type;
  }
  out << YAML::Key << "dimension" << YAML::Value << set.dimension();
  if (!set.distance.empty()) out << YAML::Key << "distance" << YAML::Value << set.distance;
  out << YAML::Key << "descriptors" << YAML::Value << npy_name;
  if (set.encoded && set.encoded->precision == StoragePrecision::kInt8) {
    // Exactly the float the elements are multiplied by (9 significant digits round-trip).
    out << YAML::Key << "descriptor_scale" << YAML::Value << YAML::Precision(9)
        << set.encoded->scale;
  }
  out << YAML::Key << "place_ids" << YAML::Value << YAML::Flow << set.place_ids;
  if (!set.poses.empty()) {
    out << YAML::Key << "poses" << YAML::Value << YAML::BeginSeq;
    for (const PlacePose& p : set.poses) {
      out << YAML::Flow << std::vector<double>{p.x_m, p.y_m, p.z_m, p.yaw_rad};
    }
    out << YAML::EndSeq;
  }
  if (!image_files.empty()) {
    out << YAML::Key << "images" << YAML::Value << ImagesField(images, yaml_folder);
    out << YAML::Key << "image_files" << YAML::Value << YAML::Flow << image_files;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

// A new folder for a save's images: "<stem>_images.<8 characters>", not there yet.
std::string SavedImageFolder(const DataDirectory& dir, const std::string& stem) {
  for (;;) {
    const std::string folder = stem + kSavedImagesMarker + RandomChars(8);
    if (!dir.Exists(folder)) return folder;
  }
}

// Whether `folder` (relative) is a folder SavedImageFolder made for `stem`.
bool IsSavedImageFolder(const std::string& folder, const std::string& stem) {
  const std::string prefix = stem + kSavedImagesMarker;
  return folder.size() == prefix.size() + 8 && folder.compare(0, prefix.size(), prefix) == 0 &&
         folder.find('/', prefix.size()) == std::string::npos;
}

// Row `row`'s image file name, "" for a row without an image: "000042.png" or ".jpg".
std::string SavedImageName(size_t row, const std::string& encoded) {
  if (encoded.empty()) return "";
  char name[32];
  std::snprintf(name, sizeof(name), "%06zu%s", row,
                encoded.size() > 3 && encoded.compare(1, 3, "PNG") == 0 ? ".png" : ".jpg");
  return name;
}

// Adds to *files what the YAML at `yaml` (the set about to be replaced) names that is the
// set's own, made by an earlier save: its descriptors `<stem>.<hash>.npy` and the images in
// a folder SavedImageFolder made. A file a person put there (another name, another folder)
// is never the save's to remove.
void AddReplacedFiles(const DataDirectory& dir, const std::string& yaml, const std::string& stem,
                      SaveFiles* files) {
  YAML::Node old;
  try {
    old = YAML::Load(dir.Read(yaml));
  } catch (const std::exception&) {
    return;  // an unreadable old YAML: what it names stays where it is
  }
  if (!old.IsMap()) return;
  
  try {
    if (old["descriptors"] && old["descriptors"].IsScalar()) {
      const std::string npy = internal::ResolveBelow(dir, yaml, old["descriptors"].as<std::string>());
      // "<stem>.<12 hex digits>.npy": this stem's, not another's that starts with it.
      if (npy != files->descriptors && npy.size() == stem.size() + 1 + 12 + 4 &&
          npy.rfind(stem + ".", 0) == 0 && HasSavedDescriptorName(BaseName(npy))) {
        files->replaced.push_back(npy);
        files->replaced_proofs.push_back(ProofByName());
      }
    }
  } catch (const std::exception&) {
  }
  try {
    if (!old["images"] || !old["images"].IsScalar() || !old["image_files"] ||
        !old["image_files"].IsSequence()) {
      return;
    }
    const std::string folder = internal::ResolveBelow(dir, yaml, old["images"].as<std::string>());
    if (!IsSavedImageFolder(folder, stem)) return;
    for (const YAML::Node& entry : old["image_files"]) {
      const std::string name = entry.as<std::string>();
      if (name.empty() || !ImageFileProblem(name).empty()) continue;
      const std::string image = dir.Relative(folder + "/" + name);
      try {
        // Its bytes now: only these go once the new set is in place.
        const std::string bytes = dir.Read(image);
        files->replaced.push_back(image);
        files->replaced_proofs.push_back(ProofOfContent(bytes));
      } catch (const std::exception&) {
        // Gone or unreadable: nothing of it to remove.
      }
    }
    files->replaced_folders.push_back(folder);
  } catch (const std::exception&) {
  }
}

}  // namespace

void SaveStoredReferenceSet(const StoredReferenceSet& stored, const std::string& yaml_path) {
  if (!EndsWith(yaml_path, ".yaml")) {
    throw std::invalid_argument("a reference set is saved as a .yaml, got " +
                                QuotedForMessage(yaml_path));
  }
  const std::string stem = yaml_path.substr(0, yaml_path.size() - 5);
  static const NpyDtype kDtypes[] = {NpyDtype::kFloat32, NpyDtype::kFloat16, NpyDtype::kInt8};
  const std::string bytes = EncodeNpyBytes(stored.data(), stored.size(), stored.dimension(),
                                           kDtypes[static_cast<int>(stored.precision())]);
  // Named by its content (`<stem>.<precision>.<hash>.npy`), so that it never replaces the
  // file an existing YAML names: the YAML's rename is the one step that replaces the set, and
  // a kill before it leaves the old set whole (its rows and its scale).
  const std::string npy = SavedDescriptorPath(stem + "." + ToString(stored.precision()), bytes);
  std::string replaced;  // the descriptors the YAML named before, if this tool wrote them
  try {
    const YAML::Node old = YAML::Load(ReadFile(yaml_path));
    const std::string named = old["descriptors"] ? old["descriptors"].as<std::string>() : "";
    if (HasSavedDescriptorName(named) && named.find('/') == std::string::npos &&
        named.rfind(BaseName(stem) + ".", 0) == 0) {
      replaced = DirName(yaml_path) + "/" + named;
    }
  } catch (const std::exception&) {
    // No YAML there (or not one of ours): nothing to replace.
  }
  WriteFileAtomically(npy, bytes);
  // The sidecar of the set's metadata, naming the encoded rows just written.
  ReferenceSet meta;
  meta.name = stored.name();
  meta.condition = stored.condition();
  meta.descriptor_type = stored.descriptor_type();
  meta.distance = stored.distance();
  meta.place_ids = stored.place_ids();
  meta.poses = stored.poses();
  EncodedRows rows;
  rows.precision = stored.precision();
  rows.rows = stored.size();
  rows.cols = stored.dimension();
  rows.scale = stored.scale();
  rows.data = stored.data();
  meta.encoded = rows;
  const std::string folder = AbsoluteFolder(DirName(yaml_path));
  WriteFileAtomically(
      yaml_path, SidecarText(meta, BaseName(npy), folder, stored.images(), stored.image_files()));
  // The old rows go once the YAML names the new ones (a map holding them mapped keeps them).
  if (!replaced.empty() && BaseName(replaced) != BaseName(npy)) std::remove(replaced.c_str());
}

void SaveReferenceSet(const ReferenceSet& set, const std::string& yaml_path) {
  const DataDirectory dir(DirName(yaml_path), /*create=*/true);
  SaveReferenceSet(dir, set, BaseName(yaml_path), /*replace=*/true);
}

void SaveReferenceSet(const DataDirectory& dir, const ReferenceSet& set,
                      const std::string& yaml_request, bool replace) {
  SaveOptions options;
  options.replace = replace;
  SaveReferenceSet(dir, set, yaml_request, options);
}

namespace {

// The YAML a save of `set` writes, below `dir`: refused (std::invalid_argument) for a set
// that cannot be saved, a path that is no .yaml, a set in place without `replace`, or
// images that do not match the rows.
std::string CheckedSave(const DataDirectory& dir, const ReferenceSet& set,
                        const std::string& yaml_request, const SaveOptions& options) {
  const std::string name_problem = SetNameProblem(set.name);
  if (!name_problem.empty()) throw std::invalid_argument(name_problem);
  set.Validate();
  if (set.encoded) {
    throw std::invalid_argument("reference set " + QuotedForMessage(set.name) + " is held by " +
                                set.encoded->source + ": its file is the set; copy that");
  }
  std::string yaml = dir.Relative(yaml_request);
  if (!EndsWith(yaml, ".yaml")) {
    throw std::invalid_argument("a reference set is saved as a .yaml, got " +
                                QuotedForMessage(yaml_request));
  }
  if (!options.replace && dir.Exists(yaml)) {
    throw std::invalid_argument(QuotedForMessage(yaml) +
                                " exists already; choose another name (or ask to overwrite)");
  }
  if (options.images && options.images->size() != static_cast<size_t>(set.size())) {
    throw std::invalid_argument("saving " + QuotedForMessage(set.name) + ": " +
                                std::to_string(options.images->size()) + " images for " +
                                std::to_string(set.size()) + " rows");
  }
  return yaml;
}

}  // namespace

SavedImages SaveReferenceSet(const DataDirectory& dir, const ReferenceSet& set,
                             const std::string& yaml_request, const SaveOptions& options) {
  const std::string yaml = CheckedSave(dir, set, yaml_request, options);
  // Every file of the new set gets a name of its own (the descriptors by their content, the
  // images in a new folder), then the YAML that names them is renamed into place: that rename
  // is the one step that replaces the old set by the new one, so an interruption anywhere
  // leaves either the old set or the new one whole, each with its own images. The journal
  // (save_journal.h) lets the next start finish or undo a save that was killed.
  const std::string stem = yaml.substr(0, yaml.size() - 5);
  const std::string bytes = EncodeNpyMatrix(set.descriptors);
  SaveFiles files;
  files.yaml = yaml;
  files.descriptors = SavedDescriptorPath(stem, bytes);
  files.created.push_back(files.descriptors);
  files.created_proofs.push_back(ProofByName());
  std::string image_folder;
  std::vector<std::string> image_files;
  if (options.images && std::any_of(options.images->begin(), options.images->end(),
                                    [](const std::string& image) { return !image.empty(); })) {
    image_folder = SavedImageFolder(dir, stem);
    files.created_folders.push_back(image_folder);
    for (size_t row = 0; row < options.images->size(); ++row) {
      image_files.push_back(SavedImageName(row, (*options.images)[row]));
      if (image_files.back().empty()) continue;
      files.created.push_back(image_folder + "/" + image_files.back());
      files.created_proofs.push_back(ProofOfContent((*options.images)[row]));
    }
  }
  if (dir.Exists(yaml)) AddReplacedFiles(dir, yaml, stem, &files);
  const std::string folder = DirName(yaml) == "." ? dir.path() : dir.path() + "/" + DirName(yaml);
  const std::string text =
      image_folder.empty()
          ? SidecarText(set, BaseName(files.descriptors), folder, set.images, set.image_files)
          : SidecarText(set, BaseName(files.descriptors), folder, dir.path() + "/" + image_folder,
                        image_files);
  files.yaml_digest = ContentDigest(text);
  SaveJournal journal(dir, files);              // nothing is written before it
  std::vector<std::string> made, made_folders;  // for a roll-back: only what this save made
  try {
    if (!image_folder.empty()) {
      dir.CreateFolder(image_folder);  // refuses one that exists: never another's
      made_folders.push_back(image_folder);
      for (size_t row = 0; row < image_files.size(); ++row) {
        if (image_files[row].empty()) continue;
        const std::string image = image_folder + "/" + image_files[row];
        dir.WriteAtomically(image, (*options.images)[row], /*replace=*/false);
        made.push_back(image);  // (a write that fails leaves nothing)
      }
    }
    dir.WriteAtomically(files.descriptors, bytes);
    made.push_back(files.descriptors);
    dir.WriteAtomically(yaml, text, options.replace);
  } catch (...) {
    journal.RollBack(made, made_folders);
    throw;
  }
  journal.Finish(options.keep);
  SavedImages saved;
  if (!image_folder.empty()) {
    saved.images = dir.path() + "/" + image_folder;
    saved.image_files = std::move(image_files);
  }
  return saved;
}

std::set<std::string> FilesOfReferenceSets(const DataDirectory& dir,
                                           const std::vector<std::string>& paths) {
  std::set<std::string> below;
  const auto add = [&](const std::string& path) {
    std::error_code ec;
    std::string absolute = std::filesystem::weakly_canonical(AbsoluteFolder(path), ec).string();
    if (ec) absolute = AbsoluteFolder(path);
    try {
      below.insert(dir.Relative(absolute));
    } catch (const std::invalid_argument&) {
      // Outside the directory: no save below it can remove it.
    }
  };
  for (const std::string& path : paths) {
    add(path);
    if (!EndsWith(path, ".yaml") && !EndsWith(path, ".yml")) continue;
    try {
      const YAML::Node root = YAML::Load(ReadFile(path));
      if (!root.IsMap()) continue;
      if (root["descriptors"] && root["descriptors"].IsScalar()) {
        add(ResolvePath(DirName(path), root["descriptors"].as<std::string>()));
      }
      if (root["images"] && root["images"].IsScalar()) {
        // The folder: every file in it is the set's (NamedFiles::Names).
        add(ResolvePath(DirName(path), root["images"].as<std::string>()));
      }
    } catch (const std::exception&) {
      // Unreadable: the set does not load either; its file itself is kept.
    }
  }
  return below;
}

}  // namespace bsf_vpr
