// Built with -ffp-contract=off (CMakeLists.txt): the portable kernel must multiply then add
// exactly as written, whatever the compiler would fuse, for the summation order to hold.
#include "src/core/internal/distance_kernels.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <type_traits>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#include <immintrin.h>
#define BSF_VPR_HAVE_AVX2_KERNEL 1
#define BSF_VPR_AVX2 __attribute__((target("avx2,fma,f16c")))
#define BSF_VPR_AVX512 __attribute__((target("avx512f,avx512dq,avx2,fma,f16c")))
#endif

namespace bsf_vpr {
namespace kernels {
namespace {

constexpr int kLanes = 8;

// The fixed reduction tree of the eight lanes.
inline float ReduceLanes(const float* l) {
  return ((l[0] + l[4]) + (l[1] + l[5])) + ((l[2] + l[6]) + (l[3] + l[7]));
}

inline float Decode(float v) { return v; }
inline float Decode(uint16_t v) { return HalfToFloat(v); }

// The last, partial block of a row, zero-padded to eight lanes.
template <class T>
inline void PadTail(const T* row, int from, int n, float* lanes) {
  for (int k = 0; k < kLanes; ++k) lanes[k] = from + k < n ? Decode(row[from + k]) : 0.0f;
}

// ---- portable kernel: eight lanes as a float array --------------------------------------

// A tile: NQ queries x NR rows over the elements [i0, i1) of a row. `first`: the lanes start
// at zero, else they continue from `lanes` (pair (j, k) at lanes + j * lanes_stride + k * 8).
// At the row's end (i1 == d) the lanes are reduced into out[j * out_stride + k]; before it
// they are stored back to `lanes`. Splitting a row into such passes keeps every lane's
// additions in the same order, so chunked and whole-row tiles give the same bits.
struct TileArgs {
  const float* q = nullptr;
  int q_stride = 0;
  int i0 = 0, i1 = 0, d = 0;
  bool first = true;
  float* lanes = nullptr;
  int lanes_stride = 0;
  float* out = nullptr;
  int out_stride = 0;
  // int8 rows only: the queries rounded to int16 (query j at q16 + j * q_stride), the scale
  // of each (q_scales[j]) and the rows' scale.
  float scale = 1.0f;
  const int16_t* q16 = nullptr;
  const float* q_scales = nullptr;
  // AVX-512 pair tiles only: queries 2p and 2p + 1 interleaved in blocks of eight elements
  // (pair p at pairs + p * pairs_stride; see Queries::pairs).
  const float* pairs = nullptr;
  int pairs_stride = 0;
};

// ---- int8 rows: integer inner products -----------------------------------------------
// The query is rounded to int16 with its own scale and each pair's products are summed
// exactly in integers (int32 lanes that cannot overflow, see QueryLevels), so the value
// does not depend on any order: both kernels and every tile give the same bits.

inline float Int8Result(int64_t sum, float row_scale, float query_scale) {
  return static_cast<float>(static_cast<double>(sum) *
                            (static_cast<double>(row_scale) * static_cast<double>(query_scale)));
}

// Largest |int16 level| of a query such that an int32 lane (d / 8 products of at most
// 127 x level) cannot overflow.
int QueryLevels(int d) {
  const int64_t bound = (int64_t{2147483647} * 8) / (int64_t{127} * std::max(d, 8));
  return static_cast<int>(std::min<int64_t>(32767, bound));
}

template <int NQ, int NR>
void TileInt8Portable(const TileArgs& a, const int8_t* r, int r_stride) {
  for (int j = 0; j < NQ; ++j) {
    const int16_t* q = a.q16 + j * a.q_stride;
    for (int k = 0; k < NR; ++k) {
      const int8_t* row = r + k * r_stride;
      int64_t sum = 0;
      for (int i = 0; i < a.d; ++i) sum += static_cast<int32_t>(q[i]) * row[i];
      a.out[j * a.out_stride + k] = Int8Result(sum, a.scale, a.q_scales[j]);
    }
  }
}

template <class T, int NQ, int NR>
void TilePortable(const TileArgs& a, const T* r, int r_stride) {
  float acc[NQ][NR][kLanes];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) {
      for (int l = 0; l < kLanes; ++l) {
        acc[j][k][l] = a.first ? 0.0f : a.lanes[j * a.lanes_stride + k * kLanes + l];
      }
    }
  }
  int i = a.i0;
  for (; i + kLanes <= a.i1; i += kLanes) {
    for (int k = 0; k < NR; ++k) {
      float rv[kLanes];
      for (int l = 0; l < kLanes; ++l) rv[l] = Decode(r[k * r_stride + i + l]);
      for (int j = 0; j < NQ; ++j) {
        const float* qj = a.q + j * a.q_stride + i;
        for (int l = 0; l < kLanes; ++l) acc[j][k][l] = acc[j][k][l] + qj[l] * rv[l];
      }
    }
  }
  if (a.i1 < a.d) {
    for (int j = 0; j < NQ; ++j) {
      for (int k = 0; k < NR; ++k) {
        for (int l = 0; l < kLanes; ++l)
          a.lanes[j * a.lanes_stride + k * kLanes + l] = acc[j][k][l];
      }
    }
    return;
  }
  if (i < a.d) {
    for (int k = 0; k < NR; ++k) {
      float rv[kLanes];
      PadTail(r + k * r_stride, i, a.d, rv);
      for (int j = 0; j < NQ; ++j) {
        float qv[kLanes];
        PadTail(a.q + j * a.q_stride, i, a.d, qv);
        for (int l = 0; l < kLanes; ++l) acc[j][k][l] = acc[j][k][l] + qv[l] * rv[l];
      }
    }
  }
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) a.out[j * a.out_stride + k] = ReduceLanes(acc[j][k]);
  }
}

