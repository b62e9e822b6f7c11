// The reference-set YAML sidecar: a small text file describing one reference set and
// pointing at its descriptor .npy.
//
//   name: winter                      # required; SetNameProblem (below) says the rule
//   condition: snow                   # optional
//   descriptor_type: patchnorm_64x32_p8  # optional
//   dimension: 2048                   # optional; checked against the .npy when given
//   distance: euclidean               # optional: euclidean | cosine
//   descriptors: winter.npy           # required; relative paths are relative to this file
//                                     # (saving names it winter.<content hash>.npy); float
//                                     # (float16/32/64) or int8 with descriptor_scale
//   descriptor_scale: 0.0021          # only for an int8 .npy: element = scale x value (as
//                                     # bsf_store_set writes a set held at int8)
//   place_ids: [0, 1, 2]              # optional; default 0 .. N_u-1
//   poses: [[x, y, z, yaw], ...]      # optional; one per row, metres and radians, finite,
//                                     # |x|, |y|, |z| <= kMaxPoseCoordinateM (place_layout.h)
//   images: winter_images             # optional: the folder of the rows' images, relative
//                                     # to this file (or absolute); row k shows the k-th
//                                     # image file of the folder in name order
//                                     # (ListImageFiles' order), which must hold one per row
//   image_files: [a.png, b/c.png]     # optional, only with images: one file per row,
//                                     # relative to images (no absolute path, no '..'), for
//                                     # sets whose rows are not the folder's images in order;
//                                     # "" for a row that has no image
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
#include <optional>
#include <set>
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

// How a set's descriptors are brought in.
struct ReadSetOptions {
  // Memory-map the descriptor .npy instead of reading it when it holds them row-major (C
  // order) at this precision (float32 '<f4', float16 '<f2', or int8 '|i1' with the YAML's
  // descriptor_scale): the set (ReferenceSet::encoded) then costs its place ids and norms, not
  // its bytes, and the page cache holds what is read of it. A file at another precision, or
  // in Fortran order, is read as without it. nullopt: always read.
  std::optional<StoragePrecision> memory_map;
};

// Dispatches on the extension: .yaml/.yml sidecar, or .npy (named `name`). Throws
// std::runtime_error for other paths (saying so, or that the file is missing).
ReferenceSet LoadReferenceSetFile(const std::string& path, const std::string& name,
                                  const ReadSetOptions& options = {});

// The same, for a request (relative, or absolute below dir.path()) from the outside world:
// the YAML, the .npy and the images folder it names are read through `dir`
// (DataDirectory::Read, ListFiles), so none may lie outside it, be reached through a link,
// or be anything but a regular file (a folder for images); links among the images are not
// listed. The set's `images` is then dir.path() + "/" + the folder's relative path.
ReferenceSet LoadReferenceSetFile(const DataDirectory& dir, const std::string& request,
                                  const std::string& name, const ReadSetOptions& options = {});

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
// beside it, which the YAML names. The set is replaced as one: every new file is written
// under a name of its own first (the descriptors by their content, images in a new folder),
// then the YAML is renamed into place, then the old set's own files are removed; an
// interruption leaves the old set or the new one whole, each with its own images, and the
// save's journal lets the next start finish or undo it (RecoverInterruptedSaves). Missing
// folders are created. A set with images names its folder relative to the YAML's folder
// when it lies below it (or is it), else absolute, and lists image_files explicitly.
// Throws std::invalid_argument for an invalid set
// (ReferenceSet::Validate, SetNameProblem), std::runtime_error naming the file when writing
// fails (nothing is replaced then, and nothing the save wrote is left). A set a map holds is
// saved from StoredReferenceSet::ToReferenceSet(), which refuses one held at reduced
// precision only.
void SaveReferenceSet(const ReferenceSet& set, const std::string& yaml_path);

// Writes a set as a map holds it (`set.precision()`: float32, float16, or int8 with its
// descriptor_scale), for memory-mapping (ReadSetOptions::memory_map):
// `<stem>.<precision>.<content hash>.npy` beside `yaml_path`, then the YAML naming it, each
// atomically; the YAML's rename replaces an existing set as one (a kill before it leaves the
// old set whole), and the old set's rows, if this function wrote them, are removed after it.
// For the command line (bsf_store_set); the node's saves go through SaveReferenceSet. Throws
// std::invalid_argument for a path not ending in .yaml, std::runtime_error naming the file
// when writing fails.
void SaveStoredReferenceSet(const StoredReferenceSet& set, const std::string& yaml_path);

struct SaveOptions {
  // Whether an existing YAML is replaced (never, when false).
  bool replace = false;
  // One encoded image (PNG or JPEG bytes) per row of the set, "" for a row without one:
  // written to a new folder of this save's own, `<stem>_images.<8 characters>`, as
  // `<row, 6 digits>.png` or `.jpg`, and named in the YAML instead of the set's own images
  // (rows without one get an empty image_files entry). Null: the set's images as they are.
  const std::vector<std::string>* images = nullptr;
  // Files (relative to the directory) that are never removed as the replaced set's: the
  // caller's configured sets.
  std::set<std::string> keep;
};

// The same below a data directory (`yaml_request` as for DataDirectory::Relative, ending
// in .yaml). Replacing a set removes what was its own: its descriptors if the save named
// them (`<stem>.<hash>.npy`) and its images if a save wrote them (`<stem>_images.<...>`),
// each only when no YAML below `dir` and no file of options.keep names it.
void SaveReferenceSet(const DataDirectory& dir, const ReferenceSet& set,
                      const std::string& yaml_request, bool replace);
// Returns where the images of options.images went (ReferenceSet::images, absolute, and
// image_files), for the caller's copy of the set; both empty when none was given.
struct SavedImages {
  std::string images;
  std::vector<std::string> image_files;
};
SavedImages SaveReferenceSet(const DataDirectory& dir, const ReferenceSet& set,
                             const std::string& yaml_request, const SaveOptions& options);

// The files below `dir` (relative paths) that the sets at `paths` (absolute: configured .npy
// or .yaml files, wherever they lie) consist of: each file itself and, for a YAML, the
// descriptors and images it names. For SaveOptions::keep and RecoverInterruptedSaves: a
// configured set's files are never removed, even when no YAML below `dir` names them. A
// YAML that cannot be read adds only itself.
std::set<std::string> FilesOfReferenceSets(const DataDirectory& dir,
                                           const std::vector<std::string>& paths);

// Finishes or undoes the saves (SaveReferenceSet) that a killed process left below `dir`,
// by their journals: where the new YAML is in place, the files of the set it replaced go;
// where it is not, the files the save had written go (and the half-written copies its
// writes left), and the old set is as it was. A file goes only when a complete journal of
// this version lists it, its bytes are still those the journal proves (the hash in a saved
// .npy's name, or the digest the journal holds), and neither a YAML below `dir` nor `keep`
// (relative paths: the configured sets' files) names it. A file found lying around is never
// removed, whatever its name; a file with a journal's name that is no such journal (another
// program's, an earlier version's, a hand-made one) is left as it is with every file it
// names. A journal that a running save holds (another process) is left alone. Returns a line
// for each journal, naming every file removed and every listed file kept, for the caller to
// log. If a YAML below `dir` cannot be read (it might name anything), nothing is removed and
// the line says so. Call it at start-up.
std::vector<std::string> RecoverInterruptedSaves(const DataDirectory& dir,
                                                 const std::set<std::string>& keep = {});

}  // namespace bsf_vpr
