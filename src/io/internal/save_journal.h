// The journal of one save of a reference set (private header of bsf_vpr_io): the files the
// save is about to create and the old set's files it replaces, written and locked before
// the save touches anything, removed when the save has ended either way. A save killed on
// the way (kill -9, a power cut) leaves its journal; RecoverInterruptedSaves
// (reference_set_io.h) reads it at the next start and finishes the save (the new YAML is in
// place: the replaced files go) or undoes it (the new YAML is not: the created files go).
// A file goes only when the journal lists it and its bytes are still the ones the journal
// proves (SaveFiles' proofs), so start-up removes only what a save of ours wrote or replaced,
// never a file found lying around, whatever its name, nor one a hand-made journal names. A
// file with a journal's name that is not a complete journal of this version is left as it is
// and reported.
#pragma once

#include <set>
#include <string>
#include <vector>

#include "bsf_vpr/io/data_directory.h"

namespace bsf_vpr {

// How a journal proves that a file is the one its save wrote (or replaced), before anything
// removes it: the file's bytes must still be those the save knew.
// "named by content": a saved .npy whose name carries the hash of its bytes
// (IsSavedDescriptorFile); "content <16 hex>": the ContentDigest of its bytes.
std::string ProofByName();
std::string ProofOfContent(const std::string& bytes);

// Paths relative to the data directory.
struct SaveFiles {
  std::string yaml;                           // the set's YAML
  std::string descriptors;                    // the new .npy: the YAML names it once saved
  std::string yaml_digest;  // ContentDigest of the new YAML: it is in place once saved
  std::vector<std::string> created;           // files the save makes (.npy, images)
  std::vector<std::string> created_proofs;    // one per created file (ProofByName, ProofOfContent)
  std::vector<std::string> created_folders;   // folders the save makes (images), new ones
  std::vector<std::string> replaced;          // the old set's own files, to go once saved
  std::vector<std::string> replaced_proofs;   // one per replaced file
  std::vector<std::string> replaced_folders;  // their folders, removed when left empty
};

// Files that a YAML below the directory (or the caller) still names: never removed.
struct NamedFiles {
  std::set<std::string> descriptor_names;  // file names (no folder) of `descriptors`
  std::set<std::string> paths;             // relative paths: images, and the caller's keep
  bool Names(const std::string& relative) const;
};

// What every YAML below `dir` names (`descriptors` by file name, whatever folder or spelling
// the YAML uses; images by path), plus `keep`. Throws std::runtime_error naming a YAML that
// cannot be read or parsed: it might name any file.
NamedFiles ScanNamedFiles(const DataDirectory& dir, const std::set<std::string>& keep);

class SaveJournal {
 public:
  // Writes and locks the journal beside files.yaml. Throws std::runtime_error if it cannot
  // (nothing of the save exists yet then).
  SaveJournal(const DataDirectory& dir, SaveFiles files);
  SaveJournal(const SaveJournal&) = delete;
  SaveJournal& operator=(const SaveJournal&) = delete;

  const SaveFiles& files() const { return files_; }
  // The save failed before its YAML was renamed into place: removes what it made (`made`,
  // `made_folders`: those of files().created it did make), then the journal. A file any YAML
  // names stays. Never throws; what cannot be removed stays, with the journal, for the next
  // start.
  void RollBack(const std::vector<std::string>& made,
                const std::vector<std::string>& made_folders) noexcept;
  // The YAML is in place: removes the replaced files that nothing else names (`keep` and
  // every YAML below the directory are asked), then the journal. Never throws.
  void Finish(const std::set<std::string>& keep) noexcept;

 private:
  const DataDirectory& dir_;
  SaveFiles files_;
  std::string path_;
  DataDirectory::LockedFile lock_;
};

// Whether `name` (no folder) is a journal's file name.
bool IsSaveJournalName(const std::string& name);

}  // namespace bsf_vpr
