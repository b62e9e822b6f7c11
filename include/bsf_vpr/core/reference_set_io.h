// The reference-set YAML sidecar: a small text file describing one reference set and
// pointing at its descriptor .npy.
//
//   name: winter                      # required
//   condition: snow                   # optional
//   descriptor_type: patchnorm_64x32_p8  # optional
//   dimension: 2048                   # optional; checked against the .npy when given
//   distance: euclidean               # optional: euclidean | cosine
//   descriptors: winter.npy           # required; relative paths are relative to this file
//   place_ids: [0, 1, 2]              # optional; default 0 .. N_u-1
//   poses: [[x, y, z, yaw], ...]      # optional; one per row, metres and radians
//
// Unknown keys are refused (a misspelt key would otherwise be silently ignored).
#pragma once

#include <string>

#include "bsf_vpr/core/reference_set.h"

namespace bsf_vpr {

// Loads a reference set from a sidecar YAML. Throws std::runtime_error naming the file and
// the problem (missing key, unknown key, unreadable .npy, dimension or count mismatch).
ReferenceSet LoadReferenceSetYaml(const std::string& yaml_path);

// Loads a descriptor .npy as a set named `name` whose row k is place k.
ReferenceSet LoadReferenceSetNpy(const std::string& npy_path, const std::string& name);

// Dispatches on the extension: .yaml/.yml sidecar, or .npy (named `name`). Throws
// std::runtime_error for other paths. (Image folders are described by the caller.)
ReferenceSet LoadReferenceSetFile(const std::string& path, const std::string& name);

// Writes `set` as `yaml_path` plus its descriptors as `<yaml_path without .yaml>.npy` (float32),
// both atomically; the YAML refers to the .npy by its file name.
void SaveReferenceSet(const ReferenceSet& set, const std::string& yaml_path);

}  // namespace bsf_vpr
