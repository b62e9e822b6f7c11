// A folder that requests from the outside world (service calls, YAML fields they lead to)
// may read and write below, and nowhere else.
//
// Every access opens the folder (by its path: links in the folder's own path are the
// operator's choice) and walks from that handle one path component at a time with
// openat(O_NOFOLLOW), so a symbolic link below the folder is never followed and a link
// swapped in between a check and a use cannot redirect a read or a write: the path is
// checked at the moment the file is opened. (The folder may be emptied or recreated while
// a node runs.) ".." is resolved lexically and may not
// climb above the folder. Reads accept only regular files (opened non-blocking, so a FIFO
// cannot hang the caller). Writes go to a temporary file beside the target, are flushed and
// renamed into place below the same handle.
//
// Thread-safe: every method is const and uses only the folder's handle.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/io/file_util.h"

namespace bsf_vpr {

class DataDirectory {
 public:
  // Opens `path` (links within `path` itself are followed: choosing the folder is the
  // operator's decision). With `create`, missing folders are made first (mode 0755).
  // Throws std::runtime_error naming the folder if it cannot be opened.
  explicit DataDirectory(const std::string& path, bool create = false);
  DataDirectory(const DataDirectory&) = delete;
  DataDirectory& operator=(const DataDirectory&) = delete;

  // The folder's absolute path, links resolved (as opened).
  const std::string& path() const { return path_; }

  // The path of a request below the folder, normalised: "a/b.yaml". Accepts a relative
  // path or an absolute one that starts with path(). Throws std::invalid_argument naming
  // the request if it is empty, escapes the folder ("..", another absolute path), names
  // the folder itself, or holds a control character or invalid UTF-8.
  std::string Relative(const std::string& request) const;

  // The bytes of the regular file at `relative` (a path from Relative). Throws
  // std::runtime_error naming it if it is missing, a link, a FIFO, a device, a folder,
  // larger than `max_bytes` (checked before anything is read) or unreadable, or
  // std::invalid_argument if `relative` is not a valid relative path.
  std::string Read(const std::string& relative,
                   uint64_t max_bytes = std::numeric_limits<uint64_t>::max()) const;

  // The regular file at `relative`, memory-mapped (MapFile, file_util.h), reached as Read
  // reaches it. Throws as Read does.
  std::shared_ptr<const MappedFile> Map(const std::string& relative) const;

  // The names of the regular files in the folder at `relative` (a path from Relative), sorted;
  // links (and folders, FIFOs...) are left out. The folder is reached like Read's files, one
  // component at a time without following links. Throws std::runtime_error naming it if it
  // is missing, a link, not a folder or unreadable, or std::invalid_argument if `relative`
  // is not a valid relative path.
  std::vector<std::string> ListFiles(const std::string& relative_folder) const;

  // The paths (as Relative gives them) of the regular files anywhere below the folder,
  // sorted. Folders are walked like ListFiles' one, without following links; links are not
  // listed. Throws std::runtime_error naming a folder that cannot be opened or listed.
  std::vector<std::string> ListFilesBelow() const;

  // Whether an entry (file, folder or link) exists at `relative`. Links are not followed.
  bool Exists(const std::string& relative) const;

  // Writes `bytes` to `relative` atomically, creating missing folders on the way (links
  // refused). With `replace` false an existing entry is never replaced (the write fails
  // and names it). Throws std::runtime_error naming the file and the system error; the
  // temporary file is removed on failure.
  void WriteAtomically(const std::string& relative, const std::string& bytes,
                       bool replace = true) const;

  // Removes the file at `relative` if it exists (never follows a link; removes the link).
  void Remove(const std::string& relative) const;

  // The temporary files of WriteAtomically and CreateLocked anywhere below the folder
  // (".<name>.bsf_tmp.<8 of a-z0-9>", relative paths, sorted): what writes killed on the way
  // left. Nothing is removed here: a temporary is removed only by the journal of the save that
  // wrote it (RecoverInterruptedSaves), the others are reported.
  std::vector<std::string> Temporaries() const;
  // Whether `temporary` (relative) is a temporary that a write of `relative` made.
  static bool IsTemporaryOf(const std::string& temporary, const std::string& relative);

  // Makes the folder at `relative` (and the folders on the way), which must not exist yet.
  // Throws std::runtime_error naming it if it exists or cannot be made.
  void CreateFolder(const std::string& relative) const;
  // Removes the folder at `relative` if it exists and is empty; a folder that holds anything
  // stays. Returns whether it is gone. Throws std::runtime_error if the folder above cannot
  // be opened.
  bool RemoveEmptyFolder(const std::string& relative) const;

  // An exclusive lock (flock) on a file below the folder, held while this object lives (or
  // until the process ends, however it ends).
  class LockedFile {
   public:
    LockedFile() = default;
    LockedFile(LockedFile&& o) noexcept : fd_(o.fd_) { o.fd_ = -1; }
    LockedFile& operator=(LockedFile&& o) noexcept;
    LockedFile(const LockedFile&) = delete;
    LockedFile& operator=(const LockedFile&) = delete;
    ~LockedFile();
    bool held() const { return fd_ >= 0; }

   private:
    friend class DataDirectory;
    explicit LockedFile(int fd) : fd_(fd) {}
    int fd_ = -1;
  };
  // Creates the file `relative` (it must not exist; missing folders are made), locks it,
  // writes `bytes` and flushes the file and its folder. The bytes are written under a
  // temporary name first, so that the file never exists half-written. Throws std::runtime_error naming it;
  // a file it created is removed again on failure.
  LockedFile CreateLocked(const std::string& relative, const std::string& bytes) const;
  // Locks the regular file at `relative` without waiting and returns its bytes, the lock
  // kept in *lock; std::nullopt when another open file holds its lock (a process that is
  // writing it, alive). Throws std::runtime_error naming it if it cannot be opened or read.
  std::optional<std::string> ReadIfUnlocked(const std::string& relative, LockedFile* lock) const;

 private:
  int OpenRoot() const;  // a new handle on the folder; the caller closes it
  // The file at `relative` opened read-only as Read opens it (below the folder, no link
  // followed, non-blocking); the caller closes it. Throws std::runtime_error naming it.
  int OpenForReading(const std::string& relative) const;

  std::string path_;
};

// `text` quoted for a message: control characters and bytes that are not UTF-8 escaped
// ('a\x0ab', '\xff'), bidirectional controls and invisible characters (UnreadableCharacter)
// escaped as '\u202e', and, past `max_chars` characters, cut with the full length in bytes
// said ('abc...' (10000000 characters)). For echoing input in errors: what is shown is
// what was sent, and no part of it can reorder or hide the rest of the message.
std::string QuotedForMessage(const std::string& text, size_t max_chars = 160);

// Why `text` is not a name a person can read ("" when it is): the first invalid UTF-8
// ("invalid UTF-8 at byte 3"), control character (C0, DEL, C1), bidirectional control
// (U+202A-202E, U+2066-2069, U+200E, U+200F, U+061C), invisible character (zero-width
// U+200B-200D, U+2060-2064, U+FEFF, soft hyphen U+00AD, U+034F, U+180E, U+FFF9-FFFB, tags
// U+E0000-E007F) or line/paragraph separator (U+2028, U+2029), with its code point and byte
// offset ("a bidirectional control (U+202E) at byte 4").
std::string UnreadableCharacter(const std::string& text);

// Whether `text` is valid UTF-8 without any of those (a name a person can read).
bool IsPrintableUtf8(const std::string& text);

}  // namespace bsf_vpr