// ---- AVX2 kernel: eight lanes as one __m256, FMA ------------------------------------------

#ifdef BSF_VPR_HAVE_AVX2_KERNEL
BSF_VPR_AVX2 inline __m256 Load8(const float* p) { return _mm256_loadu_ps(p); }
BSF_VPR_AVX2 inline __m256 Load8(const uint16_t* p) {
  return _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
}

template <class T, int NQ, int NR>
BSF_VPR_AVX2 void TileAvx2(const TileArgs& a, const T* r, int r_stride) {
  __m256 acc[NQ][NR];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) {
      acc[j][k] = a.first ? _mm256_setzero_ps()
                          : _mm256_loadu_ps(a.lanes + j * a.lanes_stride + k * kLanes);
    }
  }
  int i = a.i0;
  for (; i + kLanes <= a.i1; i += kLanes) {
    __m256 rv[NR];
    for (int k = 0; k < NR; ++k) rv[k] = Load8(r + k * r_stride + i);
    for (int j = 0; j < NQ; ++j) {
      const __m256 qv = _mm256_loadu_ps(a.q + j * a.q_stride + i);
      for (int k = 0; k < NR; ++k) acc[j][k] = _mm256_fmadd_ps(qv, rv[k], acc[j][k]);
    }
  }
  if (a.i1 < a.d) {
    for (int j = 0; j < NQ; ++j) {
      for (int k = 0; k < NR; ++k)
        _mm256_storeu_ps(a.lanes + j * a.lanes_stride + k * kLanes, acc[j][k]);
    }
    return;
  }
  if (i < a.d) {
    alignas(32) float pad[kLanes];
    __m256 rv[NR];
    for (int k = 0; k < NR; ++k) {
      PadTail(r + k * r_stride, i, a.d, pad);
      rv[k] = _mm256_load_ps(pad);
    }
    for (int j = 0; j < NQ; ++j) {
      PadTail(a.q + j * a.q_stride, i, a.d, pad);
      const __m256 qv = _mm256_load_ps(pad);
      for (int k = 0; k < NR; ++k) acc[j][k] = _mm256_fmadd_ps(qv, rv[k], acc[j][k]);
    }
  }
  alignas(32) float lanes[kLanes];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) {
      _mm256_store_ps(lanes, acc[j][k]);
      a.out[j * a.out_stride + k] = ReduceLanes(lanes);
    }
  }
}

