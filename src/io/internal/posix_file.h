// File-descriptor helpers shared by file_util.cpp and data_directory.cpp (private header).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <limits>
#include <string>

#include "bsf_vpr/io/file_util.h"

namespace bsf_vpr {

// Closes a descriptor when it goes out of scope.
class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  Fd(Fd&& o) noexcept : fd_(o.fd_) { o.fd_ = -1; }
  Fd& operator=(Fd&& o) noexcept {
    if (this != &o) {
      if (fd_ >= 0) close(fd_);
      fd_ = o.fd_;
      o.fd_ = -1;
    }
    return *this;
  }
  int get() const { return fd_; }
  // Gives the descriptor up without closing it.
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_;
};

// Writes all of `bytes` to `fd` (retrying on EINTR). Returns 0, or the errno that stopped it.
int WriteAll(int fd, const std::string& bytes);

// `n` random letters and digits for a file name of its own (temporaries, journals, a save's
// image folder), drawn afresh each call: a generator seeded once would give a process forked
// from this one, or from its parent, the same names.
std::string RandomChars(size_t n);

// The bytes of the file open as `fd` (opened non-blocking), which must be a regular file.
// Throws std::runtime_error naming `name` if it is a folder, FIFO, socket or device, is
// larger than `max_bytes` (checked before anything is read, and again while reading), or
// cannot be read.
std::string ReadRegularFile(int fd, const std::string& name,
                            uint64_t max_bytes = std::numeric_limits<uint64_t>::max());

// Maps the regular file open at `fd` read-only (MapFile's rules; `name` in messages).
std::shared_ptr<const MappedFile> MapRegularFile(int fd, const std::string& name);

}  // namespace bsf_vpr
