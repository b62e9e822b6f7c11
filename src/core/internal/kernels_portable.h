// The portable kernel: eight lanes as a float array, multiply then add as written. Included
// by distance_kernels.cpp alone.
#pragma once

#include "src/core/internal/kernel_common.h"

namespace bsf_vpr {
namespace kernels {
namespace {

// ---- portable kernel: eight lanes as a float array --------------------------------------

template <int NQ, int NR>
void TileInt8Portable(const TileArgs& a, const int8_t* r, int r_stride) {
  for (int j = 0; j < NQ; ++j) {
    const int16_t* q = a.q16 + j * a.q_stride;
    for (int k = 0; k < NR; ++k) {  // no lanes: every element in the exact sum
      a.out[j * a.out_stride + k] =
          Int8Finish(nullptr, 0, q, r + k * r_stride, 0, a.d, a.scale, a.q_scales[j]);
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

}  // namespace
}  // namespace kernels
}  // namespace bsf_vpr
