#include "bsf_vpr/io/file_util.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
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

namespace {

// The mappings a SIGBUS may fall in: a file truncated under its mapping faults on the pages
// past its new end. Slots are taken and freed under the mutex; the handler reads them lock-free.
struct GuardedRange {
  std::atomic<uintptr_t> begin{0};  // 0: a free slot
  std::atomic<size_t> length{0};
  std::atomic<int> faulted{0};
};
constexpr int kGuardedRanges = 4096;
GuardedRange g_ranges[kGuardedRanges];
std::mutex g_ranges_mutex;
struct sigaction g_previous_bus;

// SIGBUS in a mapping of ours: its pages become zeros (an anonymous mapping in its place) and
// the read goes on; the mapping's Changed() then says the file shrank, and the answer is not
// used. Elsewhere: as the handler before, or the default (the process ends).
void OnBus(int sig, siginfo_t* info, void* context) {
  const uintptr_t at = reinterpret_cast<uintptr_t>(info->si_addr);
  for (GuardedRange& r : g_ranges) {
    const uintptr_t begin = r.begin.load(std::memory_order_acquire);
    const size_t length = r.length.load(std::memory_order_acquire);
    if (begin == 0 || at < begin || at - begin >= length) continue;
    if (mmap(reinterpret_cast<void*>(begin), length, PROT_READ,
             MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED, -1, 0) != MAP_FAILED) {
      r.faulted.store(1, std::memory_order_release);
      return;
    }
    break;
  }
  if ((g_previous_bus.sa_flags & SA_SIGINFO) && g_previous_bus.sa_sigaction != nullptr) {
    g_previous_bus.sa_sigaction(sig, info, context);
  } else if (!(g_previous_bus.sa_flags & SA_SIGINFO) && g_previous_bus.sa_handler != SIG_DFL &&
             g_previous_bus.sa_handler != SIG_IGN) {
    g_previous_bus.sa_handler(sig);
  } else {
    signal(SIGBUS, SIG_DFL);  // the faulting read runs again and ends the process
  }
}

// A slot for [begin, begin + length), or -1 when all are taken (the mapping then goes
// unguarded: a truncation under it would end the process).
int GuardRange(const void* begin, size_t length) {
  static std::once_flag installed;
  std::call_once(installed, [] {
    struct sigaction action {};
    action.sa_sigaction = OnBus;
    action.sa_flags = SA_SIGINFO | SA_NODEFER;
    sigemptyset(&action.sa_mask);
    sigaction(SIGBUS, &action, &g_previous_bus);
  });
  std::lock_guard<std::mutex> lock(g_ranges_mutex);
  for (int i = 0; i < kGuardedRanges; ++i) {
    GuardedRange& r = g_ranges[i];
    if (r.begin.load(std::memory_order_relaxed) != 0) continue;
    r.faulted.store(0, std::memory_order_relaxed);
    r.length.store(length, std::memory_order_release);
    r.begin.store(reinterpret_cast<uintptr_t>(begin), std::memory_order_release);
    return i;
  }
  return -1;
}

void ReleaseRange(int slot) {
  if (slot < 0) return;
  std::lock_guard<std::mutex> lock(g_ranges_mutex);
  g_ranges[slot].begin.store(0, std::memory_order_release);
}

}  // namespace

MappedFile::~MappedFile() {
  ReleaseRange(guard_);
  if (data != nullptr) munmap(const_cast<char*>(data), size);
  if (fd_ >= 0) close(fd_);
}

std::string MappedFile::Changed() const {
  if (fd_ < 0) return "";
  std::lock_guard<std::mutex> lock(mutex_);
  if (!changed_.empty()) return changed_;
  struct stat st;
  if (guard_ >= 0 && g_ranges[guard_].faulted.load(std::memory_order_acquire)) {
    changed_ = "was truncated under its mapping (a read fell past its end)";
  } else if (fstat(fd_, &st) != 0) {
    changed_ = std::string("can no longer be inspected: ") + std::strerror(errno);
  } else if (st.st_size != size_at_map_) {
    changed_ = "was rewritten in place: " + std::to_string(size_at_map_) + " bytes when loaded, " +
               std::to_string(st.st_size) + " now";
  } else if (st.st_mtim.tv_sec != mtime_sec_ || st.st_mtim.tv_nsec != mtime_nsec_) {
    changed_ = "was rewritten in place (modified since it was loaded)";
  }
  if (!changed_.empty()) changed_ = QuotedForMessage(name_) + " " + changed_;
  return changed_;
}

std::shared_ptr<const MappedFile> MapRegularFile(int fd, const std::string& name) {
  struct stat st;
  if (fstat(fd, &st) != 0) {
    throw std::runtime_error("cannot inspect " + QuotedForMessage(name) + ": " +
                             std::strerror(errno));
  }
  const size_t size = static_cast<size_t>(RegularFileSize(fd, name));
  auto file = std::make_shared<MappedFile>();
  if (size == 0) return file;
  // Its own handle, kept: Changed() asks the file mapped, not whatever has its name now.
  file->fd_ = fcntl(fd, F_DUPFD_CLOEXEC, 0);
  if (file->fd_ < 0) {
    throw std::runtime_error("cannot map " + QuotedForMessage(name) +
                             " into memory: " + std::strerror(errno));
  }
  file->name_ = name;
  file->size_at_map_ = static_cast<int64_t>(size);
  file->mtime_sec_ = st.st_mtim.tv_sec;
  file->mtime_nsec_ = st.st_mtim.tv_nsec;
  void* at = mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
  if (at == MAP_FAILED) {
    throw std::runtime_error("cannot map " + QuotedForMessage(name) +
                             " into memory: " + std::strerror(errno));
  }
  file->data = static_cast<const char*>(at);
  file->size = size;
  file->guard_ = GuardRange(at, size);
  return file;
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
