// What the reference sets of one route share, built from their descriptors: one
// representation of every place from all the traversals that show it (docs/method.md, "What
// the references share"). Three kinds, each the core of a training-free multi-reference
// method of the field:
//
//   mean_descriptor  the mean of the place's L2-normalised reference descriptors;
//                    distance 1 - cos(q, mean)
//   subspace         an orthonormal basis of the span of the place's normalised references
//                    (Ismagilov et al. 2025); distance ||q - Q Q^T q|| for the normalised q,
//                    the residual of its best reconstruction, in [0, 1]
//   discriminant     a projection W that maximises between-place over within-place scatter
//                    of the normalised references (a generalised eigenproblem, after
//                    DisPlace, Rajani et al. 2026), one vector per place v_p = W^T (m_p - mu);
//                    distance 1 - cos(W^T (q - mu), v_p)
//
// with q the L2-normalised query, m_p the mean of place p's normalised references and mu
// the mean of all of them. Distances are not squared, >= 0, and lower is nearer, as a
// reference set's (distances.h): the likelihood and the methods take them as one more source.
//
// Immutable once built: any number of threads may call Distances at once.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "bsf_vpr/core/enum_names.h"
#include "bsf_vpr/core/options.h"
#include "bsf_vpr/core/types.h"

namespace bsf_vpr {

class StoredReferenceSet;

enum class JointKind { kMeanDescriptor, kSubspace, kDiscriminant };
const EnumNames<JointKind>& JointKindNames();  // mean_descriptor, subspace, discriminant
std::string ToString(JointKind kind);

struct JointOptions {
  // discriminant: the directions kept (at most the places - 1 and the references' rank).
  int discriminant_dimensions = 64;
  // discriminant: the ridge added to the within-place scatter, as a fraction of its mean
  // eigenvalue (its trace / its dimension): 0 trusts the scatter fully, large values tend
  // to the between-place scatter's own principal directions.
  double discriminant_ridge = 0.1;

  void Validate() const;  // throws std::invalid_argument naming the bad field
};
const OptionTable<JointOptions>& JointOptionsTable();

// The scatters of the discriminant are estimated on at most this many places (every
// ceil(N / this)-th place, all their references): M x 5000 rows are plenty for scatters in
// kJointPrincipalDirections dimensions, and the build's memory and time stay bounded on a
// long route (10 x 100,000 x 4096: 800 MB of rows, not 16 GB).
constexpr int kJointScatterPlaces = 5000;
// The discriminant works in at most this many principal directions of the references
// (the PCA before LDA of Fisherfaces), found by subspace iteration where D is larger, from
// at most kJointBasisRows of the scatters' rows spread evenly (as the pca first stage's
// basis comes from 2048 rows): the build's cost then stays seconds at D = 4096.
constexpr int kJointPrincipalDirections = 512;
constexpr int kJointBasisRows = 2048;

// Throws std::invalid_argument, naming the sets, unless `sets` are two or more of one
// dimension of which some place is shown by two (Build's check, for those who check early).
void CheckJointSets(const std::vector<const StoredReferenceSet*>& sets, int num_places);

class JointRepresentation {
 public:
  JointRepresentation() = default;

  // Builds `kind` from `sets` (one descriptor: the same dimension; row k of set u shows
  // place place_ids()[k] of a map of `num_places` places). Throws std::invalid_argument when
  // fewer than two sets are given, their dimensions differ, or no place is shown by two of
  // them (the message names the sets): a joint representation needs references that share
  // places. Deterministic: the same sets give the same bits.
  static JointRepresentation Build(JointKind kind,
                                   const std::vector<const StoredReferenceSet*>& sets,
                                   int num_places, const JointOptions& options = {});

  JointKind kind() const { return kind_; }
  int num_places() const { return num_places_; }
  int dimension() const { return dimension_; }  // D of the queries it takes
  bool empty() const { return num_places_ == 0; }
  // The names of the sets it was built from, in order.
  const std::vector<std::string>& set_names() const { return set_names_; }
  // discriminant: the directions kept (0 for the other kinds).
  int discriminant_dimensions() const { return static_cast<int>(projection_.rows()); }
  size_t MemoryBytes() const;

  // Distances (Q x num_places, row-major; see above) of `queries` (Q x D, any scale: each
  // row is normalised; a row of zeros has distance 1, or 1 to every subspace) to every place.
  RowMatrixXf Distances(const Eigen::Ref<const RowMatrixXf>& queries) const;

  // For tests: the projection W (d x D, one direction per row), the mean mu (D), the place
  // vectors (N x d or N x D) and the subspaces' basis rows with their places.
  const RowMatrixXf& projection() const { return projection_; }
  const Eigen::VectorXf& mean() const { return mean_; }
  const RowMatrixXf& place_vectors() const { return place_vectors_; }
  const std::vector<int>& basis_places() const { return basis_places_; }

 private:
  JointKind kind_ = JointKind::kMeanDescriptor;
  int num_places_ = 0;
  int dimension_ = 0;
  std::vector<std::string> set_names_;
  // mean_descriptor: N x D normalised means. discriminant: N x d normalised v_p.
  // subspace: K x D orthonormal basis rows, row k of place basis_places_[k] (ascending).
  RowMatrixXf place_vectors_;
  std::vector<int> basis_places_;
  RowMatrixXf projection_;  // discriminant: d x D
  Eigen::VectorXf mean_;    // discriminant: mu
};

}  // namespace bsf_vpr
