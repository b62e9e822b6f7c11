#include "bsf_vpr/core/first_stage.h"

#include <cstdio>
#include <stdexcept>

namespace bsf_vpr {

const EnumNames<FirstStageKind>& FirstStageKindNames() {
  static const EnumNames<FirstStageKind> kNames{{FirstStageKind::kExact, "exact"},
                                                {FirstStageKind::kPca, "pca"}};
  return kNames;
}

std::string ToString(FirstStageKind kind) { return FirstStageKindNames().Name(kind); }

FirstStageKind FirstStageOptions::Kind() const {
  return FirstStageKindNames().Parse(kind, "first_stage");
}

void FirstStageOptions::Validate() const {
  // The choice and the bounds, named as the options are (first_stage_dimensions, ...).
  FirstStageOptionsTable().CheckValues(*this);
}

const OptionTable<FirstStageOptions>& FirstStageOptionsTable() {
  static const OptionTable<FirstStageOptions> kTable =
      OptionTable<FirstStageOptions>()
          .AddChoice(
              "first_stage", [](auto& o) -> auto& { return o.kind; },
              "how distances to the reference rows are computed: exact (every stored "
              "descriptor) or pca (a compressed first stage for maps too large to search "
              "exactly at camera rate: approximate distances to every row from int8 "
              "projections onto a PCA basis of the map, then each set's rerank_candidates "
              "nearest made exact; docs/performance.md gives its error on real data)",
              FirstStageKindNames())
          .Include(
              ApproximateOptionsTable(), [](auto& o) -> auto& { return o.approximate; });
  return kTable;
}

void DistanceStage::SetOptions(const FirstStageOptions& options) {
  options.Validate();
  const FirstStageKind kind = options.Kind();
  const ApproximateOptions& a = options.approximate;
  const ApproximateOptions& b = options_.approximate;
  if (kind != kind_ || a.dimensions != b.dimensions || a.rerank != b.rerank ||
      a.sample_rows != b.sample_rows || a.seed != b.seed) {
    index_.reset();
  }
  options_ = options;
  kind_ = kind;
}

void DistanceStage::Prepare(const ReferenceSets& map) {
  if (kind_ == FirstStageKind::kPca && !index_ && map.num_sets() > 0) {
    index_ = std::make_shared<const ApproximateIndex>(map, options_.approximate);
  }
}

std::vector<RowMatrixXf> DistanceStage::Distances(DistanceMetric metric, const RowMatrixXf& queries,
                                                  const ReferenceSets& map) {
  // An empty map has no rows to project: the exact search answers (and checks the queries).
  if (map.num_sets() > 0) Prepare(map);
  const DistanceIndex* index = map.num_sets() > 0 ? Current() : &ExactIndex::Instance();
  return index->Search(metric, queries, map, nullptr);
}

const DistanceIndex* DistanceStage::Current() const {
  if (kind_ == FirstStageKind::kExact) return &ExactIndex::Instance();
  return index_.get();
}

const ExactIndex& ExactIndex::Instance() {
  static const ExactIndex kIndex;
  return kIndex;
}

std::vector<RowMatrixXf> ExactIndex::Search(DistanceMetric metric, const RowMatrixXf& queries,
                                            const ReferenceSets& sets,
                                            std::vector<bool>* covered) const {
  if (covered) covered->assign(static_cast<size_t>(sets.num_sets()), true);
  return ComputeDistances(metric, queries, sets);
}

std::string DistanceStage::Summary() const {
  if (kind_ == FirstStageKind::kExact) return ToString(kind_);
  if (!index_) return "pca: no index built yet";
  char text[160];
  std::snprintf(text, sizeof text,
                "pca: %d dimensions keeping %.1f%% of the energy of %lld rows, %d re-ranked per "
                "set, %.1f MB",
                index_->dimensions(), 100.0 * index_->RetainedEnergy(),
                static_cast<long long>(index_->rows()), index_->options().rerank,
                index_->MemoryBytes() / 1e6);
  return text;
}

}  // namespace bsf_vpr
