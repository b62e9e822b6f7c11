#include "src/core/internal/distance_kernels.h"

#include "src/core/internal/vector_math.h"

// The dispatch among the kernels (kernels_portable.h, kernels_avx2.h, kernels_avx512.h):
// one translation unit with them, so that the -ffp-contract=off it is compiled with holds
// for every kernel.
#include <algorithm>
#include <atomic>
#include <stdexcept>
#include <vector>

#include "src/core/internal/distance_formula.h"
#include "src/core/internal/kernel_common.h"
#include "src/core/internal/kernels_avx2.h"
#include "src/core/internal/kernels_avx512.h"
#include "src/core/internal/kernels_portable.h"
#include "src/core/internal/kernels_vector_math.h"

namespace bsf_vpr {
namespace kernels {
namespace {

// ---- driver: tiles over a block of rows that stays in cache ---------------------------

// `buffer` sized for `count` floats starting on a 64-byte boundary; returns that start.
float* On64Bytes(size_t count, std::vector<float>* buffer) {
  buffer->resize(count + 16);
  float* p = buffer->data();
  return p + (16 - (reinterpret_cast<uintptr_t>(p) / sizeof(float)) % 16) % 16;
}

// In order of what they add: each runs whatever the one before it runs.
enum class Isa { kPortable, kAvx2, kAvx512, kAvx512Vnni };
std::atomic<int> g_forced{-1};  // -1: by CPU

Isa CurrentIsa() {
  const int forced = g_forced.load();
  if (forced >= 0) return static_cast<Isa>(forced);
  static const Isa by_cpu = CpuHasAvx512Vnni() ? Isa::kAvx512Vnni
                            : CpuHasAvx512()   ? Isa::kAvx512
                            : CpuHasAvx2()     ? Isa::kAvx2
                                               : Isa::kPortable;
  return by_cpu;
}

template <class T, int NQ, int NR>
void Tile(Isa isa, const TileArgs& a, const T* r, int r_stride) {
  if constexpr (std::is_same_v<T, int8_t>) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
    if (isa == Isa::kAvx512Vnni) return TileInt8Vnni<NQ, NR>(a, r, r_stride);
    if (isa != Isa::kPortable) return TileInt8Avx2<NQ, NR>(a, r, r_stride);
#endif
    TileInt8Portable<NQ, NR>(a, r, r_stride);
  } else {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
    if (isa != Isa::kPortable) return TileAvx2<T, NQ, NR>(a, r, r_stride);
#endif
    TilePortable<T, NQ, NR>(a, r, r_stride);
  }
  (void)isa;
}

// One pass of NQ queries (a.q, a.out and a.lanes at their first) over the rows [b0, b1),
// NR rows a tile and the remainder one by one.
template <class T, int NQ, int NR>
void Sweep(Isa isa, TileArgs a, const T* rows, int b0, int b1) {
  float* const out = a.out;
  float* const lanes = a.lanes;
  int r = b0;
  const auto at = [&](int row) {
    a.out = out + (row - b0);
    a.lanes = lanes ? lanes + (row - b0) * kLanes : nullptr;
    return rows + static_cast<size_t>(row) * a.d;
  };
  for (; r + NR <= b1; r += NR) Tile<T, NQ, NR>(isa, a, at(r), a.d);
  for (; r < b1; ++r) Tile<T, NQ, 1>(isa, a, at(r), a.d);
}

#ifdef BSF_VPR_HAVE_AVX2_KERNEL
// The same over pairs of queries (a.pairs, a.out and a.lanes at the pair's first query).
template <int NP, int NR>
void SweepPairs(TileArgs a, const float* rows, int b0, int b1) {
  float* const out = a.out;
  float* const lanes = a.lanes;
  const auto at = [&](int row) {
    a.out = out + (row - b0);
    a.lanes = lanes ? lanes + (row - b0) * 2 * kLanes : nullptr;
    return rows + static_cast<size_t>(row) * a.d;
  };
  int r = b0;
  for (; r + NR <= b1; r += NR) TilePairsAvx512<NP, NR>(a, at(r), a.d);
  for (; r < b1; ++r) TilePairsAvx512<NP, 1>(a, at(r), a.d);
}
#endif

// Queries from which a tile gains by passes over L1-sized pieces of the rows (and by an
// aligned copy of the queries).
constexpr int kBatchQueries = 8;
// Queries from which the AVX-512 kernel runs a batch by lane (DotsLanesAvx512): the rows'
// packing is paid back by the panels of queries that pass over them.
[[maybe_unused]] constexpr int kPackQueries = 32;  // (x86 kernels only)

#ifdef BSF_VPR_HAVE_AVX2_KERNEL
// A large float32 or float16 batch on the AVX-512 kernel: the rows 32 at a time packed by lane
// (PackRowLanesAvx512, in L2 while every panel of 12 queries passes over them), then made
// distances while in cache. Measured on a 2-core AMD EPYC (Zen 5), 500 queries x 9000 rows x
// 4096: 93-99% of OpenBLAS sgemm's throughput, where the pair tiles over packed rows reached
// 79-85% (their 18.7 bytes loaded per FMA against the lane tiles' 7.7).
template <class T>
void DotsLanesAvx512(const T* rows, int r0, int r1, const Queries& queries, float* out,
                     int out_stride, const ToDistancesArgs* finish) {
  const int d = queries.cols, steps = queries.lane_steps, num_queries = queries.rows;
  std::vector<float> packing;
  float* const packed = On64Bytes(static_cast<size_t>(kLanes) * steps * kLaneRows, &packing);
  const size_t panel = static_cast<size_t>(kLanes) * steps * kLaneQueries;
  for (int b0 = r0; b0 < r1; b0 += kLaneRows) {
    const int count = std::min(kLaneRows, r1 - b0);
    PackRowLanesAvx512(rows, d, b0, count, packed);
    for (int q0 = 0; q0 < num_queries; q0 += kLaneQueries) {
      TileLanesAvx512(queries.lanes.data() + (q0 / kLaneQueries) * panel, packed, steps,
                      out + static_cast<size_t>(q0) * out_stride + (b0 - r0), out_stride,
                      std::min(kLaneQueries, num_queries - q0), count);
    }
    if (finish != nullptr) {
      for (int q = 0; q < num_queries; ++q) {
        formula::ToDistances(finish->metric, finish->query_squared_norms[q],
                             finish->row_squared_norms + b0, 0, count,
                             out + static_cast<size_t>(q) * out_stride + (b0 - r0));
      }
    }
  }
}
#endif

template <class T>
void DotsTyped(const T* rows, float scale, int r0, int r1, const Queries& queries, float* out,
               int out_stride, const ToDistancesArgs* finish) {
  const Isa isa = CurrentIsa();
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
  if constexpr (!std::is_same_v<T, int8_t>) {
    if (isa >= Isa::kAvx512 && !queries.lanes.empty()) {
      return DotsLanesAvx512(rows, r0, r1, queries, out, out_stride, finish);
    }
  }
#endif
  const int d = queries.cols, num_queries = queries.rows;
  // Like a matrix product's blocking: rows in blocks of 96 (in L2 while a block of 32
  // queries passes over them), and rows cut into passes of 1024 elements, so that a tile's
  // pieces (4 queries and 3 rows, at most 28 KiB) stay in L1 while it works on them. A few
  // queries get no reuse from it, so they take whole rows (sequential reads, for memory).
  // (Measured on the project's machine: passes of 512-1024 reach about 1.5x the speed of
  // whole rows for 256 queries x 3000 rows x 4096.)
  constexpr int kRowBlock = 96, kQueryBlock = 32;
  const bool int8_rows = std::is_same_v<T, int8_t>;
  if (int8_rows && queries.levels.empty()) {
    throw std::logic_error("int8 rows need queries prepared with int16 levels");
  }
  // The AVX-512 tiles (8 queries x 6 rows) were measured with passes of 256 to 4096 on a
  // 2-core AMD EPYC (Zen 4): 1024 and longer equally fast, 256 and 512 slower.
  const bool pairs = std::is_same_v<T, float> && isa >= Isa::kAvx512 && !queries.pairs.empty();
  const int chunk = num_queries >= kBatchQueries && !int8_rows ? 1024 : d;
  std::vector<float> lanes(chunk < d ? static_cast<size_t>(kQueryBlock) * kRowBlock * kLanes : 0);
  const int lanes_stride = kRowBlock * kLanes;
  for (int b0 = r0; b0 < r1; b0 += kRowBlock) {
    const int b1 = std::min(r1, b0 + kRowBlock);
    for (int qb0 = 0; qb0 < num_queries; qb0 += kQueryBlock) {
      const int qb1 = std::min(num_queries, qb0 + kQueryBlock);
      for (int i0 = 0; i0 < d; i0 += chunk) {
        TileArgs a;
        a.q_stride = int8_rows ? d : queries.stride;  // int16 levels are packed
        a.i0 = i0;
        a.i1 = std::min(d, i0 + chunk);
        a.d = d;
        a.first = i0 == 0;
        a.lanes_stride = lanes_stride;
        a.scale = scale;
        a.out_stride = out_stride;
        const auto for_query = [&](int q) {
          a.q = queries.data + static_cast<size_t>(q) * queries.stride;
          if (int8_rows) {
            a.q16 = queries.levels.data() + static_cast<size_t>(q) * d;
            a.q_scales = queries.scales.data() + q;
          }
          a.out = out + static_cast<size_t>(q) * out_stride + (b0 - r0);
          if (!lanes.empty()) a.lanes = lanes.data() + static_cast<size_t>(q - qb0) * lanes_stride;
          return a;
        };
        int q = qb0;
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
        if constexpr (std::is_same_v<T, float>) {
          if (pairs) {  // pair p = q / 2 (a block starts on an even query)
            const auto for_pair = [&](int first) {
              TileArgs b = for_query(first);
              b.pairs =
                  queries.pairs.data() + static_cast<size_t>(first / 2) * queries.pairs_stride;
              b.pairs_stride = queries.pairs_stride;
              b.lanes_stride = 2 * lanes_stride;
              return b;
            };
            for (; q + 8 <= qb1; q += 8) SweepPairs<4, 6>(for_pair(q), rows, b0, b1);
            for (; q + 2 <= qb1; q += 2) SweepPairs<1, 6>(for_pair(q), rows, b0, b1);
          }
        }
#endif
        for (; q + 4 <= qb1; q += 4) Sweep<T, 4, 3>(isa, for_query(q), rows, b0, b1);
        for (; q < qb1; ++q) Sweep<T, 1, 6>(isa, for_query(q), rows, b0, b1);
      }
      if (finish != nullptr) {
        for (int q = qb0; q < qb1; ++q) {
          formula::ToDistances(finish->metric, finish->query_squared_norms[q],
                               finish->row_squared_norms + b0, 0, b1 - b0,
                               out + static_cast<size_t>(q) * out_stride + (b0 - r0));
        }
      }
    }
  }
}

}  // namespace

Queries PrepareQueries(const float* data, int rows, int stride, int cols, bool int16_levels) {
  Queries out;
  out.data = data;
  out.rows = rows;
  out.cols = cols;
  out.stride = stride;
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
  const bool by_lanes = rows >= kPackQueries && CurrentIsa() >= Isa::kAvx512;
#else
  const bool by_lanes = false;
#endif
  if (by_lanes) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
    // Panels of 12 queries, each lane's elements in order (TileLanesAvx512).
    const int steps = (cols + kLanes - 1) / kLanes;
    const int panels = (rows + kLaneQueries - 1) / kLaneQueries;
    out.lane_steps = steps;
    out.lanes.assign(static_cast<size_t>(panels) * kLanes * steps * kLaneQueries, 0.0f);
    for (int q = 0; q < rows; ++q) {
      const float* from = data + static_cast<size_t>(q) * stride;
      float* to = out.lanes.data() +
                  static_cast<size_t>(q / kLaneQueries) * kLanes * steps * kLaneQueries +
                  q % kLaneQueries;
      for (int i = 0; i < cols; ++i) {
        to[(static_cast<size_t>(i % kLanes) * steps + i / kLanes) * kLaneQueries] = from[i];
      }
    }
#endif
  } else if (rows >= kBatchQueries && CurrentIsa() >= Isa::kAvx512) {
    // Pairs of queries interleaved in blocks of eight, zero-padded to a whole block, for
    // the AVX-512 tiles (an odd last query is read where it is).
    const int blocks = (cols + kLanes - 1) / kLanes;
    out.pairs_stride = 2 * kLanes * blocks;
    out.pairs.assign(static_cast<size_t>(rows / 2) * out.pairs_stride + 16, 0.0f);
    for (int q = 0; q < rows / 2 * 2; ++q) {
      const float* from = data + static_cast<size_t>(q) * stride;
      float* to =
          out.pairs.data() + static_cast<size_t>(q / 2) * out.pairs_stride + (q % 2) * kLanes;
      for (int i = 0; i < cols; ++i) to[(i / kLanes) * 2 * kLanes + i % kLanes] = from[i];
    }
  } else if (rows >= kBatchQueries) {  // a batch reads every query many times: align its rows
    const int aligned_stride = (cols + 15) / 16 * 16;
    float* const base = On64Bytes(static_cast<size_t>(rows) * aligned_stride, &out.aligned);
    for (int q = 0; q < rows; ++q) {
      const float* from = data + static_cast<size_t>(q) * stride;
      std::copy(from, from + cols, base + static_cast<size_t>(q) * aligned_stride);
    }
    out.data = base;
    out.stride = aligned_stride;
  }
  if (int16_levels) {
    const int levels = QueryLevels(cols);
    out.levels.resize(static_cast<size_t>(rows) * cols);
    out.scales.resize(static_cast<size_t>(rows));
    for (int q = 0; q < rows; ++q) {
      const float* x = data + static_cast<size_t>(q) * stride;
      float max_abs = 0;
      for (int i = 0; i < cols; ++i) max_abs = std::max(max_abs, std::fabs(x[i]));
      const float s = max_abs > 0 ? max_abs / static_cast<float>(levels) : 1.0f;
      out.scales[static_cast<size_t>(q)] = s;
      for (int i = 0; i < cols; ++i) {
        const float level = std::nearbyint(x[i] / s);
        out.levels[static_cast<size_t>(q) * cols + i] = static_cast<int16_t>(
            std::clamp(level, -static_cast<float>(levels), static_cast<float>(levels)));
      }
    }
  }
  return out;
}

