// Small file helpers shared by the writers of the core.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
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
// the mapping. A file another program rewrites in place (cp over it, dd conv=notrunc,
// truncate) changes the mapped bytes: Changed() says so, and the readers check it around
// every read. A read past the end of a file truncated under the mapping, which the kernel
// answers with SIGBUS, does not end the process: the mapping's pages turn to zeros and
// Changed() says the file shrank.
class MappedFile {
 public:
  MappedFile() = default;  // empty: no bytes
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  const char* data = nullptr;
  size_t size = 0;

  // Why the mapped bytes may no longer be those the file held when it was mapped ("" while
  // they are): its size or modification time changed (a write in place), or a read fell past
  // its end. Once said, said for good. One fstat: cheap enough around every read of the rows.
  // Thread-safe.
  std::string Changed() const;

 private:
  friend std::shared_ptr<const MappedFile> MapRegularFile(int fd, const std::string& name);
  std::string name_;
  int fd_ = -1;  // kept open: fstat sees the file mapped, whatever is renamed over its name
  int64_t size_at_map_ = 0, mtime_sec_ = 0, mtime_nsec_ = 0;
  int guard_ = -1;  // its slot among the mappings the SIGBUS handler knows, -1: none
  mutable std::mutex mutex_;
  mutable std::string changed_;  // under mutex_
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
