// libFuzzer target for the reference-set YAML reader, both as the tools call it (a path:
// LoadReferenceSetYaml) and as the node's services do (a request below a data directory:
// LoadReferenceSetFile with a DataDirectory), and for the validation a loaded set then meets
// on its way into a map (ReferenceSets::Add).
//
// The reader takes a path, so each input is written to set.yaml in a private temporary
// folder made once, next to the small valid descriptor files of fuzz_fixture.h (a.npy,
// b.npy) that an input may name as its 'descriptors': the YAML parser, the key checks,
// place_ids, poses and images all get exercised, not only the refusal of a missing .npy.
//
// A std::exception is the expected answer to a bad file. Anything else (a crash, a sanitizer
// report, an allocation beyond -malloc_limit_mb) is a finding.
#include <fcntl.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/io/data_directory.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "test/fuzz/fuzz_fixture.h"

namespace bsf_vpr {
namespace fuzz {
namespace {

std::string g_dir;        // private temporary folder, made once
std::string g_yaml_path;  // <g_dir>/set.yaml

void RemoveTempDir() {
  std::remove(g_yaml_path.c_str());
  for (const FixtureNpy& f : kFixtureNpyFiles) std::remove((g_dir + "/" + f.file_name).c_str());
  rmdir(g_dir.c_str());
}

// Plain write, no fsync: the file only has to be readable by this process.
void WriteInput(const uint8_t* data, size_t size) {
  const int fd = open(g_yaml_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  size_t written = 0;
  while (fd >= 0 && written < size) {
    const ssize_t n = write(fd, data + written, size - written);
    if (n <= 0) break;
    written += static_cast<size_t>(n);
  }
  if (fd < 0 || close(fd) != 0 || written != size) {
    std::fprintf(stderr, "fuzz_reference_set_yaml: cannot write '%s'\n", g_yaml_path.c_str());
    std::exit(2);
  }
}

}  // namespace
}  // namespace fuzz
}  // namespace bsf_vpr

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  using namespace bsf_vpr::fuzz;
  g_dir = MakePrivateTempDir("bsf_fuzz_yaml");
  g_yaml_path = g_dir + "/set.yaml";
  std::atexit(RemoveTempDir);
  WriteFixtureNpyFiles(g_dir);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace bsf_vpr;
  using namespace bsf_vpr::fuzz;
  static const DataDirectory dir(g_dir);
  WriteInput(data, size);
  try {
    ReferenceSets map;
    map.Add(LoadReferenceSetYaml(g_yaml_path));
  } catch (const std::exception&) {
  }
  try {
    ReferenceSets map;
    map.Add(LoadReferenceSetFile(dir, "set.yaml", ""));
  } catch (const std::exception&) {
  }
  return 0;
}