void Dots(const RefRows& refs, int r0, int r1, const Queries& queries, float* out, int out_stride,
          const ToDistancesArgs* finish) {
  switch (refs.precision) {
    case StoragePrecision::kFloat32:
      DotsTyped(static_cast<const float*>(refs.data), 1.0f, r0, r1, queries, out, out_stride,
                finish);
      break;
    case StoragePrecision::kFloat16:
      DotsTyped(static_cast<const uint16_t*>(refs.data), 1.0f, r0, r1, queries, out, out_stride,
                finish);
      break;
    case StoragePrecision::kInt8:
      DotsTyped(static_cast<const int8_t*>(refs.data), refs.scale, r0, r1, queries, out, out_stride,
                finish);
      break;
  }
}

float SelfDot(const float* x, int n) {
  float out = 0;
  TileArgs a;
  a.q = x;
  a.q_stride = n;
  a.i1 = a.d = n;
  a.out = &out;
  a.out_stride = 1;
  Tile<float, 1, 1>(CurrentIsa(), a, x, n);
  return out;
}

double Exp(const double* x, Eigen::Index n, double shift, double* out) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
  const Isa isa = CurrentIsa();
  if (isa >= Isa::kAvx512) return ExpKernelAvx512(x, n, shift, out);
  if (isa == Isa::kAvx2) return ExpKernelAvx2(x, n, shift, out);
