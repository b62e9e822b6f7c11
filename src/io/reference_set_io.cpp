#include "bsf_vpr/io/reference_set_io.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <numeric>
#include <optional>
#include <set>
#include <stdexcept>
#include <string_view>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"
#include "src/io/internal/posix_file.h"
#include "src/io/internal/set_files.h"
#include "src/io/internal/save_journal.h"
#include "src/io/internal/saved_descriptors.h"

namespace bsf_vpr {
namespace internal {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// `path` made absolute and lexically normal, without a trailing '/'.
std::string AbsoluteFolder(const std::string& path) {
  std::filesystem::path p = std::filesystem::absolute(path).lexically_normal();
  if (!p.has_filename() && p != p.root_path()) p = p.parent_path();
  return p.string();
}

std::string ResolveBelow(const DataDirectory& dir, const std::string& yaml,
                         const std::string& field) {
  return dir.Relative(!field.empty() && field[0] == '/' ? field : DirName(yaml) + "/" + field);
}

}  // namespace internal

namespace {

using internal::AbsoluteFolder;
using internal::EndsWith;

// Throws std::runtime_error with SetNameProblem's answer for `name`, if any.
void CheckName(const std::string& name) {
  const std::string problem = SetNameProblem(name);
  if (!problem.empty()) throw std::runtime_error(problem);
}

// Throws std::runtime_error with SetNameProblem's answer for `name`, a name the caller gave
// for the file at `path`: the name is at fault, not the file.
void CheckGivenName(const std::string& name, const std::string& path) {
  const std::string problem = SetNameProblem(name);
  if (!problem.empty()) {
    throw std::runtime_error("the name given for " + QuotedForMessage(path) +
                             " is refused: " + problem);
  }
}

// Where the files of a reference set come from: the file system as the caller sees it
// (command-line tools, the node's start-up configuration), or a data directory that no
// request may leave (the node's services).
struct FileAccess {
  // The path of the file (or folder) that `field` (a path in a YAML) names, relative to
  // `yaml_path`.
  std::function<std::string(const std::string& yaml_path, const std::string& field)> resolve;
  std::function<std::string(const std::string& path)> read;
  std::function<std::shared_ptr<const MappedFile>(const std::string& path)> map;
  // The names of the regular files in the folder at `path` (from resolve), sorted.
  std::function<std::vector<std::string>(const std::string& path)> list;
  // The folder at `path` (from resolve) as the absolute path ReferenceSet::images holds.
  std::function<std::string(const std::string& path)> absolute;
  bool confined = false;  // below a data directory (Below)
};

FileAccess Unconfined() {
  return {[](const std::string& yaml, const std::string& field) {
            return ResolvePath(DirName(yaml), field);
          },
          [](const std::string& path) { return ReadFile(path); },
          [](const std::string& path) { return MapFile(path); },
          [](const std::string& path) { return ListFileNames(path); },
          [](const std::string& path) { return AbsoluteFolder(path); }};
}

FileAccess Below(const DataDirectory& dir) {
  return {[&dir](const std::string& yaml, const std::string& field) {
            return internal::ResolveBelow(dir, yaml, field);
          },
          [&dir](const std::string& path) { return dir.Read(path); },
          [&dir](const std::string& path) { return dir.Map(path); },
          [&dir](const std::string& path) { return dir.ListFiles(path); },
          [&dir](const std::string& path) {
            return (dir.path() == "/" ? "" : dir.path()) + "/" + path;
          },
          /*confined=*/true};
}

// Refuses a header of no descriptors, or of too many rows for an int place index.
void CheckDescriptorShape(const NpyHeader& h, const std::string& npy_path) {
  if (h.rows == 0 || h.cols == 0) {
    throw std::runtime_error("'" + npy_path + "' holds no descriptors (shape " +
                             std::to_string(h.rows) + " x " + std::to_string(h.cols) + ")");
  }
  if (h.rows > kMaxPlaces || h.cols > kMaxDimension) {
    throw std::runtime_error("'" + npy_path + "' has shape " + std::to_string(h.rows) + " x " +
                             std::to_string(h.cols) + ": at most " + std::to_string(kMaxPlaces) +
                             " rows (places) and " + std::to_string(kMaxDimension) +
                             " columns (dimension) are accepted");
  }
}

// The storage precision an .npy's dtype holds rows at, if any.
std::optional<StoragePrecision> PrecisionOf(NpyDtype dtype) {
  switch (dtype) {
    case NpyDtype::kFloat32:
      return StoragePrecision::kFloat32;
    case NpyDtype::kFloat16:
      return StoragePrecision::kFloat16;
    case NpyDtype::kInt8:
      return StoragePrecision::kInt8;
    default:
      return std::nullopt;
  }
}

// A set's descriptors: read into memory, or memory-mapped where options.memory_map asks for
// them at the precision the file holds them at. `scale` is the YAML's descriptor_scale, which
// an int8 file needs (its elements stand for scale x value).
struct Descriptors {
  RowMatrixXf matrix;
  std::optional<EncodedRows> encoded;
};

Descriptors ReadDescriptors(const FileAccess& files, const std::string& npy_path,
                            const ReadSetOptions& options, std::optional<float> scale) {
  Descriptors out;
  if (options.memory_map) {
    std::shared_ptr<const MappedFile> file = files.map(npy_path);
    const NpyHeader h = ParseNpyHeader(std::string_view(file->data, file->size), npy_path);
    CheckDescriptorShape(h, npy_path);
    if (PrecisionOf(h.dtype) == options.memory_map && !h.fortran_order) {
      if (h.dtype == NpyDtype::kInt8 && !scale) {
        throw std::runtime_error("'" + npy_path +
                                 "' holds int8 descriptors but the set gives no descriptor_scale");
      }
      EncodedRows rows;
      rows.precision = *options.memory_map;
      rows.rows = h.rows;
      rows.cols = h.cols;
      rows.scale = h.dtype == NpyDtype::kInt8 ? *scale : 1.0f;
      rows.data = file->data + h.data_offset;
      rows.source = QuotedForMessage(npy_path) + ", memory-mapped";
      rows.changed = [file] { return file->Changed(); };
      rows.owner = std::move(file);
      out.encoded = std::move(rows);
      return out;
    }
    // Not at the precision asked for (or in Fortran order): read as below.
  }
  const std::string bytes = files.read(npy_path);
  const NpyHeader h = ParseNpyHeader(bytes, npy_path);
  CheckDescriptorShape(h, npy_path);
  if (h.dtype == NpyDtype::kInt8) {
    if (!scale) {
      throw std::runtime_error("'" + npy_path +
                               "' holds int8 descriptors: only a set's YAML that gives their "
                               "descriptor_scale can load it");
    }
    // Decoded as a map holding them at int8 decodes them: scale x value.
    const int8_t* levels = reinterpret_cast<const int8_t*>(bytes.data() + h.data_offset);
    out.matrix.resize(h.rows, h.cols);
    for (int64_t r = 0; r < h.rows; ++r) {
      for (int64_t c = 0; c < h.cols; ++c) {
        const int64_t at = h.fortran_order ? c * h.rows + r : r * h.cols + c;
        out.matrix(r, c) = *scale * static_cast<float>(levels[at]);
      }
    }
    return out;
  }
  out.matrix = DecodeNpyMatrix(bytes, npy_path);
  return out;
}

// A set of `descriptors` whose row k is place k.
ReferenceSet MakeSetOf(const std::string& name, Descriptors descriptors) {
  if (!descriptors.encoded) return MakeReferenceSet(name, std::move(descriptors.matrix));
  ReferenceSet set = MakeReferenceSet(name, RowMatrixXf());
  set.place_ids.resize(static_cast<size_t>(descriptors.encoded->rows));
  std::iota(set.place_ids.begin(), set.place_ids.end(), 0);
  set.encoded = std::move(descriptors.encoded);
  return set;
}

// Refuses the first of `names` (paths relative to the folder at `folder`, from
// files.resolve; `field` as the YAML names it) that is not a regular file there. Each folder
// the names lie in is listed once.
void CheckImageFilesExist(const FileAccess& files, const std::string& folder,
                          const std::string& field, const std::vector<std::string>& names) {
  std::map<std::string, std::vector<std::string>> listed = {{"", files.list(folder)}};
  for (size_t k = 0; k < names.size(); ++k) {
    if (names[k].empty()) continue;  // the row has no image
    const size_t slash = names[k].rfind('/');
    const std::string sub = slash == std::string::npos ? "" : names[k].substr(0, slash);
    auto it = listed.find(sub);
    if (it == listed.end()) {
      std::vector<std::string> in_sub;
      try {
        in_sub = files.list(folder + "/" + sub);
      } catch (const std::exception&) {
        // No such folder (or one that cannot be listed): the file is not there.
      }
      it = listed.emplace(sub, std::move(in_sub)).first;
    }
    const std::string base = slash == std::string::npos ? names[k] : names[k].substr(slash + 1);
    if (!std::binary_search(it->second.begin(), it->second.end(), base)) {
      throw std::runtime_error("image_files[" + std::to_string(k) + "] " +
                               QuotedForMessage(names[k]) + " is not a file in images " +
                               QuotedForMessage(field));
    }
  }
}

// The `images` folder and `image_files` of a sidecar, checked against the set's rows and
// the folder's files; nothing when the YAML has no `images`.
void ParseImages(const YAML::Node& root, const std::string& yaml_path, const FileAccess& files,
                 ReferenceSet* set) {
  if (!root["images"]) {
    if (root["image_files"]) {
      throw std::runtime_error("'image_files' needs 'images', the folder they lie in");
    }
    return;
  }
  const std::string field = root["images"].as<std::string>();
  if (field.empty()) throw std::runtime_error("'images' is empty");
  std::string folder;
  std::vector<std::string> names;
  try {
    try {
      folder = files.resolve(yaml_path, field);
    } catch (const std::invalid_argument&) {
      // A set loaded through a data directory whose images lie outside it (bsf_import
      // writes the YAML there and names the dataset's frames): its descriptors are
      // loaded, its images are not read.
      if (files.confined) return;
      throw;
    }
    if (root["image_files"]) {
      const YAML::Node list = root["image_files"];
      if (!list.IsSequence()) throw std::runtime_error("'image_files' is not a list");
      if (list.size() != static_cast<size_t>(set->size())) {
        throw std::runtime_error("'image_files' lists " + std::to_string(list.size()) +
                                 " files for " + std::to_string(set->size()) + " descriptors");
      }
      names = list.as<std::vector<std::string>>();
      for (size_t k = 0; k < names.size(); ++k) {
        const std::string problem = ImageFileProblem(names[k]);
        if (!problem.empty()) {
          throw std::runtime_error("image_files[" + std::to_string(k) + "] " + problem);
        }
      }
      CheckImageFilesExist(files, folder, field, names);
    } else {
      // Row k is the k-th image of the folder in name order, as ListImageFiles lists them.
      for (std::string& name : files.list(folder)) {
        if (IsImageFileName(name)) names.push_back(std::move(name));
      }
      if (names.size() != static_cast<size_t>(set->size())) {
        throw std::runtime_error(QuotedForMessage(field) + " holds " +
                                 std::to_string(names.size()) + " image files for " +
                                 std::to_string(set->size()) +
                                 " descriptors; list each row's file with image_files");
      }
    }
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("images: ") + e.what());
  }
  set->images = files.absolute(folder);
  set->image_files = std::move(names);
}

ReferenceSet ParseSidecar(const YAML::Node& root, const std::string& yaml_path,
                          const FileAccess& files, const ReadSetOptions& options) {
  if (!root.IsMap()) throw std::runtime_error("is not a YAML mapping");
  static const std::set<std::string> kKnown = {
      "name",      "condition", "descriptor_type", "dimension",   "distance",        "descriptors",
      "place_ids", "poses",     "images",          "image_files", "descriptor_scale"};
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (!kKnown.count(key)) throw std::runtime_error("unknown key " + QuotedForMessage(key));
  }
  if (!root["name"]) throw std::runtime_error("missing required key 'name'");
  if (!root["descriptors"]) throw std::runtime_error("missing required key 'descriptors'");
  const std::string npy = files.resolve(yaml_path, root["descriptors"].as<std::string>());
  CheckName(root["name"].as<std::string>());
  std::optional<float> scale;
  if (root["descriptor_scale"]) {
    scale = root["descriptor_scale"].as<float>();
    if (!(*scale > 0) || !std::isfinite(*scale)) {
      throw std::runtime_error("'descriptor_scale' must be a positive number, got " +
                               root["descriptor_scale"].as<std::string>());
    }
    if (*scale < kMinInt8Scale) {
      throw std::runtime_error("'descriptor_scale' " + root["descriptor_scale"].as<std::string>() +
                               " is too small: the int8 rows would decode to (nearly) zero, "
                               "their squared norms underflowing float; the smallest is 1.0842022e-19");
    }
  }
  ReferenceSet set =
      MakeSetOf(root["name"].as<std::string>(), ReadDescriptors(files, npy, options, scale));
  if (root["condition"]) set.condition = root["condition"].as<std::string>();
  if (root["descriptor_type"]) set.descriptor_type = root["descriptor_type"].as<std::string>();
  if (root["distance"]) {
    set.distance = root["distance"].as<std::string>();
    ParseDistanceMetric(set.distance);  // refuses unknown names
  }
  if (root["dimension"] && root["dimension"].as<int64_t>() != set.dimension()) {
    throw std::runtime_error("declares dimension " + root["dimension"].as<std::string>() +
                             " but '" + npy + "' has " + std::to_string(set.dimension()) +
                             " columns");
  }
  if (root["place_ids"]) {
    const YAML::Node ids = root["place_ids"];
    if (!ids.IsSequence()) throw std::runtime_error("'place_ids' is not a list");
    if (ids.size() != static_cast<size_t>(set.size())) {
      throw std::runtime_error("lists " + std::to_string(ids.size()) + " place_ids for " +
                               std::to_string(set.size()) + " descriptors");
    }
    set.place_ids = ids.as<std::vector<int>>();
  }
  if (root["poses"]) {
    const YAML::Node poses = root["poses"];
    if (!poses.IsSequence() || poses.size() != static_cast<size_t>(set.size())) {
      throw std::runtime_error("'poses' must list one [x, y, z, yaw] per descriptor (" +
                               std::to_string(set.size()) + ")");
    }
    for (const auto& p : poses) {
      const std::vector<double> v = p.as<std::vector<double>>();
      if (v.size() != 4) throw std::runtime_error("a pose must be [x, y, z, yaw]");
      set.poses.push_back({v[0], v[1], v[2], v[3]});
    }
  }
  ParseImages(root, yaml_path, files, &set);
  set.Validate();
  return set;
}