template <int NQ, int NR>
BSF_VPR_AVX2 void TileInt8Avx2(const TileArgs& a, const int8_t* r, int r_stride) {
  __m256i acc[NQ][NR];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) acc[j][k] = _mm256_setzero_si256();
  }
  int i = 0;
  for (; i + 16 <= a.d; i += 16) {
    __m256i rv[NR];
    for (int k = 0; k < NR; ++k) {
      rv[k] = _mm256_cvtepi8_epi16(
          _mm_loadu_si128(reinterpret_cast<const __m128i*>(r + k * r_stride + i)));
    }
    for (int j = 0; j < NQ; ++j) {
      const __m256i qv =
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(a.q16 + j * a.q_stride + i));
      for (int k = 0; k < NR; ++k) {
        acc[j][k] = _mm256_add_epi32(acc[j][k], _mm256_madd_epi16(qv, rv[k]));
      }
    }
  }
  alignas(32) int32_t lanes[8];
  for (int j = 0; j < NQ; ++j) {
    const int16_t* q = a.q16 + j * a.q_stride;
    for (int k = 0; k < NR; ++k) {
      _mm256_store_si256(reinterpret_cast<__m256i*>(lanes), acc[j][k]);
      int64_t sum = 0;
      for (int32_t l : lanes) sum += l;
      const int8_t* row = r + k * r_stride;
      for (int t = i; t < a.d; ++t) sum += static_cast<int32_t>(q[t]) * row[t];
      a.out[j * a.out_stride + k] = Int8Result(sum, a.scale, a.q_scales[j]);
    }
  }
}

bool CpuHasAvx2() {
  // F16C from CPUID leaf 1 directly: clang before 16 refuses __builtin_cpu_supports("f16c").
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  const bool f16c = __get_cpuid(1, &eax, &ebx, &ecx, &edx) && (ecx & bit_F16C) != 0;
  return f16c && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}

// ---- AVX-512 kernel: two queries' eight lanes in one __m512 -----------------------------
// The same eight lanes, order and FMA as the AVX2 kernel, so the bits are the same: the low
// half of a register holds query 2p's lanes for a row and the high half query 2p + 1's, the
// row's eight elements broadcast to both halves. A 4-pair x 6-row tile keeps 24 registers of
// sums (384 pairs' lanes) busy for 10 loads per eight elements, where the AVX2 tile of 4 x 3
// keeps 12 for 7 loads. Float32 rows in batches only; the rest is the AVX2 kernel's.

