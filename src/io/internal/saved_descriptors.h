// How SaveReferenceSet names a set's descriptor file (private header of bsf_vpr_io): by
// its content, so that the new .npy never overwrites the old one the YAML still names.
#pragma once

#include <string>

namespace bsf_vpr {

// `<stem>.<h>.npy`, h the first 12 hex digits (lower case) of the FNV-1a 64-bit hash of
// `npy_bytes` (the whole file). `stem` is the YAML's path without ".yaml".
std::string SavedDescriptorPath(const std::string& stem, const std::string& npy_bytes);

// 16 hex digits naming `bytes` by their content (FNV-1a, 64 bits): what a save's journal
// holds of the YAML it is about to write, to tell at the next start whether it was written.
std::string ContentDigest(const std::string& bytes);

// Whether `file_name` (without folders) has the form SavedDescriptorPath gives:
// a non-empty stem, a dot, 12 lower-case hex digits, ".npy".
bool HasSavedDescriptorName(const std::string& file_name);

// Whether `bytes` are what SavedDescriptorPath named `file_name` for (its hash is the
// name's): the file is a save's own writing, not a file that only looks like one.
bool IsSavedDescriptorFile(const std::string& file_name, const std::string& bytes);

}  // namespace bsf_vpr
