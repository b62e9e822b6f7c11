#include "src/io/internal/save_journal.h"

#include <yaml-cpp/yaml.h>

#include <optional>
#include <stdexcept>

#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "src/io/internal/posix_file.h"
#include "src/io/internal/saved_descriptors.h"

namespace bsf_vpr {
namespace {

// ".<yaml file name>.bsf_save.<8 characters>", beside the YAML.
constexpr char kJournalMarker[] = ".bsf_save.";
constexpr size_t kRandomChars = 8;

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string Folder(const std::string& relative) {
  const size_t slash = relative.rfind('/');
  return slash == std::string::npos ? "" : relative.substr(0, slash + 1);
}

// The path below `dir` that `field` of the YAML at `yaml` names (relative to the YAML's
// folder, or absolute below the directory); "" when it lies outside or is not a path.
std::string Resolve(const DataDirectory& dir, const std::string& yaml, const std::string& field) {
  try {
    return dir.Relative(!field.empty() && field[0] == '/' ? field : Folder(yaml) + field);
  } catch (const std::invalid_argument&) {
    return "";
  }
}

// The .npy the YAML at `yaml` names (relative), "" if there is no such YAML or it names none
// below the directory. Throws std::runtime_error for a YAML that exists but cannot be parsed.
std::string DescriptorsOf(const DataDirectory& dir, const std::string& yaml) {
  if (!dir.Exists(yaml)) return "";
  try {
    const YAML::Node root = YAML::Load(dir.Read(yaml));
    if (!root.IsMap() || !root["descriptors"] || !root["descriptors"].IsScalar()) return "";
    return Resolve(dir, yaml, root["descriptors"].as<std::string>());
  } catch (const std::exception& e) {
    throw std::runtime_error(QuotedForMessage(yaml) + " cannot be read (" + e.what() + ")");
  }
}

std::string JournalText(const SaveFiles& f) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "bsf_vpr_save_journal" << YAML::Value << 1;
  out << YAML::Key << "yaml" << YAML::Value << f.yaml;
  out << YAML::Key << "descriptors" << YAML::Value << f.descriptors;
  out << YAML::Key << "yaml_digest" << YAML::Value << f.yaml_digest;
  out << YAML::Key << "created" << YAML::Value << f.created;
  out << YAML::Key << "created_folders" << YAML::Value << f.created_folders;
  out << YAML::Key << "replaced" << YAML::Value << f.replaced;
  out << YAML::Key << "replaced_folders" << YAML::Value << f.replaced_folders;
  out << YAML::Key << "complete" << YAML::Value << true;  // last: the journal was written whole
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

// The journal's files, each checked to lie below `dir`; std::nullopt for a journal that was
// not written whole (its save created nothing yet). Throws std::runtime_error if it cannot
// be parsed.
std::optional<SaveFiles> ParseJournal(const DataDirectory& dir, const std::string& text) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const std::exception&) {
    return std::nullopt;  // cut short while written: nothing was created after it
  }
  if (!root.IsMap() || !root["complete"] || !root["complete"].as<bool>(false)) return std::nullopt;
  SaveFiles f;
  const auto paths = [&](const char* key) {
    std::vector<std::string> out;
    for (const std::string& p : root[key].as<std::vector<std::string>>()) {
      out.push_back(dir.Relative(p));
    }
    return out;
  };
  try {
    f.yaml = dir.Relative(root["yaml"].as<std::string>());
    f.descriptors = dir.Relative(root["descriptors"].as<std::string>());
    if (root["yaml_digest"]) f.yaml_digest = root["yaml_digest"].as<std::string>();
    f.created = paths("created");
    f.created_folders = paths("created_folders");
    f.replaced = paths("replaced");
    f.replaced_folders = paths("replaced_folders");
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("not a journal of a save (") + e.what() + ")");
  }
  return f;
}

// Removes those of `files` that `named` does not name, then the folders that are left
// empty; returns how many files were removed. Never throws: what cannot go stays.
int RemoveUnnamed(const DataDirectory& dir, const std::vector<std::string>& files,
                  const std::vector<std::string>& folders, const NamedFiles& named) {
  int removed = 0;
  for (const std::string& f : files) {
    if (named.Names(f)) continue;
    try {
      if (!dir.Exists(f)) continue;
      dir.Remove(f);
      ++removed;
    } catch (const std::exception&) {
    }
  }
  for (const std::string& f : folders) {
    try {
      dir.RemoveEmptyFolder(f);
    } catch (const std::exception&) {
    }
  }
  return removed;
}

}  // namespace

bool NamedFiles::Names(const std::string& relative) const {
  if (EndsWith(relative, ".npy") && descriptor_names.count(BaseName(relative))) return true;
  if (paths.count(relative)) return true;
  // A path under a named folder (a set whose rows are its images folder's files).
  for (std::string folder = Folder(relative); !folder.empty(); folder = Folder(folder)) {
    folder.pop_back();  // the trailing '/'
    if (paths.count(folder)) return true;
  }
  return false;
}