// GCC 12's _mm512_broadcast_f32x8 starts from an undefined register, which it then warns of.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
template <int NP, int NR>
BSF_VPR_AVX512 void TilePairsAvx512(const TileArgs& a, const float* r, int r_stride) {
  __m512 acc[NP][NR];
  // Pair p's lanes for row k: 16 floats at a.lanes + p * a.lanes_stride + k * 16.
  for (int p = 0; p < NP; ++p) {
    for (int k = 0; k < NR; ++k) {
      acc[p][k] = a.first ? _mm512_setzero_ps()
                          : _mm512_loadu_ps(a.lanes + p * a.lanes_stride + k * 2 * kLanes);
    }
  }
  const int full = a.i1 - (a.i1 - a.i0) % kLanes;  // a pass ends on a block unless at d
  for (int i = a.i0; i < full; i += kLanes) {
    __m512 qv[NP];
    for (int p = 0; p < NP; ++p) qv[p] = _mm512_loadu_ps(a.pairs + p * a.pairs_stride + 2 * i);
    for (int k = 0; k < NR; ++k) {
      const __m512 rv = _mm512_broadcast_f32x8(_mm256_loadu_ps(r + k * r_stride + i));
      for (int p = 0; p < NP; ++p) acc[p][k] = _mm512_fmadd_ps(qv[p], rv, acc[p][k]);
    }
  }
  if (a.i1 < a.d) {
    for (int p = 0; p < NP; ++p) {
      for (int k = 0; k < NR; ++k) {
        _mm512_storeu_ps(a.lanes + p * a.lanes_stride + k * 2 * kLanes, acc[p][k]);
      }
    }
    return;
  }
  if (full < a.d) {  // the zero-padded tail: the pairs are padded already
    alignas(32) float pad[kLanes];
    __m512 qv[NP];
    for (int p = 0; p < NP; ++p) qv[p] = _mm512_loadu_ps(a.pairs + p * a.pairs_stride + 2 * full);
    for (int k = 0; k < NR; ++k) {
      PadTail(r + k * r_stride, full, a.d, pad);
      const __m512 rv = _mm512_broadcast_f32x8(_mm256_load_ps(pad));
      for (int p = 0; p < NP; ++p) acc[p][k] = _mm512_fmadd_ps(qv[p], rv, acc[p][k]);
    }
  }
  alignas(64) float lanes[2 * kLanes];
  for (int p = 0; p < NP; ++p) {
    for (int k = 0; k < NR; ++k) {
      _mm512_store_ps(lanes, acc[p][k]);
      a.out[(2 * p) * a.out_stride + k] = ReduceLanes(lanes);
      a.out[(2 * p + 1) * a.out_stride + k] = ReduceLanes(lanes + kLanes);
    }
  }
}
#pragma GCC diagnostic pop

bool CpuHasAvx512() {
  return CpuHasAvx2() && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq");
}
#else
bool CpuHasAvx2() { return false; }
bool CpuHasAvx512() { return false; }
#endif

// ---- driver: tiles over a block of rows that stays in cache ---------------------------

enum class Isa { kPortable, kAvx2, kAvx512 };
std::atomic<int> g_forced{-1};  // -1: by CPU

Isa CurrentIsa() {
  const int forced = g_forced.load();
  if (forced >= 0) return static_cast<Isa>(forced);
  static const Isa by_cpu =
      CpuHasAvx512() ? Isa::kAvx512 : (CpuHasAvx2() ? Isa::kAvx2 : Isa::kPortable);
  return by_cpu;
}

template <class T, int NQ, int NR>
void Tile(Isa isa, const TileArgs& a, const T* r, int r_stride) {
  if constexpr (std::is_same_v<T, int8_t>) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
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

template <class T>
void DotsTyped(const T* rows, float scale, int r0, int r1, const Queries& queries, float* out,
               int out_stride) {
  const Isa isa = CurrentIsa();
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
  const bool pairs = std::is_same_v<T, float> && isa == Isa::kAvx512 && !queries.pairs.empty();
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
  if (rows >= kBatchQueries && CurrentIsa() == Isa::kAvx512) {
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
    out.aligned.resize(static_cast<size_t>(rows) * aligned_stride + 16);
    float* base = out.aligned.data();
    base += (16 - (reinterpret_cast<uintptr_t>(base) / sizeof(float)) % 16) % 16;
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

void Dots(const RefRows& refs, int r0, int r1, const Queries& queries, float* out, int out_stride) {
  switch (refs.precision) {
    case StoragePrecision::kFloat32:
      DotsTyped(static_cast<const float*>(refs.data), 1.0f, r0, r1, queries, out, out_stride);
      break;
    case StoragePrecision::kFloat16:
      DotsTyped(static_cast<const uint16_t*>(refs.data), 1.0f, r0, r1, queries, out, out_stride);
      break;
    case StoragePrecision::kInt8:
      DotsTyped(static_cast<const int8_t*>(refs.data), refs.scale, r0, r1, queries, out,
                out_stride);
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

std::string Active() {
  switch (CurrentIsa()) {
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
  } else {
    throw std::invalid_argument("unknown distance kernel '" + name +
                                "' (expected auto, avx512, avx2 or portable)");
  }
}

}  // namespace kernels
}  // namespace bsf_vpr
