#include "src/io/internal/save_journal.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
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

constexpr int kJournalVersion = 2;
constexpr char kVersionKey[] = "bsf_vpr_save_journal";
constexpr char kByName[] = "named by content";
constexpr char kContent[] = "content ";

std::string JournalText(const SaveFiles& f) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << kVersionKey << YAML::Value << kJournalVersion;
  out << YAML::Key << "yaml" << YAML::Value << f.yaml;
  out << YAML::Key << "descriptors" << YAML::Value << f.descriptors;
  out << YAML::Key << "yaml_digest" << YAML::Value << f.yaml_digest;
  out << YAML::Key << "created" << YAML::Value << f.created;
  out << YAML::Key << "created_proofs" << YAML::Value << f.created_proofs;
  out << YAML::Key << "created_folders" << YAML::Value << f.created_folders;
  out << YAML::Key << "replaced" << YAML::Value << f.replaced;
  out << YAML::Key << "replaced_proofs" << YAML::Value << f.replaced_proofs;
  out << YAML::Key << "replaced_folders" << YAML::Value << f.replaced_folders;
  out << YAML::Key << "complete" << YAML::Value << true;  // last: the journal was written whole
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

// The journal's files, each checked to lie below `dir`. Throws std::runtime_error saying why
// `text` is not a complete journal of this version (another file that has a journal's name,
// a journal of an earlier version, one cut short): such a file is left as it is.
SaveFiles ParseJournal(const DataDirectory& dir, const std::string& text) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const std::exception&) {
    throw std::runtime_error("not a journal of a bsf_vpr save (not YAML)");
  }
  if (!root.IsMap() || !root[kVersionKey]) {
    throw std::runtime_error("not a journal of a bsf_vpr save (no " + std::string(kVersionKey) +
                             ")");
  }
  if (root[kVersionKey].as<std::string>("") != std::to_string(kJournalVersion)) {
    throw std::runtime_error("a journal of version " + root[kVersionKey].as<std::string>("?") +
                             ", which cannot prove which files its save wrote; check the files "
                             "it lists and remove it by hand");
  }
  if (!root["complete"] || !root["complete"].as<bool>(false)) {
    throw std::runtime_error("a journal cut short");
  }
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
    f.yaml_digest = root["yaml_digest"].as<std::string>();
    f.created = paths("created");
    f.created_proofs = root["created_proofs"].as<std::vector<std::string>>();
    f.created_folders = paths("created_folders");
    f.replaced = paths("replaced");
    f.replaced_proofs = root["replaced_proofs"].as<std::vector<std::string>>();
    f.replaced_folders = paths("replaced_folders");
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("not a journal of a bsf_vpr save (") + e.what() + ")");
  }
  if (f.created_proofs.size() != f.created.size() ||
      f.replaced_proofs.size() != f.replaced.size()) {
    throw std::runtime_error("not a journal of a bsf_vpr save (a file without its proof)");
  }
  return f;
}

// Why the file at `relative` is not the one `proof` names ("" if it is, or is gone).
std::string Unproven(const DataDirectory& dir, const std::string& relative,
                     const std::string& proof) {
  if (!dir.Exists(relative)) return "";
  std::string bytes;
  try {
    bytes = dir.Read(relative);
  } catch (const std::exception& e) {
    return e.what();
  }
  if (proof == kByName) {
    return IsSavedDescriptorFile(BaseName(relative), bytes)
               ? ""
               : "its bytes are not those its name was given for";
  }
  if (proof.rfind(kContent, 0) == 0) {
    return ContentDigest(bytes) == proof.substr(sizeof(kContent) - 1)
               ? ""
               : "its bytes are not those the save wrote";
  }
  return "the journal proves nothing of it";
}

// What one recovery did: the files removed and those kept, each with its reason.
struct Removal {
  std::vector<std::string> removed, kept;
};

// Removes the temporaries a killed write of `files` left (a half-written copy of one),
// adding them to r->removed. Never throws.
void RemoveTemporariesOf(const DataDirectory& dir, const std::vector<std::string>& files,
                         Removal* r) {
  try {
    for (const std::string& t : dir.Temporaries()) {
      for (const std::string& f : files) {
        if (!DataDirectory::IsTemporaryOf(t, f)) continue;
        dir.Remove(t);
        r->removed.push_back(QuotedForMessage(t) + " (a half-written copy)");
        break;
      }
    }
  } catch (const std::exception&) {
  }
}