ReferenceSet LoadYaml(const FileAccess& files, const std::string& yaml_path,
                      const ReadSetOptions& options) {
  const std::string text = files.read(yaml_path);  // names the file when it fails
  try {
    return ParseSidecar(YAML::Load(text), yaml_path, files, options);
  } catch (const std::exception& e) {
    throw std::runtime_error("reference set file '" + yaml_path + "': " + e.what());
  }
}

ReferenceSet LoadNpy(const FileAccess& files, const std::string& npy_path, const std::string& name,
                     const ReadSetOptions& options) {
  CheckGivenName(name, npy_path);
  ReferenceSet set = MakeSetOf(name, ReadDescriptors(files, npy_path, options, std::nullopt));
  try {
    set.Validate();
  } catch (const std::exception& e) {
    throw std::runtime_error("'" + npy_path + "': " + e.what());
  }
  return set;
}

ReferenceSet LoadFile(const FileAccess& files, const std::string& path, const std::string& name,
                      const ReadSetOptions& options) {
  if (EndsWith(path, ".yaml") || EndsWith(path, ".yml")) {
    if (!name.empty()) CheckGivenName(name, path);
    ReferenceSet set = LoadYaml(files, path, options);
    if (!name.empty()) set.name = name;
    return set;
  }
  if (EndsWith(path, ".npy")) return LoadNpy(files, path, name, options);
  files.read(path);  // a missing file is reported as missing
  throw std::runtime_error(QuotedForMessage(path) +
                           " is neither a reference-set .yaml (.yml) nor a descriptor .npy");
}

}  // namespace

