#include "bsf_vpr/core/file_util.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace bsf_vpr {

void WriteFileAtomically(const std::string& path, const std::string& bytes) {
  std::string tmp = path + ".tmp.XXXXXX";
  int fd = mkstemp(tmp.data());
  if (fd < 0) {
    throw std::runtime_error("cannot create a temporary file next to '" + path +
                             "': " + std::strerror(errno));
  }
  fchmod(fd, 0644);  // mkstemp creates 0600; a data file is meant to be shared.
  size_t written = 0;
  while (written < bytes.size()) {
    ssize_t n = write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    written += static_cast<size_t>(n);
  }
  const bool ok = written == bytes.size() && fsync(fd) == 0;
  const int saved_errno = errno;
  close(fd);
  if (!ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = ok ? errno : saved_errno;
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot write '" + path + "': " + std::strerror(err));
  }
}

std::string ReadFile(const std::string& path) {
  // Non-blocking, so that a FIFO cannot hang the reader; only regular files are read.
  const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) throw std::runtime_error("cannot open '" + path + "': " + std::strerror(errno));
  const std::unique_ptr<int, void (*)(int*)> closer(new int(fd), [](int* f) {
    close(*f);
    delete f;
  });
  struct stat st;
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    throw std::runtime_error("'" + path + "' is not a regular file (a folder, FIFO or device)");
  }
  std::string bytes(static_cast<size_t>(st.st_size), '\0');
  size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n = read(fd, bytes.data() + got, bytes.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw std::runtime_error("cannot read '" + path + "': " + std::strerror(errno));
    if (n == 0) break;  // shrank while being read
    got += static_cast<size_t>(n);
  }
  bytes.resize(got);
  return bytes;
}

void MakeDirectories(const std::string& dir) {
  std::string partial;
  std::stringstream ss(dir);
  std::string part;
  if (!dir.empty() && dir[0] == '/') partial = "/";
  while (std::getline(ss, part, '/')) {
    if (part.empty()) continue;
    partial += part + "/";
    if (mkdir(partial.c_str(), 0755) != 0 && errno != EEXIST) {
      throw std::runtime_error("cannot create folder '" + partial + "': " + std::strerror(errno));
    }
  }
  struct stat st;
  if (stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    throw std::runtime_error("'" + dir + "' is not a folder");
  }
}

std::string DirName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

std::string ResolvePath(const std::string& base_dir, const std::string& path) {
  if (path.empty() || path[0] == '/') return path;
  return base_dir + "/" + path;
}

std::string ResolveBelowDirectory(const std::string& base_dir, const std::string& path) {
  namespace fs = std::filesystem;
  if (base_dir.empty()) throw std::invalid_argument("no data directory is configured");
  if (path.empty()) throw std::invalid_argument("empty path");
  std::error_code ec;
  const fs::path base = fs::weakly_canonical(fs::absolute(base_dir), ec);
  if (ec) throw std::invalid_argument("cannot resolve data directory '" + base_dir + "'");
  const fs::path joined = fs::path(path).is_absolute() ? fs::path(path) : base / path;
  const fs::path resolved = fs::weakly_canonical(joined, ec);
  if (ec) throw std::invalid_argument("cannot resolve path '" + path + "'");
  const auto mismatch = std::mismatch(base.begin(), base.end(), resolved.begin(), resolved.end());
  if (mismatch.first != base.end() || resolved == base) {
    throw std::invalid_argument("path '" + path + "' lies outside the data directory '" +
                                base.string() + "'");
  }
  return resolved.string();
}

}  // namespace bsf_vpr