// Removes those of `files` (with their `proofs`) that `named` does not name, then the
// temporaries of `files` and the folders left empty; but only when every one of them that
// exists is proved (bytes as the journal says): a journal that lists a file it cannot prove
// may not be ours, and nothing is removed for it (those files are `kept`). Never throws:
// what cannot go stays.
Removal RemoveProven(const DataDirectory& dir, const std::vector<std::string>& files,
                     const std::vector<std::string>& proofs,
                     const std::vector<std::string>& folders, const NamedFiles& named) {
  Removal r;
  std::vector<std::string> proved;
  for (size_t i = 0; i < files.size(); ++i) {
    const std::string& f = files[i];
    if (named.Names(f)) continue;
    try {
      if (!dir.Exists(f)) continue;
      const std::string why = Unproven(dir, f, i < proofs.size() ? proofs[i] : "");
      if (why.empty()) {
        proved.push_back(f);
      } else {
        r.kept.push_back(QuotedForMessage(f) + " (" + why + ")");
      }
    } catch (const std::exception& e) {
      r.kept.push_back(QuotedForMessage(f) + " (" + e.what() + ")");
    }
  }
  if (!r.kept.empty()) return r;
  for (const std::string& f : proved) {
    try {
      dir.Remove(f);
      r.removed.push_back(QuotedForMessage(f));
    } catch (const std::exception& e) {
      r.kept.push_back(QuotedForMessage(f) + " (" + e.what() + ")");
    }
  }
  RemoveTemporariesOf(dir, files, &r);
  for (const std::string& f : folders) {
    try {
      dir.RemoveEmptyFolder(f);
    } catch (const std::exception&) {
    }
  }
  return r;
}

// "removed 2 file(s): 'a', 'b'"; and the files kept, if any.
std::string Describe(const Removal& r) {
  std::string out = "removed " + std::to_string(r.removed.size()) + " file(s)";
  for (size_t i = 0; i < r.removed.size(); ++i) out += (i ? ", " : ": ") + r.removed[i];
  if (!r.kept.empty()) {
    out += "; kept " + std::to_string(r.kept.size()) + " it listed";
    for (size_t i = 0; i < r.kept.size(); ++i) out += (i ? ", " : ": ") + r.kept[i];
  }
  return out;
}

}  // namespace

std::string ProofByName() { return kByName; }
std::string ProofOfContent(const std::string& bytes) { return kContent + ContentDigest(bytes); }

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
  std::vector<std::string> proofs;
  for (const std::string& f : made) {
    const auto at = std::find(files_.created.begin(), files_.created.end(), f);
    proofs.push_back(at == files_.created.end()
                         ? ""
                         : files_.created_proofs[static_cast<size_t>(at - files_.created.begin())]);
  }
  RemoveProven(dir_, made, proofs, made_folders, named);
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
      RemoveProven(dir_, files_.replaced, files_.replaced_proofs, files_.replaced_folders,
                   ScanNamedFiles(dir_, keep));
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
  std::vector<std::string> report;
  // A journal's own temporary (CreateLocked writes it whole, then links it to its name): a
  // kill before the unlink leaves it, with or without its journal. Ours when its bytes are
  // (the start of) a journal of this version.
  const std::string header = std::string(kVersionKey) + ": " + std::to_string(kJournalVersion);
  for (const std::string& t : dir.Temporaries()) {
    const std::string name = BaseName(t);
    const size_t marker = name.rfind(".bsf_tmp.");
    if (marker == std::string::npos || !IsSaveJournalName(name.substr(1, marker - 1))) continue;
    try {
      const std::string bytes = dir.Read(t, 1 << 20);
      const size_t n = std::min(bytes.size(), header.size());
      if (bytes.compare(0, n, header, 0, n) != 0) continue;
      dir.Remove(t);
      report.push_back("removed " + QuotedForMessage(t) +
                       ", the copy of a journal its save was writing when it was killed");
    } catch (const std::exception&) {
    }
  }
  if (journals.empty()) return report;
  NamedFiles named;
  try {
    named = ScanNamedFiles(dir, keep);
  } catch (const std::exception& e) {
    report.push_back("left " + std::to_string(journals.size()) +
                     " interrupted save(s) as they are: " + e.what());
    return report;
  }
  for (const std::string& journal : journals) {
    DataDirectory::LockedFile lock;
    try {
      const std::optional<std::string> text = dir.ReadIfUnlocked(journal, &lock);
      if (!text) continue;  // a save running in another process
      const SaveFiles f = ParseJournal(dir, *text);
      // The new YAML is in place: the very bytes the save wrote (the same descriptors
      // saved again name the same .npy, so that alone cannot tell).
      const bool saved = dir.Exists(f.yaml) && ContentDigest(dir.Read(f.yaml)) == f.yaml_digest;
      Removal r =
          saved ? RemoveProven(dir, f.replaced, f.replaced_proofs, f.replaced_folders, named)
                : RemoveProven(dir, f.created, f.created_proofs, f.created_folders, named);
      if (!saved && r.kept.empty()) RemoveTemporariesOf(dir, {f.yaml}, &r);  // a half-written YAML
      if (!r.kept.empty()) {
        // Files it lists that are not what it says: it may not be ours; it stays with them.
        report.push_back("left " + QuotedForMessage(journal) + " and the files it lists whose " +
                         "bytes it does not prove: " + Describe(r));
        continue;
      }
      dir.Remove(journal);
      report.push_back(
          (saved ? "finished the interrupted save of " + QuotedForMessage(f.yaml) +
                       " (journal " + QuotedForMessage(journal) + "): of the set it replaced, "
                 : "undid the interrupted save of " + QuotedForMessage(f.yaml) + " (journal " +
                       QuotedForMessage(journal) + "; the old set, if any, is as it was): of " +
                       "what it had written, ") +
          Describe(r));
    } catch (const std::exception& e) {
      report.push_back("left " + QuotedForMessage(journal) + " as it is, and every file it names: " +
                       e.what());
    }
  }
  return report;
}

}  // namespace bsf_vpr
