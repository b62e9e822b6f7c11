// Built with -ffp-contract=off (CMakeLists.txt): the portable kernel must multiply then add
// exactly as written, whatever the compiler would fuse, for the summation order to hold.
#include "distance_kernels.h"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <stdexcept>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define BSF_VPR_HAVE_AVX2_KERNEL 1
#define BSF_VPR_AVX2 __attribute__((target("avx2,fma,f16c")))
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
inline float Decode(int8_t v) { return static_cast<float>(v); }

// The last, partial block of a row, zero-padded to eight lanes.
template <class T>
inline void PadTail(const T* row, int from, int n, float* lanes) {
  for (int k = 0; k < kLanes; ++k) lanes[k] = from + k < n ? Decode(row[from + k]) : 0.0f;
}

// ---- portable kernel: eight lanes as a float array --------------------------------------

template <class T, int NQ, int NR>
void TilePortable(const float* q, int q_stride, const T* r, int r_stride, int d, float scale,
                  float* out, int out_stride) {
  float acc[NQ][NR][kLanes] = {};
  int i = 0;
  for (; i + kLanes <= d; i += kLanes) {
    for (int k = 0; k < NR; ++k) {
      float rv[kLanes];
      for (int l = 0; l < kLanes; ++l) rv[l] = Decode(r[k * r_stride + i + l]);
      for (int j = 0; j < NQ; ++j) {
        const float* qj = q + j * q_stride + i;
        for (int l = 0; l < kLanes; ++l) acc[j][k][l] = acc[j][k][l] + qj[l] * rv[l];
      }
    }
  }
  if (i < d) {
    for (int k = 0; k < NR; ++k) {
      float rv[kLanes];
      PadTail(r + k * r_stride, i, d, rv);
      for (int j = 0; j < NQ; ++j) {
        float qv[kLanes];
        PadTail(q + j * q_stride, i, d, qv);
        for (int l = 0; l < kLanes; ++l) acc[j][k][l] = acc[j][k][l] + qv[l] * rv[l];
      }
    }
  }
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) out[j * out_stride + k] = ReduceLanes(acc[j][k]) * scale;
  }
}

// ---- AVX2 kernel: eight lanes as one __m256, FMA ------------------------------------------

#ifdef BSF_VPR_HAVE_AVX2_KERNEL
BSF_VPR_AVX2 inline __m256 Load8(const float* p) { return _mm256_loadu_ps(p); }
BSF_VPR_AVX2 inline __m256 Load8(const uint16_t* p) {
  return _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
}
BSF_VPR_AVX2 inline __m256 Load8(const int8_t* p) {
  return _mm256_cvtepi32_ps(_mm256_cvtepi8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
}

template <class T, int NQ, int NR>
BSF_VPR_AVX2 void TileAvx2(const float* q, int q_stride, const T* r, int r_stride, int d,
                           float scale, float* out, int out_stride) {
  __m256 acc[NQ][NR];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) acc[j][k] = _mm256_setzero_ps();
  }
  int i = 0;
  for (; i + kLanes <= d; i += kLanes) {
    __m256 rv[NR];
    for (int k = 0; k < NR; ++k) rv[k] = Load8(r + k * r_stride + i);
    for (int j = 0; j < NQ; ++j) {
      const __m256 qv = _mm256_loadu_ps(q + j * q_stride + i);
      for (int k = 0; k < NR; ++k) acc[j][k] = _mm256_fmadd_ps(qv, rv[k], acc[j][k]);
    }
  }
  if (i < d) {
    alignas(32) float pad[kLanes];
    __m256 rv[NR];
    for (int k = 0; k < NR; ++k) {
      PadTail(r + k * r_stride, i, d, pad);
      rv[k] = _mm256_load_ps(pad);
    }
    for (int j = 0; j < NQ; ++j) {
      PadTail(q + j * q_stride, i, d, pad);
      const __m256 qv = _mm256_load_ps(pad);
      for (int k = 0; k < NR; ++k) acc[j][k] = _mm256_fmadd_ps(qv, rv[k], acc[j][k]);
    }
  }
  alignas(32) float lanes[kLanes];
  for (int j = 0; j < NQ; ++j) {
    for (int k = 0; k < NR; ++k) {
      _mm256_store_ps(lanes, acc[j][k]);
      out[j * out_stride + k] = ReduceLanes(lanes) * scale;
    }
  }
}

bool CpuHasAvx2() {
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
         __builtin_cpu_supports("f16c");
}
#else
bool CpuHasAvx2() { return false; }
#endif

// ---- driver: tiles over a block of rows that stays in cache ---------------------------