std::string SetNameProblem(const std::string& name) {
  const std::string rule = " (a set's name is 1 to " + std::to_string(kMaxSetNameBytes) +
                           " bytes of printable UTF-8, without bidirectional controls or "
                           "invisible characters, and neither starts nor ends with a space)";
  if (name.empty()) return "a reference set needs a non-empty name" + rule;
  if (name.size() > kMaxSetNameBytes) {
    // Shown cut short; the quote says its length.
    return "set name " + QuotedForMessage(name, 40) + " is too long" + rule;
  }
  const std::string unreadable = UnreadableCharacter(name);
  if (!unreadable.empty()) {
    return "set name " + QuotedForMessage(name) + " holds " + unreadable + rule;
  }
  // Spaces at the ends, which a reader cannot see (ASCII and the Unicode spaces: U+00A0,
  // U+1680, U+2000-200A, U+202F, U+205F, U+3000), in UTF-8.
  static const std::vector<std::string> kSpaces = {
      " ",            "\xc2\xa0",     "\xe1\x9a\x80", "\xe2\x80\x80", "\xe2\x80\x81",
      "\xe2\x80\x82", "\xe2\x80\x83", "\xe2\x80\x84", "\xe2\x80\x85", "\xe2\x80\x86",
      "\xe2\x80\x87", "\xe2\x80\x88", "\xe2\x80\x89", "\xe2\x80\x8a", "\xe2\x80\xaf",
      "\xe2\x81\x9f", "\xe3\x80\x80"};
  std::string rest = name;  // without the spaces at its ends
  for (bool trimmed = true; trimmed && !rest.empty();) {
    trimmed = false;
    for (const std::string& space : kSpaces) {
      if (rest.compare(0, space.size(), space) == 0) {
        rest.erase(0, space.size());
        trimmed = true;
      } else if (rest.size() >= space.size() &&
                 rest.compare(rest.size() - space.size(), space.size(), space) == 0) {
        rest.erase(rest.size() - space.size());
        trimmed = true;
      }
    }
  }
  if (rest.empty()) return "set name " + QuotedForMessage(name) + " is only spaces" + rule;
  if (rest != name) {
    return "set name " + QuotedForMessage(name) + " starts or ends with a space" + rule;
  }
  return "";
}

