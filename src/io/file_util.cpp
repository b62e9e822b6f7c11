#include "bsf_vpr/io/file_util.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>

#include "bsf_vpr/io/data_directory.h"
#include "src/io/internal/posix_file.h"

namespace bsf_vpr {

void WriteFileAtomically(const std::string& path, const std::string& bytes) {
  // The folder must exist; the file is written below its handle like any data-directory
  // write (temporary name, fsync, rename).
  DataDirectory(DirName(path)).WriteAtomically(BaseName(path), bytes);
}

namespace {

std::string TooLargeMessage(const std::string& name, uint64_t size, uint64_t max_bytes) {
  return QuotedForMessage(name) + " is " + std::to_string(size) + " bytes, more than the " +
         std::to_string(max_bytes) + " allowed";
}

}  // namespace

int WriteAll(int fd, const std::string& bytes) {
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return errno;
    written += static_cast<size_t>(n);
  }
  return 0;
}

std::string RandomChars(size_t n) {
  std::random_device device;
  static const char kChars[] = "abcdefghijklmnopqrstuvwxyz0123456789";
  std::string s(n, 'x');
  for (char& c : s) c = kChars[device() % (sizeof(kChars) - 1)];
  return s;
}

// The size of the regular file open at `fd`; throws std::runtime_error naming `name` when
// it cannot be inspected or is a folder, FIFO, socket or device.
uint64_t RegularFileSize(int fd, const std::string& name) {
  struct stat st;
  if (fstat(fd, &st) != 0) {
    throw std::runtime_error("cannot inspect " + QuotedForMessage(name) + ": " +
                             std::strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) {
    throw std::runtime_error(QuotedForMessage(name) +
                             " is not a regular file (a folder, FIFO, socket or device)");
  }
  return static_cast<uint64_t>(st.st_size);
}

std::string ReadRegularFile(int fd, const std::string& name, uint64_t max_bytes) {
  const uint64_t size = RegularFileSize(fd, name);
  if (size > max_bytes) throw std::runtime_error(TooLargeMessage(name, size, max_bytes));
  // At most the size seen: a file that grows while being read is cut there.
  std::string bytes(static_cast<size_t>(size), '\0');
  size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n = read(fd, bytes.data() + got, bytes.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      throw std::runtime_error("cannot read " + QuotedForMessage(name) + ": " +
                               std::strerror(errno));
    }
    if (n == 0) break;  // shrank while being read
    got += static_cast<size_t>(n);
  }
  bytes.resize(got);
  return bytes;
}

std::shared_ptr<const MappedFile> MapRegularFile(int fd, const std::string& name) {
  const size_t size = static_cast<size_t>(RegularFileSize(fd, name));
  if (size == 0) return std::make_shared<const MappedFile>();
  void* at = mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
  if (at == MAP_FAILED) {
    throw std::runtime_error("cannot map " + QuotedForMessage(name) +
                             " into memory: " + std::strerror(errno));
  }
  auto* file = new MappedFile{static_cast<const char*>(at), size};
  return std::shared_ptr<const MappedFile>(file, [](const MappedFile* f) {
    munmap(const_cast<char*>(f->data), f->size);
    delete f;
  });
}

std::shared_ptr<const MappedFile> MapFile(const std::string& path) {
  const Fd fd(open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY));
  if (fd.get() < 0) {
    throw std::runtime_error("cannot open '" + path + "': " + std::strerror(errno));
  }
  return MapRegularFile(fd.get(), path);
}

std::string ReadFile(const std::string& path, uint64_t max_bytes) {
  // Non-blocking, so that a FIFO cannot hang the reader; only regular files are read.
  const Fd fd(open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY));
  if (fd.get() < 0) {
    throw std::runtime_error("cannot open '" + path + "': " + std::strerror(errno));
  }
  return ReadRegularFile(fd.get(), path, max_bytes);
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

std::string BaseName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
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

bool IsImageFileName(const std::string& name) {
  std::string ext = std::filesystem::path(name).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".pgm" ||
         ext == ".ppm";
}

std::vector<std::string> ListFileNames(const std::string& folder) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw std::runtime_error("'" + folder + "' is not a folder");
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    if (entry.is_regular_file()) names.push_back(entry.path().filename().string());
  }
  if (ec) throw std::runtime_error("cannot list '" + folder + "': " + ec.message());
  std::sort(names.begin(), names.end());
  return names;
}

std::vector<std::string> ListImageFiles(const std::string& folder) {
  std::vector<std::string> files;
  for (const std::string& name : ListFileNames(folder)) {
    if (IsImageFileName(name)) files.push_back((std::filesystem::path(folder) / name).string());
  }
  if (files.empty()) throw std::runtime_error("folder '" + folder + "' holds no image files");
  return files;
}

}  // namespace bsf_vpr
