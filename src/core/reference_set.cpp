#include "bsf_vpr/core/reference_set.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <type_traits>

namespace bsf_vpr {

void ReferenceSet::Validate() const {
  const std::string who = "reference set '" + name + "'";
  if (name.empty()) throw std::invalid_argument("a reference set needs a non-empty name");
  if (encoded && descriptors.size() != 0) {
    throw std::invalid_argument(who + " has both encoded rows and float32 descriptors");
  }
  if (encoded && (encoded->rows > kMaxPlaces || !encoded->data)) {
    throw std::invalid_argument(who + ": its encoded rows (" + encoded->source +
                                ") are too many or missing");
  }
  if (size() == 0 || dimension() == 0) {
    throw std::invalid_argument(who + " is empty (" + std::to_string(size()) + " x " +
                                std::to_string(dimension()) + " descriptors)");
  }
  if (place_ids.size() != static_cast<size_t>(size())) {
    throw std::invalid_argument(who + " has " + std::to_string(size()) + " descriptors but " +
                                std::to_string(place_ids.size()) + " place ids");
  }
  CheckPlaceRows(who, place_ids, poses, images, image_files);
  if (dimension() > kMaxDimension) {
    throw std::invalid_argument(who + " has dimension " + std::to_string(dimension()) +
                                ", more than " + std::to_string(kMaxDimension));
  }
  for (Eigen::Index r = 0; r < descriptors.rows(); ++r) {
    const std::string problem = DescriptorProblem(descriptors.row(r));
    if (!problem.empty()) {
      throw std::invalid_argument(who + ": descriptor row " + std::to_string(r) + " " + problem);
    }
  }
}

namespace {

// The squared L2 norm of `descriptor` in double: in double no finite float32 value
// overflows a square or a sum (at most kMaxDimension of them), so the sum is finite exactly
// when every value is. One branch-free pass with four sums in flight (this runs over every
// row of every set loaded and every query).
double SquaredNorm(const Eigen::Ref<const Eigen::RowVectorXf>& descriptor) {
  const float* x = descriptor.data();
  const Eigen::Index n = descriptor.size();
  double sums[4] = {0, 0, 0, 0};
  Eigen::Index i = 0;
  for (; i + 4 <= n; i += 4) {
    for (int k = 0; k < 4; ++k) sums[k] += static_cast<double>(x[i + k]) * x[i + k];
  }
  for (; i < n; ++i) sums[0] += static_cast<double>(x[i]) * x[i];
  return (sums[0] + sums[1]) + (sums[2] + sums[3]);
}

// DescriptorProblem of a descriptor of squared norm `squared_norm` (SquaredNorm).
std::string NormProblem(double squared_norm) {
  // The distances square and sum float32 values: a finite descriptor whose squared norm
  // overflows float32 would turn them into infinity or NaN.
  if (!std::isfinite(squared_norm)) return "holds NaN or infinity";
  if (squared_norm > kMaxDescriptorSquaredNorm) {
    return "has a norm too large to compute distances with (squared norm " +
           std::to_string(squared_norm) + " > " + std::to_string(kMaxDescriptorSquaredNorm) + ")";
  }
  return "";
}

}  // namespace

std::string DescriptorProblem(const Eigen::Ref<const Eigen::RowVectorXf>& descriptor) {
  return NormProblem(SquaredNorm(descriptor));
}

std::string QueryDescriptorProblem(const Eigen::Ref<const Eigen::RowVectorXf>& descriptor) {
  const double squared_norm = SquaredNorm(descriptor);
  // Exactly zero only when every value is (the squares of float32 values do not underflow
  // in double).
  if (squared_norm == 0) {
    return "is all zeros: it carries no information (a uniform image, e.g. a black frame or a "
           "covered lens, describes as zeros)";
  }
  return NormProblem(squared_norm);
}

std::string ImageFileProblem(const std::string& file) {
  if (file.empty()) return "";  // the row has no image
  if (file[0] == '/') return "'" + file + "' is absolute (it must be relative to images)";
  size_t start = 0;
  while (start <= file.size()) {
    const size_t slash = std::min(file.find('/', start), file.size());
    if (file.compare(start, slash - start, "..") == 0) {
      return "'" + file + "' has a '..' part (it must lie below images)";
    }
    start = slash + 1;
  }
  return "";
}

ReferenceSet MakeReferenceSet(std::string name, RowMatrixXf descriptors, std::string condition) {
  ReferenceSet set;
  set.name = std::move(name);
  set.condition = std::move(condition);
  set.place_ids.resize(static_cast<size_t>(descriptors.rows()));
  std::iota(set.place_ids.begin(), set.place_ids.end(), 0);
  set.descriptors = std::move(descriptors);
  return set;
}

SetLayout ReferenceSet::Layout() const {
  return SetLayout{name, condition, descriptor_type, place_ids, poses, images, image_files,
                   dimension()};
}

SetLayout ReferenceSet::TakeLayout() {
  const int d = dimension();
  return SetLayout{std::move(name),   std::move(condition), std::move(descriptor_type),
                   std::move(place_ids), std::move(poses),  std::move(images),
                   std::move(image_files), d};
}

void ReferenceSets::Add(ReferenceSet set) {
  set.Validate();
  // The layout's checks first: a set the map refuses is not encoded.
  PlaceLayout next = layout_;
  next.Add(set.Layout());
  Insert(StoredReferenceSet(std::move(set), storage_), std::move(next));
}

StoredReferenceSet ReferenceSets::Store(ReferenceSet set, StoragePrecision precision) {
  set.Validate();
  return StoredReferenceSet(std::move(set), precision);
}

void ReferenceSets::Add(StoredReferenceSet set) {
  if (set.precision() != storage_) {
    throw std::invalid_argument("reference set '" + set.name() + "' is held at " +
                                ToString(set.precision()) + ", the map stores " +
                                ToString(storage_));
  }
  PlaceLayout next = layout_;
  next.Add(set.layout());
  Insert(std::move(set), std::move(next));
}

void ReferenceSets::Insert(StoredReferenceSet stored, PlaceLayout next) {
  // Everything that can throw happened aside (the layout's checks, encoding, copies); the
  // map changes only by moves here.
  sets_.reserve(sets_.size() + 1);
  static_assert(std::is_nothrow_move_constructible_v<StoredReferenceSet>);
  static_assert(std::is_nothrow_move_assignable_v<PlaceLayout>);
  sets_.push_back(std::move(stored));  // cannot throw after the reserve
  layout_ = std::move(next);
}

void ReferenceSets::CheckPlacePoses(const ReferenceSet& set) const {
  layout_.CheckPlacePoses(set.name, set.place_ids, set.poses);
}

void ReferenceSets::CheckQuery(const Eigen::Ref<const Eigen::VectorXf>& descriptor) const {
  if (num_sets() == 0) throw std::invalid_argument("no reference set is loaded");
  if (descriptor.size() != dimension()) {
    throw std::invalid_argument("descriptor has dimension " + std::to_string(descriptor.size()) +
                                ", the reference sets have dimension " +
                                std::to_string(dimension()));
  }
  const std::string problem = QueryDescriptorProblem(descriptor.transpose());
  if (!problem.empty()) throw std::invalid_argument("descriptor " + problem);
}

bool ReferenceSets::Remove(const std::string& name) {
  const int u = IndexOf(name);
  if (u < 0) return false;
  layout_.Remove(name);  // builds its new place index aside
  sets_.erase(sets_.begin() + u);
  return true;
}

}  // namespace bsf_vpr