#endif
  return ExpPortable(x, n, shift, out);
}

void Log(const double* x, Eigen::Index n, double* out) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
  const Isa isa = CurrentIsa();
  if (isa >= Isa::kAvx512) return LogKernelAvx512(x, n, out);
  if (isa == Isa::kAvx2) return LogKernelAvx2(x, n, out);
#endif
  LogPortable(x, n, out);
}

double SumExp(const double* x, Eigen::Index n, double shift) { return Exp(x, n, shift, nullptr); }

double StepSums(const double* p, Eigen::Index n, const double* w, int taps, long s_lo,
                double* moved) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
  const Isa isa = CurrentIsa();
  if (isa >= Isa::kAvx512) return StepSumsAvx512(p, n, w, taps, s_lo, moved);
  if (isa == Isa::kAvx2) return StepSumsAvx2(p, n, w, taps, s_lo, moved);
#endif
  return StepSumsPortable(p, n, w, taps, s_lo, moved);
}

double ScaleShiftMultiply(double* x, Eigen::Index n, double a, double b, const double* l) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
  const Isa isa = CurrentIsa();
  if (isa >= Isa::kAvx512) return ScaleShiftMultiplyAvx512(x, n, a, b, l);
  if (isa == Isa::kAvx2) return ScaleShiftMultiplyAvx2(x, n, a, b, l);
