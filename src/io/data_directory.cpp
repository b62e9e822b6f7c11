#include "bsf_vpr/io/data_directory.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <utility>
#include <vector>

#include "src/io/internal/posix_file.h"

namespace bsf_vpr {
namespace {

// Marks WriteAtomically's temporaries: ".<name>.bsf_tmp.<random>".
constexpr char kTempMarker[] = ".bsf_tmp.";

std::string SystemError(const std::string& what, const std::string& path, int err) {
  return "cannot " + what + " " + QuotedForMessage(path) + ": " + std::strerror(err);
}

std::vector<std::string> Split(const std::string& relative) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (start <= relative.size()) {
    const size_t slash = relative.find('/', start);
    const size_t end = slash == std::string::npos ? relative.size() : slash;
    parts.push_back(relative.substr(start, end - start));
    if (slash == std::string::npos) break;
    start = slash + 1;
  }
  return parts;
}

// Opens the folder that holds the last component of `relative`, one component at a time
// without following links; with `create`, missing folders are made. Returns the handle.
Fd OpenParent(int root, const std::vector<std::string>& parts, const std::string& relative,
              bool create) {
  Fd dir(fcntl(root, F_DUPFD_CLOEXEC, 0));
  if (dir.get() < 0) throw std::runtime_error(SystemError("open the folder of", relative, errno));
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    int next = openat(dir.get(), parts[i].c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (next < 0 && errno == ENOENT && create) {
      if (mkdirat(dir.get(), parts[i].c_str(), 0755) != 0 && errno != EEXIST) {
        throw std::runtime_error(SystemError("create the folder of", relative, errno));
      }
      next = openat(dir.get(), parts[i].c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    }
    if (next < 0) {
      const int err = errno;
      throw std::runtime_error(SystemError("open the folder of", relative, err) +
                               (err == ELOOP || err == ENOTDIR
                                    ? " (a link or a file where a folder should be; links "
                                      "are not followed below the data directory)"
                                    : ""));
    }
    dir = Fd(next);
  }
  return dir;
}

// Whether `name` has WriteAtomically's temporary form: ".<name>.bsf_tmp.<8 of a-z0-9>".
bool IsTemporaryName(const std::string& name) {
  const size_t marker = name.rfind(kTempMarker);
  if (name.size() < 2 || name[0] != '.' || marker == std::string::npos || marker < 2) return false;
  const size_t tail = marker + sizeof(kTempMarker) - 1;
  if (name.size() != tail + 8) return false;
  for (size_t i = tail; i < name.size(); ++i) {
    const char c = name[i];
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9'))) return false;
  }
  return true;
}

// Appends to *out the temporaries below the folder open as `dir_fd` (paths from `prefix`).
void ListTemporariesBelow(int dir_fd, const std::string& prefix, std::vector<std::string>* out) {
  const int dup = fcntl(dir_fd, F_DUPFD_CLOEXEC, 0);
  if (dup < 0) return;
  DIR* d = fdopendir(dup);
  if (d == nullptr) {
    close(dup);
    return;
  }
  std::vector<std::string> folders;
  while (const dirent* e = readdir(d)) {
    const std::string name = e->d_name;
    if (name == "." || name == "..") continue;
    struct stat st;
    if (fstatat(dir_fd, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0) continue;
    if (S_ISDIR(st.st_mode)) {
      folders.push_back(name);
    } else if (S_ISREG(st.st_mode) && IsTemporaryName(name)) {
      out->push_back(prefix + name);
    }
  }
  closedir(d);
  for (const std::string& f : folders) {
    Fd sub(openat(dir_fd, f.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
    if (sub.get() >= 0) ListTemporariesBelow(sub.get(), prefix + f + "/", out);
  }
}

// Appends to *out the regular files below the folder `dir_fd` (whose path below the data
// directory is `prefix`, "" for the directory itself), descending into its folders without
// following links.
void AppendFilesBelow(int dir_fd, const std::string& prefix, std::vector<std::string>* out) {
  const std::string shown = prefix.empty() ? "the data directory" : QuotedForMessage(prefix);
  const int dup = fcntl(dir_fd, F_DUPFD_CLOEXEC, 0);
  if (dup < 0) throw std::runtime_error("cannot list " + shown + ": " + std::strerror(errno));
  DIR* d = fdopendir(dup);  // takes dup over: closedir closes it
  if (d == nullptr) {
    const int err = errno;
    close(dup);
    throw std::runtime_error("cannot list " + shown + ": " + std::strerror(err));
  }
  std::vector<std::string> folders;
  errno = 0;
  while (const dirent* e = readdir(d)) {
    const std::string name = e->d_name;
    struct stat st;
    if (name != "." && name != ".." &&
        fstatat(dir_fd, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0) {
      if (S_ISDIR(st.st_mode)) folders.push_back(name);
      if (S_ISREG(st.st_mode)) out->push_back(prefix + name);
    }
    errno = 0;
  }
  const int err = errno;
  closedir(d);
  if (err != 0) throw std::runtime_error("cannot list " + shown + ": " + std::strerror(err));
  for (const std::string& f : folders) {
    const Fd sub(openat(dir_fd, f.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
    if (sub.get() < 0) throw std::runtime_error(SystemError("open the folder", prefix + f, errno));
    AppendFilesBelow(sub.get(), prefix + f + "/", out);
  }
}

// Creates a new temporary for the file `name` in the folder open as `dir_fd`
// (".<name>.bsf_tmp.<8 of a-z0-9>", never an existing file), opened for writing (`access`:
// O_WRONLY or O_RDWR); its name in *tmp. -1 with errno set when it cannot.
int CreateTemporary(int dir_fd, const std::string& name, int access, std::string* tmp) {
  int raw = -1;
  for (int attempt = 0; attempt < 16 && raw < 0; ++attempt) {
    *tmp = "." + name.substr(0, 200) + kTempMarker + RandomChars(8);
    raw = openat(dir_fd, tmp->c_str(), access | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (raw < 0 && errno != EEXIST) break;
  }
  return raw;
}

}  // namespace

DataDirectory::DataDirectory(const std::string& path, bool create) {
  if (path.empty()) throw std::runtime_error("no data directory is configured");
  std::error_code ec;
  if (create) std::filesystem::create_directories(path, ec);
  const Fd root(open(path.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (root.get() < 0) throw std::runtime_error(SystemError("open the data directory", path, errno));
  path_ = std::filesystem::canonical(path, ec).string();
  if (ec) path_ = std::filesystem::absolute(path).lexically_normal().string();
}

int DataDirectory::OpenRoot() const {
  const int fd = open(path_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error(SystemError("open the data directory", path_, errno));
  return fd;
}

std::string DataDirectory::Relative(const std::string& request) const {
  if (request.empty()) throw std::invalid_argument("empty path");
  if (!IsPrintableUtf8(request)) {
    throw std::invalid_argument("path " + QuotedForMessage(request) +
                                " holds a control character or invalid UTF-8");
  }
  std::string rest = request;
  if (request[0] == '/') {
    const std::string prefix = path_ == "/" ? "/" : path_ + "/";
    if (request.compare(0, prefix.size(), prefix) != 0) {
      throw std::invalid_argument("path " + QuotedForMessage(request) +
                                  " lies outside the data directory '" + path_ + "'");
    }
    rest = request.substr(prefix.size());
  }
  std::vector<std::string> kept;
  for (const std::string& part : Split(rest)) {
    if (part.empty() || part == ".") continue;
    if (part == "..") {
      if (kept.empty()) {
        throw std::invalid_argument("path " + QuotedForMessage(request) +
                                    " lies outside the data directory '" + path_ + "'");
      }
      kept.pop_back();
      continue;
    }
    if (part.size() > 255) {
      throw std::invalid_argument("path " + QuotedForMessage(request) +
                                  " has a component longer than 255 bytes");
    }
    kept.push_back(part);
  }
  if (kept.empty()) {
    throw std::invalid_argument("path " + QuotedForMessage(request) +
                                " names the data directory itself, not a file in it");
  }
  std::string out;
  for (const std::string& part : kept) out += (out.empty() ? "" : "/") + part;
  if (out.size() > 4000)
    throw std::invalid_argument("path " + QuotedForMessage(request) + " is too long");
  return out;
}

int DataDirectory::OpenForReading(const std::string& relative) const {
  const std::vector<std::string> parts = Split(Relative(relative));
  const Fd root(OpenRoot());
  const Fd dir = OpenParent(root.get(), parts, relative, false);
  const int file = openat(dir.get(), parts.back().c_str(),
                          O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (file < 0) {
    const int err = errno;
    throw std::runtime_error(
        SystemError("open", relative, err) +
        (err == ELOOP ? " (links are not followed below the data directory)" : ""));
  }
  return file;
}

std::string DataDirectory::Read(const std::string& relative, uint64_t max_bytes) const {
  const Fd file(OpenForReading(relative));
  return ReadRegularFile(file.get(), relative, max_bytes);
}

std::shared_ptr<const MappedFile> DataDirectory::Map(const std::string& relative) const {
  const Fd file(OpenForReading(relative));
  return MapRegularFile(file.get(), relative);
}

std::vector<std::string> DataDirectory::ListFiles(const std::string& relative_folder) const {
  const std::vector<std::string> parts = Split(Relative(relative_folder));
  const Fd root(OpenRoot());
  const Fd parent = OpenParent(root.get(), parts, relative_folder, false);
  const int raw =
      openat(parent.get(), parts.back().c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (raw < 0) {
    int err = errno;
    // O_DIRECTORY reports a link as "not a folder": tell the two apart.
    struct stat st;
    if (err == ENOTDIR &&
        fstatat(parent.get(), parts.back().c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 &&
        S_ISLNK(st.st_mode)) {
      err = ELOOP;
    }
    throw std::runtime_error(
        err == ENOTDIR
            ? QuotedForMessage(relative_folder) + " is not a folder"
            : SystemError("open the folder", relative_folder, err) +
                  (err == ELOOP ? " (links are not followed below the data directory)" : ""));
  }
  // fdopendir takes the descriptor over: closedir closes it.
  DIR* d = fdopendir(raw);
  if (d == nullptr) {
    const int err = errno;
    close(raw);
    throw std::runtime_error(SystemError("list", relative_folder, err));
  }
  std::vector<std::string> names;
  errno = 0;
  while (const dirent* e = readdir(d)) {
    struct stat st;
    if (fstatat(dirfd(d), e->d_name, &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISREG(st.st_mode)) {
      names.emplace_back(e->d_name);
    }
    errno = 0;
  }
  const int err = errno;
  closedir(d);
  if (err != 0) throw std::runtime_error(SystemError("list", relative_folder, err));
  std::sort(names.begin(), names.end());
  return names;
}

std::vector<std::string> DataDirectory::ListFilesBelow() const {
  const Fd root(OpenRoot());
  std::vector<std::string> files;
  AppendFilesBelow(root.get(), "", &files);
  std::sort(files.begin(), files.end());
  return files;
}

bool DataDirectory::Exists(const std::string& relative) const {
  const std::vector<std::string> parts = Split(Relative(relative));
  try {
    const Fd root(OpenRoot());
    const Fd dir = OpenParent(root.get(), parts, relative, false);
    struct stat st;
    return fstatat(dir.get(), parts.back().c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0;
  } catch (const std::runtime_error&) {
    return false;  // a missing folder on the way
  }
}

void DataDirectory::WriteAtomically(const std::string& relative, const std::string& bytes,
                                    bool replace) const {
  const std::vector<std::string> parts = Split(Relative(relative));
  const Fd root(OpenRoot());
  const Fd dir = OpenParent(root.get(), parts, relative, true);
  const std::string& name = parts.back();
  std::string tmp;
  const int raw = CreateTemporary(dir.get(), name, O_WRONLY, &tmp);
  if (raw < 0)
    throw std::runtime_error(SystemError("create a temporary file for", relative, errno));
  int err = 0;
  {
    const Fd file(raw);
    err = WriteAll(file.get(), bytes);
    if (err == 0 && fsync(file.get()) != 0) err = errno;
  }
  if (err == 0) {
    const int rc =
        replace ? renameat(dir.get(), tmp.c_str(), dir.get(), name.c_str())
                : renameat2(dir.get(), tmp.c_str(), dir.get(), name.c_str(), RENAME_NOREPLACE);
    if (rc != 0) err = errno;
  }
  if (err != 0) {
    unlinkat(dir.get(), tmp.c_str(), 0);
    throw std::runtime_error(SystemError("write", relative, err) +
                             (err == EEXIST ? " (it exists and is not replaced)" : ""));
  }
  fsync(dir.get());  // the rename itself survives a power cut
}

void DataDirectory::Remove(const std::string& relative) const {
  const std::vector<std::string> parts = Split(Relative(relative));
  const Fd root(OpenRoot());
  const Fd dir = OpenParent(root.get(), parts, relative, false);
  if (unlinkat(dir.get(), parts.back().c_str(), 0) != 0 && errno != ENOENT) {
    throw std::runtime_error(SystemError("remove", relative, errno));
  }
}

std::vector<std::string> DataDirectory::Temporaries() const {
  const Fd root(OpenRoot());
  std::vector<std::string> out;
  ListTemporariesBelow(root.get(), "", &out);
  std::sort(out.begin(), out.end());
  return out;
}

bool DataDirectory::IsTemporaryOf(const std::string& temporary, const std::string& relative) {
  const size_t slash = relative.rfind('/');
  const std::string folder = slash == std::string::npos ? "" : relative.substr(0, slash + 1);
  const std::string prefix = folder + "." + relative.substr(folder.size()).substr(0, 200) + kTempMarker;
  return temporary.size() == prefix.size() + 8 && temporary.compare(0, prefix.size(), prefix) == 0 &&
         IsTemporaryName(temporary.substr(folder.size()));
}

void DataDirectory::CreateFolder(const std::string& relative) const {
  const std::vector<std::string> parts = Split(Relative(relative));
  const Fd root(OpenRoot());
  const Fd dir = OpenParent(root.get(), parts, relative, true);
  if (mkdirat(dir.get(), parts.back().c_str(), 0755) != 0) {
    throw std::runtime_error(SystemError("create the folder", relative, errno));
  }
  fsync(dir.get());
}

bool DataDirectory::RemoveEmptyFolder(const std::string& relative) const {
  const std::vector<std::string> parts = Split(Relative(relative));
  const Fd root(OpenRoot());
  Fd dir;
  try {
    dir = OpenParent(root.get(), parts, relative, false);
  } catch (const std::runtime_error&) {
    if (!Exists(relative)) return true;  // a folder on the way is gone: so is this one
    throw;
  }
  if (unlinkat(dir.get(), parts.back().c_str(), AT_REMOVEDIR) == 0) return true;
  return errno == ENOENT;
}

DataDirectory::LockedFile& DataDirectory::LockedFile::operator=(LockedFile&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) close(fd_);
    fd_ = o.fd_;
    o.fd_ = -1;
  }
  return *this;
}

DataDirectory::LockedFile::~LockedFile() {
  if (fd_ >= 0) close(fd_);  // releases the lock
}

DataDirectory::LockedFile DataDirectory::CreateLocked(const std::string& relative,
                                                      const std::string& bytes) const {
  const std::vector<std::string> parts = Split(Relative(relative));
  const Fd root(OpenRoot());
  const Fd dir = OpenParent(root.get(), parts, relative, true);
  const std::string& name = parts.back();
  // Written whole under a temporary name, then linked to its own: a file of this name is
  // never seen half-written, whenever the process is killed.
  std::string tmp;
  const int raw = CreateTemporary(dir.get(), name, O_RDWR, &tmp);
  if (raw < 0) throw std::runtime_error(SystemError("create", relative, errno));
  Fd file(raw);
  int err = flock(file.get(), LOCK_EX) != 0 ? errno : WriteAll(file.get(), bytes);
  if (err == 0 && fsync(file.get()) != 0) err = errno;
  if (err == 0 && linkat(dir.get(), tmp.c_str(), dir.get(), name.c_str(), 0) != 0) err = errno;
  unlinkat(dir.get(), tmp.c_str(), 0);
  if (err == 0 && fsync(dir.get()) != 0) {
    err = errno;
    unlinkat(dir.get(), name.c_str(), 0);
  }
  if (err != 0) throw std::runtime_error(SystemError("write", relative, err));
  return LockedFile(file.release());
}

std::optional<std::string> DataDirectory::ReadIfUnlocked(const std::string& relative,
                                                         LockedFile* lock) const {
  const std::vector<std::string> parts = Split(Relative(relative));
  const Fd root(OpenRoot());
  const Fd dir = OpenParent(root.get(), parts, relative, false);
  Fd file(openat(dir.get(), parts.back().c_str(),
                 O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC | O_NOCTTY));
  if (file.get() < 0) throw std::runtime_error(SystemError("open", relative, errno));
  if (flock(file.get(), LOCK_EX | LOCK_NB) != 0) {
    if (errno == EWOULDBLOCK) return std::nullopt;
    throw std::runtime_error(SystemError("lock", relative, errno));
  }
  std::string bytes = ReadRegularFile(file.get(), relative);
  *lock = LockedFile(file.release());
  return bytes;
}

}  // namespace bsf_vpr
