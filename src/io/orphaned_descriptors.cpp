#include <sys/stat.h>
#include <yaml-cpp/yaml.h>

#include <ctime>
#include <set>
#include <stdexcept>

#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "src/io/internal/saved_descriptors.h"

namespace bsf_vpr {
namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// A save renames its .npy into place a moment before the YAML that names it: a file younger
// than this may be the new .npy of a save running in another process (a respawned node
// beside one that records into the same folder), so it is not taken for an orphan yet.
constexpr double kMinOrphanAgeS = 600;

bool YoungerThan(const std::string& path, double seconds) {
  struct stat st;
  if (::lstat(path.c_str(), &st) != 0) return true;  // cannot tell: keep it
  return std::difftime(std::time(nullptr), st.st_mtime) < seconds;
}

std::string FileName(const std::string& path) {
  const size_t slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// The file names (without folders) that the `descriptors` of the YAMLs among `files` name.
// Throws std::runtime_error naming a YAML that cannot be read or parsed.
std::set<std::string> NamedDescriptorFiles(const DataDirectory& dir,
                                           const std::vector<std::string>& files) {
  std::set<std::string> named;
  for (const std::string& f : files) {
    if (!EndsWith(f, ".yaml") && !EndsWith(f, ".yml")) continue;
    try {
      const YAML::Node root = YAML::Load(dir.Read(f));
      // Another YAML (a configuration, ground truth) names no descriptors.
      if (root.IsMap() && root["descriptors"] && root["descriptors"].IsScalar()) {
        named.insert(FileName(root["descriptors"].as<std::string>()));
      }
    } catch (const std::exception& e) {
      throw std::runtime_error(QuotedForMessage(f) + " cannot be read (" + e.what() +
                               "): it might name any descriptor file, so none is removed");
    }
  }
  return named;
}

}  // namespace

std::vector<std::string> RemoveOrphanedDescriptors(const DataDirectory& dir) {
  const std::vector<std::string> files = dir.ListFilesBelow();
  const std::set<std::string> named = NamedDescriptorFiles(dir, files);
  std::vector<std::string> removed;
  for (const std::string& f : files) {
    const std::string name = FileName(f);
    // The name first, then the bytes: only the save's own files are read, and only those
    // that no YAML names.
    if (!HasSavedDescriptorName(name) || named.count(name)) continue;
    if (YoungerThan(dir.path() + "/" + f, kMinOrphanAgeS)) continue;
    try {
      if (!IsSavedDescriptorFile(name, dir.Read(f))) continue;
      dir.Remove(f);
      removed.push_back(f);
    } catch (const std::exception&) {
      // Unreadable or not removable: it stays, as it would have without this.
    }
  }
  return removed;
}

}  // namespace bsf_vpr
