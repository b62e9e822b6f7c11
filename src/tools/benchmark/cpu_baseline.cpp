#include "src/tools/benchmark/cpu_baseline.h"

#include <cblas.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

namespace bsf_vpr {
namespace tools {
namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// The value of "key : value" lines of /proc/cpuinfo's first processor.
std::string Field(const std::string& text, const std::string& key) {
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(key, 0) != 0) continue;
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string v = line.substr(colon + 1);
    v.erase(0, v.find_first_not_of(" \t"));
    return v;
  }
  return "";
}

}  // namespace

CpuInfo ReadCpuInfo() {
  std::ifstream in("/proc/cpuinfo");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  CpuInfo cpu;
  cpu.model = Field(text, "model name");
  cpu.vendor = Field(text, "vendor_id");
  cpu.family = std::atoi(Field(text, "cpu family").c_str());
  cpu.model_number = std::atoi(Field(text, "model\t").c_str());
  std::set<std::string> flags;
  std::istringstream words(Field(text, "flags"));
  for (std::string w; words >> w;) flags.insert(w);
  const char* const kShown[] = {"sse4_2",      "avx",      "avx2",        "fma",
                                "f16c",        "avx_vnni", "avx512f",     "avx512bw",
                                "avx512dq",    "avx512vl", "avx512_vnni", "avx512_bf16",
                                "avx512_fp16", "amx_tile", "amx_int8",    "amx_bf16"};
  for (const char* f : kShown) {
    if (flags.count(f)) cpu.extensions += (cpu.extensions.empty() ? "" : " ") + std::string(f);
  }
  cpu.avx2 = flags.count("avx2") && flags.count("fma");
  cpu.avx512 = flags.count("avx512f") && flags.count("avx512bw") && flags.count("avx512dq") &&
               flags.count("avx512vl");
  return cpu;
}

std::string FittingOpenBlasCore(const CpuInfo& cpu) {
  if (cpu.avx512) return "SkylakeX";
  if (cpu.avx2) return "Haswell";
  return "";
}

bool CoreFits(const std::string& corename, const std::string& fitting) {
  const std::string c = Lower(corename);
  const bool avx512 = c == "skylakex" || c == "cooperlake" || c == "sapphirerapids";
  const bool avx2 = avx512 || c == "haswell" || c == "zen" || c == "skylake";
  if (fitting == "SkylakeX") return avx512;
  if (fitting == "Haswell") return avx2;
  return true;
}

void EnsureFittingOpenBlas(char** argv) {
  if (std::getenv("OPENBLAS_CORETYPE") != nullptr) return;  // the user's, or chosen already
  const std::string fitting = FittingOpenBlasCore(ReadCpuInfo());
  const std::string own = openblas_get_corename();
  if (fitting.empty() || CoreFits(own, fitting)) return;
  setenv("OPENBLAS_CORETYPE", fitting.c_str(), 1);
  setenv("BSF_OPENBLAS_CHOSEN", ("OpenBLAS's own detection gave " + own).c_str(), 1);
  execv("/proc/self/exe", argv);  // returns only on failure: go on with OpenBLAS's own
  unsetenv("OPENBLAS_CORETYPE");
  unsetenv("BSF_OPENBLAS_CHOSEN");
}

std::string MachineLine() {
  const CpuInfo cpu = ReadCpuInfo();
  std::ostringstream line;
  line << "machine " << (cpu.model.empty() ? "unknown CPU" : cpu.model) << " (" << cpu.vendor
       << ", family " << cpu.family << " model " << cpu.model_number << "), "
       << std::thread::hardware_concurrency()
       << " cores; vector extensions: " << (cpu.extensions.empty() ? "none listed" : cpu.extensions)
       << "; OpenBLAS kernel " << openblas_get_corename();
  const char* set = std::getenv("OPENBLAS_CORETYPE");
  const char* chosen = std::getenv("BSF_OPENBLAS_CHOSEN");
  if (chosen != nullptr && set != nullptr) {
    line << " (OPENBLAS_CORETYPE=" << set << ", chosen from the CPU's features: " << chosen << ")";
  } else if (set != nullptr) {
    line << " (OPENBLAS_CORETYPE=" << set << ", set by the caller)";
    const std::string fitting = FittingOpenBlasCore(cpu);
    if (!fitting.empty() && !CoreFits(openblas_get_corename(), fitting)) {
      line << "; NOT FAIR: that kernel is narrower than this CPU's " << fitting
           << " width, so the OpenBLAS and NumPy baselines run slower than they can (unset "
              "OPENBLAS_CORETYPE and OPENBLAS_L2_SIZE to let bsf_benchmark choose)";
    }
  } else {
    line << " (OpenBLAS's own detection, which fits the CPU)";
  }
  return line.str();
}

}  // namespace tools
}  // namespace bsf_vpr