#endif
  return ScaleShiftMultiplyPortable(x, n, a, b, l);
}

void AddScaled(double* y, const double* const* x, const double* a, int m, Eigen::Index n) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
  const Isa isa = CurrentIsa();
  if (isa >= Isa::kAvx512) return AddScaledAvx512(y, x, a, m, n);
  if (isa == Isa::kAvx2) return AddScaledAvx2(y, x, a, m, n);
#endif
  AddScaledPortable(y, x, a, m, n);
}

double LaneSum(const float* v, int n, float* low) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
  const Isa isa = CurrentIsa();
  if (isa >= Isa::kAvx512) return LaneSumAvx512(v, n, low);
  if (isa == Isa::kAvx2) return LaneSumAvx2(v, n, low);
#endif
  return LaneSumPortable(v, n, low);
}

double LaneDifferenceSum(const float* d, const float* c, int n, float* out) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
  const Isa isa = CurrentIsa();
  if (isa >= Isa::kAvx512) return LaneDifferenceSumAvx512(d, c, n, out);
  if (isa == Isa::kAvx2) return LaneDifferenceSumAvx2(d, c, n, out);
#endif
  return LaneDifferenceSumPortable(d, c, n, out);
}

double LaneSquaredDeviations(const float* v, int n, double mean) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
  const Isa isa = CurrentIsa();
  if (isa >= Isa::kAvx512) return LaneSquaredDeviationsAvx512(v, n, mean);
  if (isa == Isa::kAvx2) return LaneSquaredDeviationsAvx2(v, n, mean);