ReferenceSet LoadReferenceSetYaml(const std::string& yaml_path) {
  return LoadYaml(Unconfined(), yaml_path, {});
}

ReferenceSet LoadReferenceSetNpy(const std::string& npy_path, const std::string& name) {
  return LoadNpy(Unconfined(), npy_path, name, {});
}

ReferenceSet LoadReferenceSetFile(const std::string& path, const std::string& name,
                                  const ReadSetOptions& options) {
  return LoadFile(Unconfined(), path, name, options);
}

ReferenceSet LoadReferenceSetFile(const DataDirectory& dir, const std::string& request,
                                  const std::string& name, const ReadSetOptions& options) {
  return LoadFile(Below(dir), dir.Relative(request), name, options);
}


namespace {

std::string ReadImageOfRow(const std::string& name, const std::string& images,
                           const std::vector<std::string>& image_files, int row,
                           const DataDirectory* dir, uint64_t max_bytes) {
  const std::string who = "reference set " + QuotedForMessage(name);
  if (image_files.empty()) throw std::invalid_argument(who + " names no images");
  const int size = static_cast<int>(image_files.size());
  if (row < 0 || row >= size) {
    throw std::invalid_argument(who + " has rows 0.." + std::to_string(size - 1) + ", not " +
                                std::to_string(row));
  }
  if (image_files[static_cast<size_t>(row)].empty()) {
    throw std::invalid_argument(who + " row " + std::to_string(row) +
                                " has no image (its recording kept no camera image for it)");
  }
  const std::string path = images + "/" + image_files[static_cast<size_t>(row)];
  try {
    if (dir != nullptr) {
      const std::string below = dir->path() == "/" ? "/" : dir->path() + "/";
      if (path.compare(0, below.size(), below) == 0) {
        return dir->Read(path.substr(below.size()), max_bytes);
      }
    }
    return ReadFile(path, max_bytes);
  } catch (const std::exception& e) {
    throw std::runtime_error(who + " row " + std::to_string(row) + ": " + e.what());
  }
}

}  // namespace

std::string ReadReferenceImage(const StoredReferenceSet& set, int row, const DataDirectory* dir,
                               uint64_t max_bytes) {
  return ReadImageOfRow(set.name(), set.images(), set.image_files(), row, dir, max_bytes);
}

std::string ReadReferenceImage(const SetLayout& set, int row, const DataDirectory* dir,
                               uint64_t max_bytes) {
  return ReadImageOfRow(set.name, set.images, set.image_files, row, dir, max_bytes);
}

}  // namespace bsf_vpr
