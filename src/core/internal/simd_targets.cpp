#include "src/core/internal/simd_targets.h"

#include <atomic>
#include <cstdint>
#include <stdexcept>

#include "src/core/internal/distance_kernels.h"

namespace bsf_vpr {
namespace kernels {
namespace {

struct Target {
  int64_t bit;
  const char* name;
};
// Best first. HWY_TARGETS holds those compiled in on this architecture.
constexpr Target kTargets[] = {{HWY_AVX3_DL, "avx512_vnni"},
                               {HWY_AVX3, "avx512"},
                               {HWY_AVX2, "avx2"},
                               {HWY_NEON, "neon"},
                               {HWY_BASELINE_SCALAR, "portable"}};

// The targets compiled in that this CPU runs.
int64_t Runnable() { return HWY_TARGETS & hwy::SupportedTargets(); }

int64_t BestTarget() {
  for (const Target& t : kTargets) {
    if ((Runnable() & t.bit) != 0) return t.bit;
  }
  return HWY_BASELINE_SCALAR;
}

// The target the kernels run on; the dispatch state follows it.
std::atomic<int64_t> g_target{0};

struct Chosen {
  Chosen() {
    g_target = BestTarget();
    state.Update(g_target);
  }
  hwy::ChosenTarget state;
};
Chosen& TheChosen() {
  static Chosen chosen;
  return chosen;
}

void Choose(int64_t target) {
  Chosen& chosen = TheChosen();
  g_target = target;
  chosen.state.Update(target);
}

std::string Names(int64_t targets) {
  std::string out;
  for (const Target& t : kTargets) {
    if ((targets & t.bit) != 0) out += (out.empty() ? "" : ", ") + std::string(t.name);
  }
  return out;
}

}  // namespace

hwy::ChosenTarget& ChosenTarget() { return TheChosen().state; }

std::string Active() {
  TheChosen();
  for (const Target& t : kTargets) {
    if (t.bit == g_target.load()) return t.name;
  }
  return "portable";
}

std::vector<std::string> Available() {
  std::vector<std::string> out;
  for (const Target& t : kTargets) {
    if ((Runnable() & t.bit) != 0) out.push_back(t.name);
  }
  return out;
}

void Force(const std::string& name) {
  if (name == "auto") return Choose(BestTarget());
  for (const Target& t : kTargets) {
    if (name != t.name) continue;
    if ((HWY_TARGETS & t.bit) == 0) {
      throw std::invalid_argument(
          "distance kernel '" + name +
          "' is not compiled for this architecture (compiled: " + Names(HWY_TARGETS) + ")");
    }
    if ((Runnable() & t.bit) == 0) {
      throw std::invalid_argument("this CPU cannot run the distance kernel '" + name +
                                  "' (Highway target " + hwy::TargetName(t.bit) +
                                  "); it runs: " + Names(Runnable()));
    }
    return Choose(t.bit);
  }
  throw std::invalid_argument("unknown distance kernel '" + name + "' (expected auto, " +
                              Names(~int64_t{0}) + ")");
}

}  // namespace kernels
}  // namespace bsf_vpr
