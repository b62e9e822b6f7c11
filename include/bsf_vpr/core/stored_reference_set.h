// A reference set as a ReferenceSets holds it: immutable, its descriptors encoded at the
// map's storage precision behind accessors (as faiss keeps an index's codes behind
// IndexFlatCodes), with the squared norm of every row that the distances need. Nothing
// changes it once made: any number of threads may read it at once. A copy shares the
// encoded rows (they are immutable): a snapshot of a map's sets for a background build
// costs their place ids and norms, not their descriptors.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "bsf_vpr/core/descriptor_store.h"
#include "bsf_vpr/core/place_layout.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

struct ReferenceSet;
class ReferenceSets;

class StoredReferenceSet {
 public:
  // What the set says of its places, without its rows: its name, condition, descriptor
  // type, place ids, poses, images and dimension (the one spelling of a set's metadata).
  const SetLayout& layout() const { return layout_; }
  const std::string& name() const { return layout_.name; }
  const std::string& condition() const { return layout_.condition; }
  const std::string& descriptor_type() const { return layout_.descriptor_type; }
  const std::string& distance() const { return distance_; }
  // N_u place indices (row k describes place place_ids()[k]), and empty or N_u poses.
  const std::vector<int>& place_ids() const { return layout_.place_ids; }
  const std::vector<PlacePose>& poses() const { return layout_.poses; }
  // The folder of the rows' images and, empty or one per row, their files relative to it
  // (ReferenceSet::images, image_files): row k's image is images() + "/" + image_files()[k].
  const std::string& images() const { return layout_.images; }
  const std::vector<std::string>& image_files() const { return layout_.image_files; }

  int size() const { return layout_.size(); }             // N_u >= 1 rows
  int dimension() const { return layout_.dimension; }     // D >= 1
  StoragePrecision precision() const { return precision_; }
  // The encoded rows as the distance kernels read them: size() x dimension() elements of
  // precision() (float, uint16_t binary16 or int8_t), row-major, data_bytes() bytes. Owned
  // by this set; valid while it lives.
  const void* data() const;
  size_t data_bytes() const;
  // int8: an element stands for scale() x its value (scale = max |x| / 127 over the set);
  // 1 for the other precisions.
  float scale() const { return scale_; }
  // Squared L2 norm of every row as decoded (after rounding), size() entries.
  const Eigen::VectorXf& squared_norms() const { return squared_norms_; }
  // Row r (0 <= r < size()) decoded to dimension() floats at `out`: the float32 values as
  // given, float16 exactly, int8 as scale() x value.
  void DecodeRow(int r, float* out) const;
  // Bytes held: the encoded rows, their norms, place ids, poses and image file names.
  // Memory-mapped rows count as held (they are the set's bytes, resident or not).
  size_t MemoryBytes() const;
  // Whether the rows are memory-mapped (ReferenceSet::encoded), and where from ("" if not).
  bool mapped() const;
  std::string rows_source() const;
  // Why the rows may no longer be those loaded ("" while they are): a mapped set's file
  // changed in place (EncodedRows::changed). Distances read while this says so are not to be
  // used.
  std::string RowsChanged() const;

  // The ReferenceSet this set was made from, for saving it. Only a set held at float32 has
  // it: at reduced precision the float32 values are gone, and this throws
  // std::invalid_argument saying so.
  ReferenceSet ToReferenceSet() const;

 private:
  friend class ReferenceSets;
  // Made by ReferenceSets::Add from a set it has validated (ReferenceSet::Validate). Throws
  // std::invalid_argument for values float16 cannot hold (std::bad_alloc when memory is
  // short); a float32 set keeps the given matrix without copying it. A set of encoded rows
  // (ReferenceSet::encoded) is held as it is, without reading more than its norms need; it
  // must be at `precision` and its rows finite and within kMaxDescriptorSquaredNorm
  // (std::invalid_argument naming the row otherwise).
  StoredReferenceSet(ReferenceSet set, StoragePrecision precision);
  // Holds encoded rows and reads their norms (the constructor's part for them).
  void HoldEncoded(EncodedRows rows);

  SetLayout layout_;
  std::string distance_;
  StoragePrecision precision_ = StoragePrecision::kFloat32;
  // The one encoding of precision_: float32 as given, binary16 or int8 (row-major), or rows
  // encoded elsewhere (a memory-mapped file: EncodedRows), shared by the copies of this set.
  using Rows = std::variant<RowMatrixXf, std::vector<uint16_t>, std::vector<int8_t>, EncodedRows>;
  std::shared_ptr<const Rows> rows_;
  float scale_ = 1.0f;
  Eigen::VectorXf squared_norms_;
};

}  // namespace bsf_vpr