enum class Isa { kPortable, kAvx2 };
std::atomic<int> g_forced{-1};  // -1: by CPU

Isa CurrentIsa() {
  const int forced = g_forced.load();
  if (forced >= 0) return static_cast<Isa>(forced);
  static const bool avx2 = CpuHasAvx2();
  return avx2 ? Isa::kAvx2 : Isa::kPortable;
}

template <class T, int NQ, int NR>
void Tile(Isa isa, const float* q, int q_stride, const T* r, int r_stride, int d, float scale,
          float* out, int out_stride) {
#ifdef BSF_VPR_HAVE_AVX2_KERNEL
  if (isa == Isa::kAvx2) {
    TileAvx2<T, NQ, NR>(q, q_stride, r, r_stride, d, scale, out, out_stride);
    return;
  }
#endif
  (void)isa;
  TilePortable<T, NQ, NR>(q, q_stride, r, r_stride, d, scale, out, out_stride);
}

// Rows [r0, r1) against queries: NQ queries at a time, NR rows at a time, remainders one row.
template <class T, int NQ, int NR>
void Sweep(Isa isa, const float* q, int q_stride, const T* rows, int d, float scale, int r0,
           int r1, float* out, int out_stride) {
  int r = r0;
  for (; r + NR <= r1; r += NR) {
    Tile<T, NQ, NR>(isa, q, q_stride, rows + static_cast<size_t>(r) * d, d, d, scale,
                    out + (r - r0), out_stride);
  }
  for (; r < r1; ++r) {
    Tile<T, NQ, 1>(isa, q, q_stride, rows + static_cast<size_t>(r) * d, d, d, scale,
                   out + (r - r0), out_stride);
  }
}

template <class T>
void DotsTyped(const T* rows, int d, float scale, int r0, int r1, const float* queries,
               int num_queries, int query_stride, float* out, int out_stride) {
  const Isa isa = CurrentIsa();
  // Blocks of reference rows of about 256 KiB stay in the core's cache while every group of
  // four queries passes over them.
  const int row_bytes = std::max(1, d * static_cast<int>(sizeof(T)));
  const int block = std::max(6, (256 << 10) / row_bytes);
  for (int b0 = r0; b0 < r1; b0 += block) {
    const int b1 = std::min(r1, b0 + block);
    int q = 0;
    for (; q + 4 <= num_queries; q += 4) {
      Sweep<T, 4, 3>(isa, queries + static_cast<size_t>(q) * query_stride, query_stride, rows, d,
                     scale, b0, b1, out + static_cast<size_t>(q) * out_stride + (b0 - r0),
                     out_stride);
    }
    for (; q < num_queries; ++q) {
      Sweep<T, 1, 6>(isa, queries + static_cast<size_t>(q) * query_stride, query_stride, rows, d,
                     scale, b0, b1, out + static_cast<size_t>(q) * out_stride + (b0 - r0),
                     out_stride);
    }
  }
}

}  // namespace

void Dots(const RefRows& refs, int r0, int r1, const float* queries, int num_queries,
          int query_stride, float* out, int out_stride) {
  switch (refs.precision) {
    case StoragePrecision::kFloat32:
      DotsTyped(static_cast<const float*>(refs.data), refs.cols, 1.0f, r0, r1, queries,
                num_queries, query_stride, out, out_stride);
      break;
    case StoragePrecision::kFloat16:
      DotsTyped(static_cast<const uint16_t*>(refs.data), refs.cols, 1.0f, r0, r1, queries,
                num_queries, query_stride, out, out_stride);
      break;
    case StoragePrecision::kInt8:
      DotsTyped(static_cast<const int8_t*>(refs.data), refs.cols, refs.scale, r0, r1, queries,
                num_queries, query_stride, out, out_stride);
      break;
  }
}

float SelfDot(const float* x, int n) {
  float out = 0;
  Tile<float, 1, 1>(CurrentIsa(), x, n, x, n, n, 1.0f, &out, 1);
  return out;
}

std::string Active() { return CurrentIsa() == Isa::kAvx2 ? "avx2" : "portable"; }

void Force(const std::string& name) {
  if (name == "auto") {
    g_forced = -1;
  } else if (name == "portable") {
    g_forced = static_cast<int>(Isa::kPortable);
  } else if (name == "avx2") {
    if (!CpuHasAvx2()) throw std::invalid_argument("this CPU lacks AVX2, FMA or F16C");
    g_forced = static_cast<int>(Isa::kAvx2);
  } else {
    throw std::invalid_argument("unknown distance kernel '" + name +
                                "' (expected auto, avx2 or portable)");
  }
}

}  // namespace kernels
}  // namespace bsf_vpr