#endif
  return LaneSquaredDeviationsPortable(v, n, mean);
}

std::string Active() {
  switch (CurrentIsa()) {
    case Isa::kAvx512Vnni:
      return "avx512_vnni";
    case Isa::kAvx512:
      return "avx512";
    case Isa::kAvx2:
      return "avx2";
    case Isa::kPortable:
      break;
  }
  return "portable";
}

void Force(const std::string& name) {
  if (name == "auto") {
    g_forced = -1;
  } else if (name == "portable") {
    g_forced = static_cast<int>(Isa::kPortable);
  } else if (name == "avx2") {
    if (!CpuHasAvx2()) throw std::invalid_argument("this CPU lacks AVX2, FMA or F16C");
    g_forced = static_cast<int>(Isa::kAvx2);
  } else if (name == "avx512") {
    if (!CpuHasAvx512()) throw std::invalid_argument("this CPU lacks AVX-512 (F and DQ)");
    g_forced = static_cast<int>(Isa::kAvx512);
  } else if (name == "avx512_vnni") {
    if (!CpuHasAvx512Vnni()) {
      throw std::invalid_argument("this CPU lacks AVX-512 VNNI (with F, DQ and BW)");
    }
    g_forced = static_cast<int>(Isa::kAvx512Vnni);
  } else {
    throw std::invalid_argument("unknown distance kernel '" + name +
                                "' (expected auto, avx512_vnni, avx512, avx2 or portable)");
  }
}

}  // namespace kernels
}  // namespace bsf_vpr
