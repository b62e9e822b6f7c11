// The reference-set YAML sidecar: a small text file describing one reference set and
// pointing at its descriptor .npy.
//
//   name: winter                      # required; SetNameProblem (below) says the rule
//   condition: snow                   # optional
//   descriptor_type: patchnorm_64x32_p8  # optional
//   dimension: 2048                   # optional; checked against the .npy when given
//   distance: euclidean               # optional: euclidean | cosine
//   descriptors: winter.npy           # required; relative paths are relative to this file
//                                     # (saving names it winter.<content hash>.npy)
//   place_ids: [0, 1, 2]              # optional; default 0 .. N_u-1
//   poses: [[x, y, z, yaw], ...]      # optional; one per row, metres and radians, finite,
//                                     # |x|, |y|, |z| <= kMaxPoseCoordinateM (place_layout.h)
//   images: winter_images             # optional: the folder of the rows' images, relative
//                                     # to this file (or absolute); row k shows the k-th
//                                     # image file of the folder in name order
//                                     # (ListImageFiles' order), which must hold one per row
//   image_files: [a.png, b/c.png]     # optional, only with images: one file per row,
//                                     # relative to images (no absolute path, no '..'), for
//                                     # sets whose rows are not the folder's images in order
//
// Unknown keys are refused (a misspelt key would otherwise be silently ignored). A set whose
// images are wrong (folder missing or not a folder, a count that does not match the rows, a
// listed file that is not a regular file there) is refused whole. Loaded, a set holds
// `images` as an absolute path and one image file per row (ReferenceSet::images,
// image_files).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/io/data_directory.h"

namespace bsf_vpr {

// Longest name of a set, in bytes. A name becomes file names (NAME.yaml beside
// NAME.<12 hex digits>.npy and the folder NAME_images, each within the 255 bytes a file name
// may have) and is shown in every message, diagnostic and service answer about its set:
// 128 bytes leave room for the suffixes and still say what a set is ("route_a/tonight_rain").
constexpr size_t kMaxSetNameBytes = 128;

// Why `name` cannot name a reference set ("" if it can), quoting it safely (QuotedForMessage)
// and saying the rule: a set's name is 1 to kMaxSetNameBytes bytes of printable UTF-8
// (IsPrintableUtf8: no control character, bidirectional control or invisible character)
// that neither starts nor ends with a space (ASCII or Unicode), so it is not only spaces
// either. Every way of naming a set meets it: the YAML's name, a caller's name
// for a file (the loaders below, load_reference_set's request), a saved set and a recording.
std::string SetNameProblem(const std::string& name);

// Loads a reference set from a sidecar YAML. Throws std::runtime_error naming the file and
// the problem (missing key, unknown key, a name SetNameProblem refuses, unreadable .npy,
// dimension or count mismatch, no descriptors). Only regular files are read.
ReferenceSet LoadReferenceSetYaml(const std::string& yaml_path);

// Loads a descriptor .npy as a set named `name` whose row k is place k. `name`, and the name
// given to the functions below when not empty (it replaces a YAML's), must pass
// SetNameProblem: std::runtime_error naming the file otherwise.
ReferenceSet LoadReferenceSetNpy(const std::string& npy_path, const std::string& name);

// Dispatches on the extension: .yaml/.yml sidecar, or .npy (named `name`). Throws
// std::runtime_error for other paths (saying so, or that the file is missing).
ReferenceSet LoadReferenceSetFile(const std::string& path, const std::string& name);

// The same, for a request (relative, or absolute below dir.path()) from the outside world:
// the YAML, the .npy and the images folder it names are read through `dir`
// (DataDirectory::Read, ListFiles), so none may lie outside it, be reached through a link,
// or be anything but a regular file (a folder for images); links among the images are not
// listed. The set's `images` is then dir.path() + "/" + the folder's relative path.
ReferenceSet LoadReferenceSetFile(const DataDirectory& dir, const std::string& request,
                                  const std::string& name);

// The bytes of the image file of row `row` of `set` (images() + "/" + image_files()[row]):
// read through dir->Read when `dir` is given and the file lies below dir->path() (so a link
// there is refused, as for every request), else with ReadFile. Throws
// std::invalid_argument for a set without images or a row outside 0..size()-1, and
// std::runtime_error naming the set, the row and the file when it cannot be read or is
// larger than `max_bytes` (refused before anything is read).
std::string ReadReferenceImage(const StoredReferenceSet& set, int row, const DataDirectory* dir,
                               uint64_t max_bytes = std::numeric_limits<uint64_t>::max());
std::string ReadReferenceImage(const SetLayout& set, int row, const DataDirectory* dir,
                               uint64_t max_bytes = std::numeric_limits<uint64_t>::max());

// Writes `set` as `yaml_path` plus its descriptors (float32) as `<stem>.<content hash>.npy`
// beside it, which the YAML names. The pair is replaced as one: the .npy is written first
// under its new name, then the YAML is renamed into place, then the old .npy (if it was
// this set's) is removed; an interruption leaves the old or the new pair whole. Missing
// folders are created. A set with images names its folder relative to the YAML's folder
// when it lies below it (or is it), else absolute, and lists image_files explicitly.
// Throws std::invalid_argument for an invalid set
// (ReferenceSet::Validate, SetNameProblem), std::runtime_error naming the file when writing
// fails (nothing
// is replaced then). A set a map holds is saved from StoredReferenceSet::ToReferenceSet(),
// which refuses one held at reduced precision only.
void SaveReferenceSet(const ReferenceSet& set, const std::string& yaml_path);

// The same below a data directory (`yaml_request` as for DataDirectory::Relative, ending
// in .yaml). With `replace` false an existing YAML is never replaced.
void SaveReferenceSet(const DataDirectory& dir, const ReferenceSet& set,
                      const std::string& yaml_request, bool replace);

// Removes the descriptor files that interrupted saves left below `dir` and returns their
// paths (relative to dir), for the caller to report each. SaveReferenceSet renames the new
// `<stem>.<hash>.npy` into place before the YAML that names it, and removes the old one
// after: a kill in between leaves a whole .npy that no YAML names, for ever.
// Such a file is removed only when all of these hold, so that no user's file is touched:
//  - its name has the save's form (`<stem>.<12 hex digits>.npy`);
//  - its bytes hash to the digits in its name (the save's own writing, not a file that only
//    looks like one);
//  - no YAML (a regular .yaml or .yml file) anywhere below `dir` names a file of that file
//    name in its `descriptors` (compared by file name alone, whatever folder or spelling the
//    YAML uses, so that a file a YAML names is never taken for an orphan);
//  - it was last written 10 minutes ago or more (a younger one may be the new .npy of a
//    save running in another process, its YAML not renamed yet).
// If a YAML below `dir` cannot be read or parsed, or a folder listed, nothing is removed and
// std::runtime_error names it: what it would name is unknown. A file that cannot be read or
// removed stays. YAMLs outside `dir` are not
// seen. Call it at start-up, before anything saves below `dir` (as RemoveStaleTemporaries):
// a save running meanwhile in another process could lose its new .npy.
std::vector<std::string> RemoveOrphanedDescriptors(const DataDirectory& dir);

}  // namespace bsf_vpr
