#include "bsf_vpr/core/joint_representation.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "bsf_vpr/core/stored_reference_set.h"

namespace bsf_vpr {

const EnumNames<JointKind>& JointKindNames() {
  static const EnumNames<JointKind> kNames{{JointKind::kMeanDescriptor, "mean_descriptor"},
                                           {JointKind::kSubspace, "subspace"},
                                           {JointKind::kDiscriminant, "discriminant"}};
  return kNames;
}

std::string ToString(JointKind kind) { return JointKindNames().Name(kind); }

const OptionTable<JointOptions>& JointOptionsTable() {
  static const OptionTable<JointOptions> kTable =
      OptionTable<JointOptions>()
          .Add(
              "discriminant_dimensions", [](auto& o) -> auto& { return o.discriminant_dimensions; },
              "the discriminant (method discriminant, fusion_joint discriminant): the "
              "directions kept, at most the places - 1 and the references' rank",
              "dimensions", Between(1, 4096))
          .Add(
              "discriminant_ridge", [](auto& o) -> auto& { return o.discriminant_ridge; },
              "the discriminant: the ridge added to the within-place scatter, as a fraction of "
              "its mean eigenvalue (0 trusts it fully; large values tend to the principal "
              "directions of the places' means)",
              "", Finite(AtLeast(0)));
  return kTable;
}

void JointOptions::Validate() const { JointOptionsTable().CheckValues(*this); }

namespace {

using MatrixXd = Eigen::MatrixXd;

// Every set's rows decoded and L2-normalised (a row of zeros stays zero), stacked, with the
// place of each.
struct NormalisedRows {
  RowMatrixXf rows;
  std::vector<int> places;
};

// The rows of the places `keep` accepts, decoded and normalised, stacked in set order.
template <class Keep>
NormalisedRows Normalise(const std::vector<const StoredReferenceSet*>& sets, const Keep& keep) {
  NormalisedRows out;
  Eigen::Index total = 0;
  for (const StoredReferenceSet* s : sets) {
    for (int p : s->place_ids()) total += keep(p) ? 1 : 0;
  }
  const int dim = sets.front()->dimension();
  out.rows.resize(total, dim);
  out.places.reserve(static_cast<size_t>(total));
  Eigen::Index r = 0;
  for (const StoredReferenceSet* s : sets) {
    for (int k = 0; k < s->size(); ++k) {
      const int p = s->place_ids()[static_cast<size_t>(k)];
      if (!keep(p)) continue;
      s->DecodeRow(k, out.rows.row(r).data());
      const float norm = out.rows.row(r).norm();
      if (norm > 0) out.rows.row(r) /= norm;
      out.places.push_back(p);
      ++r;
    }
  }
  return out;
}

std::string SetNames(const std::vector<const StoredReferenceSet*>& sets) {
  std::string out;
  for (size_t k = 0; k < sets.size(); ++k) {
    out += (k == 0 ? "'" : k + 1 == sets.size() ? " and '" : ", '") + sets[k]->name() + "'";
  }
  return out;
}

}  // namespace

void CheckJointSets(const std::vector<const StoredReferenceSet*>& sets, int num_places) {
  if (sets.size() < 2) {
    throw std::invalid_argument(
        "a joint representation of the references needs two or more sets that show the same "
        "places; " +
        (sets.empty() ? std::string("no set is loaded") : "only " + SetNames(sets) + " is loaded"));
  }
  const int dim = sets.front()->dimension();
  std::vector<int> shown_by(static_cast<size_t>(num_places), -1);
  bool shared = false;
  for (size_t u = 0; u < sets.size(); ++u) {
    const StoredReferenceSet& s = *sets[u];
    if (s.dimension() != dim) {
      throw std::invalid_argument("a joint representation needs sets of one descriptor: '" +
                                  s.name() + "' has dimension " + std::to_string(s.dimension()) +
                                  ", '" + sets.front()->name() + "' " + std::to_string(dim));
    }
    for (int p : s.place_ids()) {
      if (p < 0 || p >= num_places) {
        throw std::invalid_argument("set '" + s.name() + "' names place " + std::to_string(p) +
                                    " of a map of " + std::to_string(num_places));
      }
      int& first = shown_by[static_cast<size_t>(p)];
      if (first >= 0 && first != static_cast<int>(u)) shared = true;
      if (first < 0) first = static_cast<int>(u);
    }
  }
  if (!shared) {
    throw std::invalid_argument("the sets " + SetNames(sets) +
                                " share no place (no place is shown by two of them): a joint "
                                "representation of the references needs sets of one route "
                                "whose place ids match");
  }
}

namespace {

// Per place the mean of its normalised rows (N x D; zero where no row shows it), a row at a
// time (no copy of the sets), and the rows per place.
RowMatrixXf PlaceMeans(const std::vector<const StoredReferenceSet*>& sets, int num_places,
                       std::vector<int>* counts) {
  const int dim = sets.front()->dimension();
  RowMatrixXf means = RowMatrixXf::Zero(num_places, dim);
  counts->assign(static_cast<size_t>(num_places), 0);
  Eigen::RowVectorXf row(dim);
  for (const StoredReferenceSet* s : sets) {
    for (int k = 0; k < s->size(); ++k) {
      const int p = s->place_ids()[static_cast<size_t>(k)];
      s->DecodeRow(k, row.data());
      const float norm = row.norm();
      if (norm > 0) means.row(p) += row / norm;
      ++(*counts)[static_cast<size_t>(p)];
    }
  }
  for (int p = 0; p < num_places; ++p) {
    const int n = (*counts)[static_cast<size_t>(p)];
    if (n > 1) means.row(p) /= static_cast<float>(n);
  }
  return means;
}

void NormaliseRows(RowMatrixXf* m) {
  for (Eigen::Index r = 0; r < m->rows(); ++r) {
    const float norm = m->row(r).norm();
    if (norm > 0) m->row(r) /= norm;
  }
}

// The orthonormal basis rows of each place's span (Householder QR of its rows, a direction
// kept where its diagonal is above 1e-4 of the largest: a reference repeated adds none).
void SubspaceBasis(const NormalisedRows& x, int num_places, RowMatrixXf* basis,
                   std::vector<int>* places) {
  std::vector<std::vector<Eigen::Index>> rows_of(static_cast<size_t>(num_places));
  for (Eigen::Index r = 0; r < x.rows.rows(); ++r) {
    rows_of[static_cast<size_t>(x.places[static_cast<size_t>(r)])].push_back(r);
  }
  const Eigen::Index dim = x.rows.cols();
  std::vector<Eigen::VectorXf> kept;
  for (int p = 0; p < num_places; ++p) {
    const std::vector<Eigen::Index>& rows = rows_of[static_cast<size_t>(p)];
    if (rows.empty()) continue;
    MatrixXd a(dim, static_cast<Eigen::Index>(rows.size()));
    for (size_t j = 0; j < rows.size(); ++j) {
      a.col(static_cast<Eigen::Index>(j)) = x.rows.row(rows[j]).transpose().cast<double>();
    }
    Eigen::HouseholderQR<MatrixXd> qr(a);
    const MatrixXd r = qr.matrixQR().triangularView<Eigen::Upper>();
    const MatrixXd q = qr.householderQ() * MatrixXd::Identity(dim, a.cols());
    double largest = 0;
    for (Eigen::Index j = 0; j < a.cols() && j < dim; ++j) {
      largest = std::max(largest, std::abs(r(j, j)));
    }
    for (Eigen::Index j = 0; j < a.cols() && j < dim; ++j) {
      if (largest > 0 && std::abs(r(j, j)) > 1e-4 * largest) {
        kept.push_back(q.col(j).cast<float>());
        places->push_back(p);
      }
    }
  }
  basis->resize(static_cast<Eigen::Index>(kept.size()), dim);
  for (size_t k = 0; k < kept.size(); ++k) basis->row(static_cast<Eigen::Index>(k)) = kept[k];
}

// An orthonormal basis (D x k, columns) of the leading principal directions of the centred
// rows `all` (R x D), from at most kJointBasisRows of them spread evenly: all of the
// directions (their rank) when there are few rows (from their Gram matrix), else the top k
// of their covariance (all of them when D <= k; else by seeded subspace iteration).
MatrixXd PrincipalDirections(const RowMatrixXf& all, int k) {
  RowMatrixXf sampled;
  if (all.rows() > kJointBasisRows) {
    sampled.resize(kJointBasisRows, all.cols());
    for (Eigen::Index j = 0; j < kJointBasisRows; ++j) {
      sampled.row(j) = all.row(j * all.rows() / kJointBasisRows);
    }
  }
  const RowMatrixXf& c = all.rows() > kJointBasisRows ? sampled : all;
  const Eigen::Index r = c.rows(), dim = c.cols();
  if (r <= dim && r <= 1024) {  // the span of the rows, from their Gram matrix
    const MatrixXd cd = c.cast<double>();
    const MatrixXd gram = cd * cd.transpose();
    Eigen::SelfAdjointEigenSolver<MatrixXd> eig(gram);
    const double top = eig.eigenvalues().maxCoeff();
    std::vector<Eigen::Index> keep;
    for (Eigen::Index j = r - 1; j >= 0 && static_cast<int>(keep.size()) < k; --j) {
      if (eig.eigenvalues()(j) > 1e-9 * top) keep.push_back(j);
    }
    MatrixXd p(dim, static_cast<Eigen::Index>(keep.size()));
    for (size_t j = 0; j < keep.size(); ++j) {
      const Eigen::Index e = keep[j];
      p.col(static_cast<Eigen::Index>(j)) =
          cd.transpose() * eig.eigenvectors().col(e) / std::sqrt(eig.eigenvalues()(e));
    }
    return p;
  }
  // The covariance (a float GEMM), then its leading eigenvectors: all of them where D <= k,
  // else the top k by subspace iteration on k + 16 columns (float products, each
  // orthonormalised by Cholesky QR: its Gram matrix is small and in double).
  const Eigen::MatrixXf cov = c.transpose() * c;
  if (dim <= k) {
    Eigen::SelfAdjointEigenSolver<MatrixXd> eig(cov.cast<double>());
    return eig.eigenvectors().rowwise().reverse();
  }
  const Eigen::Index width = std::min<Eigen::Index>(dim, k + 16);
  Eigen::MatrixXf y(dim, width);
  uint64_t state = 0x9E3779B97F4A7C15ull;  // splitmix64: a fixed start
  for (Eigen::Index j = 0; j < y.size(); ++j) {
    state += 0x9E3779B97F4A7C15ull;
    uint64_t z = state;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    y.data()[j] = static_cast<float>(static_cast<double>(z >> 11) / 9007199254740992.0 - 0.5);
  }
  // y's columns orthonormalised: y R^-1 with R^T R = y^T y (twice: Cholesky QR2).
  const auto orthonormalise = [](Eigen::MatrixXf* m) {
    for (int pass = 0; pass < 2; ++pass) {
      const MatrixXd gram = (m->transpose() * *m).cast<double>();
      const Eigen::LLT<MatrixXd> llt(gram);
      const MatrixXd r_inverse = llt.matrixU().solve(MatrixXd::Identity(gram.rows(), gram.cols()));
      *m = *m * r_inverse.cast<float>();
    }
  };
  for (int it = 0; it < 3; ++it) {
    orthonormalise(&y);
    y = cov * y;
  }
  orthonormalise(&y);
  const MatrixXd q = y.cast<double>();
  const MatrixXd projected = (y.transpose() * cov * y).cast<double>();
  Eigen::SelfAdjointEigenSolver<MatrixXd> small(projected);
  return q * small.eigenvectors().rowwise().reverse().leftCols(k);
}

// The within- and between-place scatters of the rows `y` (R x k, centred on their mean),
// row j at place row_places[j].
struct Scatters {
  MatrixXd within, between;
  int places_seen = 0;  // places with a row
};
Scatters PlaceScatters(const MatrixXd& y, const std::vector<int>& row_places, int num_places) {
  const Eigen::Index k = y.cols();
  MatrixXd place_sum = MatrixXd::Zero(num_places, k);
  std::vector<int> n(static_cast<size_t>(num_places), 0);
  for (Eigen::Index j = 0; j < y.rows(); ++j) {
    const int place = row_places[static_cast<size_t>(j)];
    place_sum.row(place) += y.row(j);
    ++n[static_cast<size_t>(place)];
  }
  Scatters s;
  s.within = MatrixXd::Zero(k, k);
  s.between = MatrixXd::Zero(k, k);
  MatrixXd centred = y;
  for (Eigen::Index j = 0; j < y.rows(); ++j) {
    const int place = row_places[static_cast<size_t>(j)];
    centred.row(j) -= place_sum.row(place) / static_cast<double>(n[static_cast<size_t>(place)]);
  }
  s.within.selfadjointView<Eigen::Lower>().rankUpdate(centred.transpose());
  s.within = s.within.selfadjointView<Eigen::Lower>();
  for (int place = 0; place < num_places; ++place) {
    const int m = n[static_cast<size_t>(place)];
    if (m == 0) continue;
    const Eigen::VectorXd mean = place_sum.row(place).transpose() / m;
    s.between.noalias() += m * mean * mean.transpose();  // mu is 0 after centring
    ++s.places_seen;
  }
  return s;
}

// The discriminant's directions (k x d): S_b w = lambda (S_w + ridge I) w, through the
// Cholesky factor L of S_w + ridge I: L^-1 S_b L^-T v = lambda v, w = L^-T v (so that
// w^T (S_w + ridge I) w = 1), the d largest.
MatrixXd DiscriminantDirections(const Scatters& s, const JointOptions& options) {
  const Eigen::Index k = s.within.rows();
  double ridge = options.discriminant_ridge * s.within.trace() / static_cast<double>(k);
  if (!(ridge > 0)) ridge = 1e-9 * std::max(1.0, s.between.trace() / static_cast<double>(k));
  MatrixXd a = s.within;
  a.diagonal().array() += ridge;
  const Eigen::LLT<MatrixXd> llt(a);
  if (llt.info() != Eigen::Success) {
    throw std::runtime_error("the discriminant's within-place scatter is not positive definite");
  }
  MatrixXd b = llt.matrixL().solve(s.between);
  b = llt.matrixL().solve(b.transpose()).transpose();
  Eigen::SelfAdjointEigenSolver<MatrixXd> eig(b);
  const Eigen::Index d =
      std::min<Eigen::Index>({static_cast<Eigen::Index>(options.discriminant_dimensions), k,
                              static_cast<Eigen::Index>(std::max(1, s.places_seen - 1))});
  const MatrixXd v = eig.eigenvectors().rowwise().reverse().leftCols(d);
  return llt.matrixU().solve(v);  // L^T w = v
}

}  // namespace

JointRepresentation JointRepresentation::Build(JointKind kind,
                                               const std::vector<const StoredReferenceSet*>& sets,
                                               int num_places, const JointOptions& options) {
  options.Validate();
  CheckJointSets(sets, num_places);
  JointRepresentation out;
  out.kind_ = kind;
  out.num_places_ = num_places;
  out.dimension_ = sets.front()->dimension();
  for (const StoredReferenceSet* s : sets) out.set_names_.push_back(s->name());
  std::vector<int> counts;
  if (kind == JointKind::kSubspace) {
    const NormalisedRows x = Normalise(sets, [](int) { return true; });
    SubspaceBasis(x, num_places, &out.place_vectors_, &out.basis_places_);
    return out;
  }
  RowMatrixXf means = PlaceMeans(sets, num_places, &counts);
  if (kind == JointKind::kMeanDescriptor) {
    NormaliseRows(&means);
    out.place_vectors_ = std::move(means);
    return out;
  }
  // The discriminant's scatters, on the rows of every stride-th place.
  const int stride = (num_places + kJointScatterPlaces - 1) / kJointScatterPlaces;
  NormalisedRows x = Normalise(sets, [stride](int p) { return p % stride == 0; });
  RowMatrixXf& c = x.rows;
  const Eigen::RowVectorXf mu = c.colwise().mean();
  c.rowwise() -= mu;
  const MatrixXd p = PrincipalDirections(c, kJointPrincipalDirections);  // D x k
  // The sampled rows in those directions, and the scatters there.
  // R x k: in double where the rows are few (the bits of the studies' cases), a float GEMM
  // where they are many.
  const MatrixXd y = c.rows() <= 2048 ? MatrixXd(c.cast<double>() * p)
                                      : MatrixXd((c * p.cast<float>()).cast<double>());
  const MatrixXd w =
      DiscriminantDirections(PlaceScatters(y, x.places, num_places), options);  // k x d
  out.projection_ = (p * w).transpose().cast<float>();  // d x D
  out.mean_ = mu.transpose();
  // v_p = W^T (m_p - mu) for every place (the means of all its rows, not only the sampled).
  means.rowwise() -= mu;
  out.place_vectors_ = means * out.projection_.transpose();
  for (int place = 0; place < num_places; ++place) {
    if (counts[static_cast<size_t>(place)] == 0) out.place_vectors_.row(place).setZero();
  }
  NormaliseRows(&out.place_vectors_);
  return out;
}

size_t JointRepresentation::MemoryBytes() const {
  return sizeof(float) *
             static_cast<size_t>(place_vectors_.size() + projection_.size() + mean_.size()) +
         sizeof(int) * basis_places_.size();
}

RowMatrixXf JointRepresentation::Distances(const Eigen::Ref<const RowMatrixXf>& queries) const {
  if (empty()) throw std::logic_error("JointRepresentation::Distances before Build");
  if (queries.cols() != dimension_) {
    throw std::invalid_argument("a query of dimension " + std::to_string(queries.cols()) +
                                " for a joint representation of dimension " +
                                std::to_string(dimension_));
  }
  // Query by query, each by matrix-vector products: a query's distances have the same bits
  // whether it comes alone (the node) or in a block (bsf_evaluate).
  RowMatrixXf out(queries.rows(), num_places_);
  Eigen::VectorXf q(dimension_), z, dots;
  for (Eigen::Index i = 0; i < queries.rows(); ++i) {
    q = queries.row(i).transpose();
    const float norm = q.norm();
    if (norm > 0) q /= norm;
    Eigen::Map<Eigen::VectorXf> row(out.row(i).data(), num_places_);
    switch (kind_) {
      case JointKind::kMeanDescriptor:
        row.noalias() = place_vectors_ * q;
        row.array() = 1.0f - row.array();
        break;
      case JointKind::kDiscriminant: {
        z.noalias() = projection_ * (q - mean_);  // d
        const float zn = z.norm();
        if (zn > 0) z /= zn;
        row.noalias() = place_vectors_ * z;
        row.array() = 1.0f - row.array();
        break;
      }
      case JointKind::kSubspace: {
        dots.noalias() = place_vectors_ * q;  // K
        row.setZero();
        for (size_t k = 0; k < basis_places_.size(); ++k) {
          const float v = dots(static_cast<Eigen::Index>(k));
          row(basis_places_[k]) += v * v;
        }
        for (int p = 0; p < num_places_; ++p) {
          row(p) = norm == 0 ? 1.0f : std::sqrt(std::max(0.0f, 1.0f - row(p)));
        }
        break;
      }
    }
  }
  out = out.cwiseMax(0.0f);
  return out;
}

}  // namespace bsf_vpr
