#include "bsf_vpr/core/stored_reference_set.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <type_traits>

#include "bsf_vpr/core/reference_set.h"
#include "src/core/internal/distance_kernels.h"

namespace bsf_vpr {

StoredReferenceSet::StoredReferenceSet(ReferenceSet set, StoragePrecision precision)
    : layout_(set.TakeLayout()), distance_(std::move(set.distance)), precision_(precision) {
  if (set.encoded) {
    HoldEncoded(std::move(*set.encoded));
    return;
  }
  const RowMatrixXf& x = set.descriptors;
  const size_t n = static_cast<size_t>(x.size());
  if (precision == StoragePrecision::kFloat16) {
    std::vector<uint16_t> half(n);
    for (size_t i = 0; i < n; ++i) half[i] = FloatToHalf(x.data()[i]);  // throws beyond 65504
    rows_ = std::make_shared<const Rows>(std::move(half));
  } else if (precision == StoragePrecision::kInt8) {
    const float max_abs = n ? x.cwiseAbs().maxCoeff() : 0.0f;
    scale_ = max_abs > 0 ? max_abs / 127.0f : 1.0f;
    std::vector<int8_t> levels(n);
    for (size_t i = 0; i < n; ++i) {
      const float q = std::nearbyint(x.data()[i] / scale_);
      levels[i] = static_cast<int8_t>(std::clamp(q, -127.0f, 127.0f));
    }
    rows_ = std::make_shared<const Rows>(std::move(levels));
  }
  // The norms of the values the kernels read, after rounding, in the kernels' own order.
  squared_norms_.resize(static_cast<Eigen::Index>(x.rows()));
  std::vector<float> row(static_cast<size_t>(layout_.dimension));
  for (int r = 0; r < static_cast<int>(x.rows()); ++r) {
    const float* values = x.row(r).data();
    if (precision != StoragePrecision::kFloat32) {
      DecodeRow(r, row.data());
      values = row.data();
    }
    squared_norms_(r) = kernels::SelfDot(values, layout_.dimension);
  }
  // Last, once nothing can throw: float32 keeps the given matrix itself (no copy).
  if (precision == StoragePrecision::kFloat32) {
    rows_ = std::make_shared<const Rows>(std::move(set.descriptors));
  }
}

void StoredReferenceSet::HoldEncoded(EncodedRows rows) {
  const std::string who = "reference set '" + name() + "'";
  if (rows.precision != precision_) {
    throw std::invalid_argument(who + " is held at " + ToString(rows.precision) + " by " +
                                rows.source + ", but the map stores " + ToString(precision_) +
                                ": write the set at " + ToString(precision_) +
                                " (bsf_store_set) or load it without memory_map");
  }
  scale_ = rows.scale;
  if (precision_ == StoragePrecision::kInt8 && !(scale_ >= kMinInt8Scale && std::isfinite(scale_))) {
    char got[32];
    std::snprintf(got, sizeof got, "%g", static_cast<double>(scale_));
    throw std::invalid_argument(who +
                                ": its int8 rows need a finite scale of at least 1.0842022e-19 "
                                "(below it they decode to zero), got " +
                                got);
  }
  rows_ = std::make_shared<const Rows>(std::move(rows));
  // The norms as the resident encodings give them (decoded, then the kernels' SelfDot), so
  // a mapped set's distances are bitwise those of the same set read and encoded. Reading
  // them is the one pass over the rows a mapped load makes.
  const int n = size();
  squared_norms_.resize(n);
  std::vector<float> row(static_cast<size_t>(layout_.dimension));
  for (int r = 0; r < n; ++r) {
    DecodeRow(r, row.data());
    const float norm = kernels::SelfDot(row.data(), layout_.dimension);
    if (!std::isfinite(norm) || norm > kMaxDescriptorSquaredNorm) {
      throw std::invalid_argument(who + ": descriptor row " + std::to_string(r) + " of " +
                                  std::get<EncodedRows>(*rows_).source +
                                  " is not finite or too large (squared norm " +
                                  std::to_string(norm) + ")");
    }
    squared_norms_(r) = norm;
  }
  const std::string changed = RowsChanged();
  if (!changed.empty()) {
    throw std::invalid_argument(who + ": " + changed + ", while it was being loaded");
  }
}

std::string StoredReferenceSet::RowsChanged() const {
  const auto* encoded = std::get_if<EncodedRows>(rows_.get());
  return encoded && encoded->changed ? encoded->changed() : "";
}

bool StoredReferenceSet::mapped() const { return std::holds_alternative<EncodedRows>(*rows_); }

std::string StoredReferenceSet::rows_source() const {
  const auto* encoded = std::get_if<EncodedRows>(rows_.get());
  return encoded ? encoded->source : "";
}

const void* StoredReferenceSet::data() const {
  return std::visit(
      [](const auto& rows) -> const void* {
        if constexpr (std::is_same_v<std::decay_t<decltype(rows)>, EncodedRows>) {
          return rows.data;
        } else {
          return rows.data();
        }
      },
      *rows_);
}

size_t StoredReferenceSet::data_bytes() const {
  return static_cast<size_t>(size()) * static_cast<size_t>(layout_.dimension) *
         static_cast<size_t>(BytesPerElement(precision_));
}

void StoredReferenceSet::DecodeRow(int r, float* out) const {
  const size_t base = static_cast<size_t>(r) * static_cast<size_t>(layout_.dimension);
  const void* rows = data();
  if (precision_ == StoragePrecision::kFloat16) {
    const uint16_t* half = static_cast<const uint16_t*>(rows) + base;
    for (int k = 0; k < layout_.dimension; ++k) out[k] = HalfToFloat(half[k]);
  } else if (precision_ == StoragePrecision::kInt8) {
    const int8_t* levels = static_cast<const int8_t*>(rows) + base;
    for (int k = 0; k < layout_.dimension; ++k) out[k] = scale_ * static_cast<float>(levels[k]);
  } else {
    const float* row = static_cast<const float*>(rows) + base;
    std::copy(row, row + layout_.dimension, out);
  }
}

size_t StoredReferenceSet::MemoryBytes() const {
  size_t names = images().size();
  for (const std::string& f : image_files()) names += sizeof(std::string) + f.size();
  return data_bytes() + static_cast<size_t>(squared_norms_.size()) * sizeof(float) +
         place_ids().size() * sizeof(int) + poses().size() * sizeof(PlacePose) + names;
}

ReferenceSet StoredReferenceSet::ToReferenceSet() const {
  const RowMatrixXf* descriptors = std::get_if<RowMatrixXf>(rows_.get());
  RowMatrixXf mapped_rows;
  if (const auto* encoded = std::get_if<EncodedRows>(rows_.get());
      encoded && precision_ == StoragePrecision::kFloat32) {
    // float32 rows mapped from a file: their values are all there.
    mapped_rows =
        Eigen::Map<const RowMatrixXf>(static_cast<const float*>(encoded->data), size(), layout_.dimension);
    descriptors = &mapped_rows;
  }
  if (!descriptors) {
    throw std::invalid_argument("reference set '" + name() + "' is held at " + ToString(precision_) +
                                " precision only; save it from its float32 source");
  }
  ReferenceSet set;
  set.name = name();
  set.condition = condition();
  set.descriptor_type = descriptor_type();
  set.distance = distance_;
  set.descriptors = *descriptors;
  set.place_ids = place_ids();
  set.poses = poses();
  set.images = images();
  set.image_files = image_files();
  return set;
}

}  // namespace bsf_vpr
