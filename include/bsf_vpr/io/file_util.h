// Small file helpers shared by the writers of the core.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace bsf_vpr {

// Writes `bytes` to `path` atomically: the data goes to a temporary file in the same folder,
// is flushed, and is renamed over `path`, so a reader sees either the old file or the new
// one, never a partial one. Throws std::runtime_error naming the path on any failure (and
// removes the temporary file).
void WriteFileAtomically(const std::string& path, const std::string& bytes);

// Reads a whole file. Throws std::runtime_error naming the path if it cannot be read or is
// larger than `max_bytes` (checked before anything is read).
std::string ReadFile(const std::string& path,
                     uint64_t max_bytes = std::numeric_limits<uint64_t>::max());

// A regular file mapped read-only into memory: `size` bytes at `data`, unmapped when the
// last pointer to it goes. The pages are read from the file when first touched and may be
// dropped again by the kernel under memory pressure (the page cache holds them). A file
// replaced by a rename (as every writer of bsf_vpr replaces files) keeps its old pages for
// the mapping; a file truncated in place by another program would fault on access (SIGBUS):
// the data directory's files are never rewritten in place.
struct MappedFile {
  const char* data = nullptr;
  size_t size = 0;
};

// Maps the regular file at `path`. Throws std::runtime_error naming it if it cannot be
// opened or mapped, or is not a regular file.
std::shared_ptr<const MappedFile> MapFile(const std::string& path);

// Creates `dir` and its missing parents (mode 0755). Throws std::runtime_error naming the
// folder on failure, or when `dir` exists and is not a folder.
void MakeDirectories(const std::string& dir);

// The file-name part of `path` (all of it when it has no '/').
std::string BaseName(const std::string& path);

// The folder part of `path` ("." when it has none).
std::string DirName(const std::string& path);

// `path` unchanged if absolute, else joined to `base_dir`.
std::string ResolvePath(const std::string& base_dir, const std::string& path);

// Whether a file name has an image extension: .png .jpg .jpeg .bmp .pgm .ppm, in any case.
bool IsImageFileName(const std::string& name);

// The names of the regular files (or links to them) in `folder`, sorted. Throws
// std::runtime_error naming the folder if it is not a folder or cannot be read.
std::vector<std::string> ListFileNames(const std::string& folder);

// The image files of ListFileNames(folder) (IsImageFileName), as `folder`/name, sorted by
// name. Throws std::runtime_error if the folder cannot be read or holds no image.
std::vector<std::string> ListImageFiles(const std::string& folder);

}  // namespace bsf_vpr