NamedFiles ScanNamedFiles(const DataDirectory& dir, const std::set<std::string>& keep) {
  NamedFiles named;
  named.paths = keep;
  for (const std::string& f : dir.ListFilesBelow()) {
    if (!EndsWith(f, ".yaml") && !EndsWith(f, ".yml")) continue;
    try {
      const YAML::Node root = YAML::Load(dir.Read(f));
      // Another YAML (a configuration, ground truth) names no set's files.
      if (!root.IsMap() || !root["descriptors"] || !root["descriptors"].IsScalar()) continue;
      named.descriptor_names.insert(BaseName(root["descriptors"].as<std::string>()));
      if (!root["images"] || !root["images"].IsScalar()) continue;
      const std::string folder = Resolve(dir, f, root["images"].as<std::string>());
      if (folder.empty()) continue;
      if (!root["image_files"] || !root["image_files"].IsSequence()) {
        named.paths.insert(folder);  // every file in it
        continue;
      }
      for (const YAML::Node& image : root["image_files"]) {
        if (!image.IsScalar() || image.as<std::string>().empty()) continue;
        const std::string path = Resolve(dir, folder + "/x", image.as<std::string>());
        if (!path.empty()) named.paths.insert(path);
      }
    } catch (const std::exception& e) {
      throw std::runtime_error(QuotedForMessage(f) + " cannot be read (" + e.what() +
                               "): it might name any file, so none is removed");
    }
  }
  return named;
}

bool IsSaveJournalName(const std::string& name) {
  const size_t marker = name.rfind(kJournalMarker);
  return name.size() > 1 && name[0] == '.' && marker != std::string::npos && marker > 1 &&
         name.size() == marker + sizeof(kJournalMarker) - 1 + kRandomChars;
}

SaveJournal::SaveJournal(const DataDirectory& dir, SaveFiles files)
    : dir_(dir), files_(std::move(files)) {
  const std::string text = JournalText(files_);
  for (int attempt = 0;; ++attempt) {
    path_ = Folder(files_.yaml) + "." + BaseName(files_.yaml).substr(0, 200) + kJournalMarker +
            RandomChars(kRandomChars);
    try {
      lock_ = dir_.CreateLocked(path_, text);
      return;
    } catch (const std::runtime_error&) {
      if (attempt >= 4 || !dir_.Exists(path_)) throw;  // not a name taken by chance
    }
  }
}

void SaveJournal::RollBack(const std::vector<std::string>& made,
                           const std::vector<std::string>& made_folders) noexcept {
  // Only what this save made (a file of the same name it did not make is another's), and
  // nothing a YAML names (the old set, when the same descriptors were saved again).
  NamedFiles named;
  try {
    if (!made.empty()) named = ScanNamedFiles(dir_, {});  // (folders go only when empty)
  } catch (const std::exception&) {
    return;  // the journal stays for the next start, which asks every YAML again
  }
  RemoveUnnamed(dir_, made, made_folders, named);
  try {
    for (const std::string& f : made) {
      if (!named.Names(f) && dir_.Exists(f)) return;  // left: the next start tries again
    }
    dir_.Remove(path_);
  } catch (const std::exception&) {
  }
}

void SaveJournal::Finish(const std::set<std::string>& keep) noexcept {
  try {
    // A set saved under a new name replaced nothing: no YAML need be read.
    if (!files_.replaced.empty()) {
      RemoveUnnamed(dir_, files_.replaced, files_.replaced_folders, ScanNamedFiles(dir_, keep));
    }
  } catch (const std::exception&) {
    // A YAML that cannot be read might name the old files: they stay, and so does nothing
    // else of this save to do.
  }
  try {
    dir_.Remove(path_);
  } catch (const std::exception&) {
  }
}

std::vector<std::string> RecoverInterruptedSaves(const DataDirectory& dir,
                                                 const std::set<std::string>& keep) {
  std::vector<std::string> journals;
  for (const std::string& f : dir.ListFilesBelow()) {
    if (IsSaveJournalName(BaseName(f))) journals.push_back(f);
  }
  if (journals.empty()) return {};
  // The temporaries a killed write left in a save's new folder: else the folder is not empty
  // when its save is undone.
  dir.RemoveStaleTemporaries();
  std::vector<std::string> report;
  NamedFiles named;
  try {
    named = ScanNamedFiles(dir, keep);
  } catch (const std::exception& e) {
    return {"left " + std::to_string(journals.size()) +
            " interrupted save(s) as they are: " + e.what()};
  }
  for (const std::string& journal : journals) {
    DataDirectory::LockedFile lock;
    try {
      const std::optional<std::string> text = dir.ReadIfUnlocked(journal, &lock);
      if (!text) continue;  // a save running in another process
      const std::optional<SaveFiles> f = ParseJournal(dir, *text);
      if (f) {
        // The new YAML is in place: the very bytes the save wrote (the same descriptors
        // saved again name the same .npy, so that alone cannot tell).
        const bool saved =
            f->yaml_digest.empty()
                ? DescriptorsOf(dir, f->yaml) == f->descriptors
                : dir.Exists(f->yaml) && ContentDigest(dir.Read(f->yaml)) == f->yaml_digest;
        const int n = saved ? RemoveUnnamed(dir, f->replaced, f->replaced_folders, named)
                            : RemoveUnnamed(dir, f->created, f->created_folders, named);
        report.push_back((saved ? "finished the interrupted save of " + QuotedForMessage(f->yaml) +
                                      ": removed " + std::to_string(n) +
                                      " file(s) of the set it replaced"
                                : "undid the interrupted save of " + QuotedForMessage(f->yaml) +
                                      " (the old set, if any, is as it was): removed " +
                                      std::to_string(n) + " file(s) it had written"));
      }
      dir.Remove(journal);
    } catch (const std::exception& e) {
      report.push_back("left the interrupted save " + QuotedForMessage(journal) +
                       " as it is: " + e.what());
    }
  }
  return report;
}

}  // namespace bsf_vpr
