#include "bsf_vpr/map/local_map.h"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "bsf_vpr/core/sharding.h"
#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "bsf_vpr/map/set_loading.h"

namespace bsf_vpr {

namespace {

// Below this share of the rows' energy the first stage's basis warns (docs/performance.md).
constexpr double kFirstStageEnergyWarning = 0.99;

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string Printed(const char* format, double value) {
  char out[64];
  std::snprintf(out, sizeof out, format, value);
  return out;
}

// How the map's sets are brought in (memory_map).
ReadSetOptions ReadOptionsOf(const LocalMapOptions& options) {
  ReadSetOptions out;
  if (options.memory_map) out.memory_map = options.storage;
  return out;
}

}  // namespace

LocalMap::LocalMap(LocalMapOptions options, const DataDirectory* data_dir, std::string shard)
    : options_(std::move(options)),
      data_dir_(data_dir),
      shard_(std::move(shard)),
      metric_(options_.metric.value_or(DistanceMetric::kEuclidean)),
      layout_(std::make_shared<NumberedLayout>(PlaceLayout(), 0)) {
  MutexLock lock(&mutex_);
  sets_.SetStoragePrecision(options_.storage);
  sets_.SetPlacePoseTolerance(options_.place_pose_tolerance_m);
  stage_.SetOptions(options_.first_stage);
}

void LocalMap::Log(LogLevel level, const std::string& message) const {
  if (options_.log) options_.log(level, message);
}

void LocalMap::LoadConfigured(const std::vector<ConfiguredSet>& configured) {
  // Read and encoded without the lock (a mapped set's norms are read here).
  std::vector<std::pair<StoredReferenceSet, std::string>> sets;  // and the file each came from
  for (const ConfiguredSet& e : configured) {
    ReferenceSet set = LoadReferenceSetFile(e.path, e.name, ReadOptionsOf(options_));
    if (!e.condition.empty()) set.condition = e.condition;
    sets.emplace_back(ReferenceSets::Store(std::move(set), options_.storage), e.path);
  }
  MutexLock lock(&mutex_);
  if (!options_.metric) {
    // The distance the sets were made for, if they agree on one.
    std::string declared;
    for (const auto& [set, path] : sets) {
      if (set.distance().empty()) continue;
      if (!declared.empty() && set.distance() != declared) {
        throw std::invalid_argument("the reference sets are meant for different distances (" +
                                    declared + " and " + set.distance() + " for '" + set.name() +
                                    "'); set the parameter distance");
      }
      declared = set.distance();
    }
    if (!declared.empty()) metric_ = ParseDistanceMetric(declared);
  }
  for (auto& [set, path] : sets) {
    CheckSetDistance(set, metric_, path);
    sets_.Add(std::move(set));
    const StoredReferenceSet& s = sets_.sets().back();
    if (options_.fingerprints) fingerprints_.push_back(SetFingerprint(s));
    Log(LogLevel::kInfo, "loaded reference set '" + s.name() + "' (" + std::to_string(s.size()) +
                             " places, dimension " + std::to_string(s.dimension()) + ", " +
                             ToString(s.precision()) +
                             (s.mapped() ? ", memory-mapped from " + s.rows_source() : "") + ")");
  }
  Changed();
}

MapBackend::Layout LocalMap::layout() const {
  MutexLock lock(&mutex_);
  return layout_;
}

DistanceMetric LocalMap::metric() const {
  MutexLock lock(&mutex_);
  return metric_;
}

RowMatrixXf LocalMap::QueryRow(const QueryDescriptor& descriptor) const {
  const Eigen::Map<const Eigen::VectorXf> d = descriptor.view();
  sets_.CheckQuery(d);
  return d.transpose();
}

MapBackend::Query LocalMap::Ask(const QueryDescriptor& descriptor) {
  const auto start = std::chrono::steady_clock::now();
  Query query;
  query.header = descriptor.header;
  MutexLock lock(&mutex_);
  DropChangedSets();
  const RowMatrixXf row = QueryRow(descriptor);
  query.layout = layout_;
  bool changed = false;
  query.distances = ReadDistances(row, &changed);
  query.acceptance_rule = calibrator_.rule();
  if (changed) DropChangedSets();  // the next query's layout is without them
  query.seconds = SecondsSince(start);
  return query;
}

QueryDistances LocalMap::ReadDistances(const RowMatrixXf& row, bool* changed) {
  QueryDistances distances = DistancesOf(row);
  if (joint_ && joint_->num_places() == sets_.num_places()) {
    distances.SetJoint({joint_->kind(), joint_build_, joint_->Distances(row)});
  }
  // Asked after the rows were read: a write in place changes a file's modification time
  // before its bytes, so rows read while (or after) it wrote are seen here.
  for (int u = 0; u < sets_.num_sets(); ++u) {
    if (sets_.set(u).RowsChanged().empty()) continue;
    distances.SetAbsent(u);
    distances.ClearJoint();
    *changed = true;
  }
  return distances;
}

void LocalMap::DropChangedSets() {
  bool any = false;
  for (int u = sets_.num_sets() - 1; u >= 0; --u) {
    const std::string why = sets_.set(u).RowsChanged();
    if (why.empty()) continue;
    const std::string name = sets_.set(u).name();
    if (joint_) {
      const std::vector<std::string>& in_joint = joint_->set_names();
      if (std::find(in_joint.begin(), in_joint.end(), name) != in_joint.end()) joint_.reset();
    }
    sets_.Remove(name);
    if (options_.fingerprints) fingerprints_.erase(fingerprints_.begin() + u);
    dropped_[name] = why;
    last_dropped_ = name;
    any = true;
    Log(LogLevel::kError, "reference set '" + name + "' unloaded: its file " + why +
                              " while memory-mapped; no belief uses its rows from now on: "
                              "load it again to use the file as it is now");
  }
  if (any) Changed();
}

std::string LocalMap::Load(const LoadRequest& request, const SetCheck& check) {
  if (!request.shard.empty()) {
    throw std::invalid_argument("shard " + QuotedForMessage(request.shard) +
                                " given, but this node fuses no shards (parameter shards)");
  }
  // Read, and encoded (a mapped set's norms read), without the lock: queries go on.
  ReferenceSet set = ReadRequestedSet(data_dir_, request, ReadOptionsOf(options_));
  if (check) check(set.name);
  StoredReferenceSet stored = ReferenceSets::Store(std::move(set), options_.storage);
  MutexLock lock(&mutex_);
  return AddLocked(std::move(stored), data_dir_->Relative(request.path));
}

std::string LocalMap::Add(ReferenceSet set, const std::string& where) {
  StoredReferenceSet stored = ReferenceSets::Store(std::move(set), options_.storage);
  MutexLock lock(&mutex_);
  return AddLocked(std::move(stored), where);
}

std::string LocalMap::AddLocked(StoredReferenceSet set, const std::string& where) {
  DistanceMetric metric = metric_;
  if (!options_.metric && sets_.num_sets() == 0 && !set.distance().empty()) {
    // No distance configured and nothing loaded yet: the first set's own distance.
    metric = ParseDistanceMetric(set.distance());
  }
  CheckSetDistance(set, metric, where);
  const std::string name = set.name();
  const int places = set.size();
  const std::string declared = set.distance();
  fingerprints_.reserve(fingerprints_.size() + 1);  // no throw once the set is in
  sets_.Add(std::move(set));
  if (options_.fingerprints) fingerprints_.push_back(SetFingerprint(sets_.sets().back()));
  dropped_.erase(name);
  if (metric != metric_) {
    metric_ = metric;
    Log(LogLevel::kInfo, "distance " + declared + ", as the reference set '" + name + "' declares");
  }
  Changed();
  return "loaded '" + name + "' (" + std::to_string(places) + " places)" +
         (shard_.empty() ? "" : " on shard " + shard_);
}

std::string LocalMap::Unload(const std::string& name) {
  MutexLock lock(&mutex_);
  const int u = sets_.IndexOf(name);
  if (u < 0) {
    throw std::invalid_argument("no reference set named " + QuotedForMessage(name) + " is loaded" +
                                (shard_.empty() ? "" : " on shard " + shard_));
  }
  sets_.Remove(name);
  if (options_.fingerprints) fingerprints_.erase(fingerprints_.begin() + u);
  Changed();
  return "unloaded '" + name + "'" + (shard_.empty() ? "" : " from shard " + shard_);
}

void LocalMap::Changed() {
  layout_ = std::make_shared<NumberedLayout>(sets_.layout(), ++generations_);
  RequestJoint();
  calibrator_.Calibrate(sets_, metric_, layout_->generation);
  if (sets_.num_sets() == 0) {
    index_.reset();  // nothing to answer for; the next set starts a new basis
    stage_.Adopt(nullptr);
    index_status_ = "none built yet";
    return;
  }
  if (stage_.kind() == FirstStageKind::kPca) RequestIndex();
}

QueryDistances LocalMap::DistancesOf(const RowMatrixXf& row) {
  const DistanceIndex* index = stage_.Current();
  if (!index) {
    throw std::invalid_argument("the first stage's index is being built (" + index_status_ +
                                "): no set answers until it is ready");
  }
  std::vector<bool> covered;
  std::vector<RowMatrixXf> distances = index->Search(metric_, row, sets_, &covered);
  QueryDistances out(sets_.num_sets());
  for (int u = 0; u < sets_.num_sets(); ++u) {
    if (covered[static_cast<size_t>(u)]) out.Set(u, std::move(distances[static_cast<size_t>(u)]));
  }
  return out;
}

void LocalMap::RequestIndex() {
  auto sets = std::make_shared<const std::vector<StoredReferenceSet>>(sets_.sets());
  std::shared_ptr<const ApproximateIndex> base = index_;
  const uint64_t generation = layout_->generation;
  const ApproximateOptions options = stage_.options().approximate;
  int64_t rows = 0;
  for (const StoredReferenceSet& set : *sets) rows += set.size();
  index_status_ = "building the index of " + std::to_string(sets->size()) + " sets (" +
                  std::to_string(rows) + " rows)" +
                  (base ? "; the previous index answers for the sets it holds meanwhile" : "");
  index_job_.Ask([this, sets, base, generation, options] {
    IndexResult result;
    result.generation = generation;
    const auto start = std::chrono::steady_clock::now();
    try {
      // One thread, the job's own: the worker pool stays the queries'.
      std::shared_ptr<const ApproximateIndex> built;
      int kept = 0, projected = 0;
      bool refit = !base;
      if (base) {
        for (const StoredReferenceSet& set : *sets) (base->Covers(set) ? kept : projected)++;
        built = std::make_shared<const ApproximateIndex>(*base, *sets, /*threads=*/1);
        // A basis fitted without a new set may miss its directions: when it keeps of the
        // new set's energy a point less than of the rows it was fitted to (and under the
        // warning's 99%), a basis is fitted to all sets. Random rows, which no basis fits,
        // are kept alike by any: they do not make every load refit.
        const double fits = std::min(kFirstStageEnergyWarning, base->RetainedEnergy() - 0.01);
        for (const StoredReferenceSet& set : *sets) {
          if (!base->Covers(set) && built->RetainedEnergyOf(set) < fits) refit = true;
        }
        result.how = std::to_string(kept) + " sets kept, " + std::to_string(projected) +
                     " projected onto the basis";
      }
      if (refit) {
        built = std::make_shared<const ApproximateIndex>(*sets, options, /*threads=*/1);
        result.how = base ? "a new basis (the old one kept too little of a new set's energy)"
                          : "a new basis";
      }
      result.index = std::move(built);
    } catch (const std::exception& e) {
      result.error = e.what();
    }
    result.seconds = SecondsSince(start);
    IndexBuilt(std::move(result));
  });
}

void LocalMap::IndexBuilt(IndexResult result) {
  MutexLock lock(&mutex_);
  if (stage_.kind() != FirstStageKind::kPca) return;
  if (!result.index) {
    // The sets stay as they are; exact search answers until the node is restarted, rather
    // than every change trying the build again.
    FirstStageOptions exact = stage_.options();
    exact.kind = ToString(FirstStageKind::kExact);
    stage_.SetOptions(exact);
    first_stage_error_ = result.error;
    index_.reset();
    Log(LogLevel::kError,
        "the pca first stage could not be built (" + result.error + "): exact search from now on");
    return;
  }
  if (sets_.num_sets() == 0 || result.generation < index_generation_) return;  // superseded
  index_ = std::move(result.index);
  stage_.Adopt(index_);
  index_generation_ = result.generation;
  const bool current = result.generation == layout_->generation;
  index_status_ = "pca: " + std::to_string(index_->dimensions()) + " dimensions keeping " +
                  Printed("%.1f%%", 100.0 * index_->RetainedEnergy()) + " of the energy of " +
                  std::to_string(index_->rows()) + " rows, " +
                  std::to_string(index_->options().rerank) + " re-ranked per set, " +
                  Printed("%.1f MB", index_->MemoryBytes() / 1e6) +
                  (current ? "" : " (a newer build follows)");
  Log(LogLevel::kInfo, "first stage " + index_status_ + ", built in " +
                           Printed("%.2f s", result.seconds) +
                           (result.how.empty() ? "" : " (" + result.how + ")"));
  const double energy = index_->RetainedEnergy();
  if (energy < kFirstStageEnergyWarning) {
    // On the real data, bases keeping under 99% lost 2 points of R@1 and more.
    Log(LogLevel::kWarn,
        "the first stage's basis keeps only " + Printed("%.1f%%", 100.0 * energy) +
            " of the rows' energy: recall may fall short of exact search; raise "
            "first_stage_dimensions or first_stage_sample_rows, or measure with bsf_evaluate "
            "--first-stage pca (docs/performance.md, large maps)");
  }
}

void LocalMap::SetJoint(std::optional<JointKind> kind, const JointOptions& options) {
  MutexLock lock(&mutex_);
  const bool same = kind == joint_kind_ &&
                    options.discriminant_dimensions == joint_options_.discriminant_dimensions &&
                    options.discriminant_ridge == joint_options_.discriminant_ridge;
  if (same) return;
  joint_kind_ = kind;
  joint_options_ = options;
  joint_.reset();  // another kind or other options: the old one answers for nothing asked
  RequestJoint();
}

void LocalMap::RequestJoint() {
  if (joint_ && joint_->num_places() != sets_.num_places()) joint_.reset();
  if (!joint_kind_) {
    joint_.reset();
    joint_status_ = "none asked for";
    return;
  }
  std::vector<const StoredReferenceSet*> sets;
  for (const StoredReferenceSet& s : sets_.sets()) sets.push_back(&s);
  try {
    CheckJointSets(sets, sets_.num_places());
  } catch (const std::invalid_argument& e) {
    joint_.reset();
    joint_status_ = std::string("none: ") + e.what();
    return;
  }
  joint_status_ = "building " + ToString(*joint_kind_) + " of " + std::to_string(sets_.num_sets()) +
                  " sets" + (joint_ ? " (the previous one answers meanwhile)" : "");
  joint_builder_.Request(*joint_kind_, sets_.sets(), sets_.num_places(), joint_options_,
                         layout_->generation);
}

void LocalMap::JointBuilt(JointBuilder::Result result) {
  MutexLock lock(&mutex_);
  if (result.generation != layout_->generation || !joint_kind_ || result.kind != *joint_kind_) {
    return;  // the sets or the kind changed since: a newer request is on its way
  }
  const std::string took = Printed("%.2f s", result.seconds);
  for (const StoredReferenceSet& s : sets_.sets()) {
    if (!s.RowsChanged().empty()) return;  // built from rows that changed: the set goes first
  }
  if (!result.joint) {
    joint_.reset();
    joint_status_ = "failed: " + result.error;
    Log(LogLevel::kError, "the " + ToString(result.kind) +
                              " representation of the sets could not be built (" + result.error +
                              "): the method goes on with the sets alone");
    return;
  }
  joint_ = std::move(result.joint);
  joint_build_ = ++joint_builds_;
  std::string sets;
  for (const std::string& n : joint_->set_names()) sets += (sets.empty() ? "" : ", ") + n;
  joint_status_ = ToString(joint_->kind()) + " of " + sets +
                  (joint_->kind() == JointKind::kDiscriminant
                       ? " (" + std::to_string(joint_->discriminant_dimensions()) + " dimensions)"
                       : std::string()) +
                  ", built in " + took;
  Log(LogLevel::kInfo, "joint representation " + joint_status_);
}

SetList LocalMap::List() const {
  MutexLock lock(&mutex_);
  SetList out;
  for (const StoredReferenceSet& s : sets_.sets()) out.sets.push_back(Summarize(s));
  out.num_places = sets_.num_places();
  out.calibration = calibrator_.status();
  return out;
}

void LocalMap::SetCalibration(std::optional<CalibrationRequest> request) {
  MutexLock lock(&mutex_);
  if (calibrator_.SetRequest(std::move(request))) {
    calibrator_.Calibrate(sets_, metric_, layout_->generation);
  }
}

std::string LocalMap::DescriptorTypeMismatch(const std::string& type) const {
  MutexLock lock(&mutex_);
  return TypeMismatch(type, sets_.layout());
}

std::string LocalMap::Problem() const {
  MutexLock lock(&mutex_);
  if (!dropped_.empty()) {
    const auto last = dropped_.find(last_dropped_);
    const auto& [name, why] = last != dropped_.end() ? *last : *dropped_.begin();
    return "reference set '" + name + "' was unloaded: its file " + why +
           " while memory-mapped; load it again" +
           (dropped_.size() > 1 ? " (and " + std::to_string(dropped_.size() - 1) + " more)" : "");
  }
  return first_stage_error_.empty()
             ? ""
             : "first stage pca failed, exact search instead: " + first_stage_error_;
}

StatusValues LocalMap::Diagnose() const {
  MutexLock lock(&mutex_);
  std::string first_stage = stage_.Summary();
  if (!first_stage_error_.empty()) {
    first_stage = "exact: pca failed: " + first_stage_error_;
  } else if (stage_.kind() == FirstStageKind::kPca) {
    first_stage = index_job_.busy() ? index_status_ + " (building a new index)" : index_status_;
  }
  StatusValues out = {{"joint representation", joint_status_}, {"first stage", first_stage}};
  out.push_back({"calibration", calibrator_.status()});
  for (const auto& [name, why] : dropped_) {
    out.push_back({"unloaded, its file changed in place: " + name, why});
  }
  return out;
}

ShardAnswer LocalMap::Answer(const QueryDescriptor& descriptor) {
  ShardAnswer out;
  MutexLock lock(&mutex_);
  if (sets_.num_sets() == 0) return out;  // a shard without sets answers with none
  try {
    DropChangedSets();
    if (sets_.num_sets() == 0) return out;
    const RowMatrixXf row = QueryRow(descriptor);
    bool changed = false;
    QueryDistances distances = ReadDistances(row, &changed);
    // A set whose codes are being built (or whose rows changed) is left out: the combiner
    // takes it for absent.
    for (int u = 0; u < sets_.num_sets(); ++u) {
      if (!distances.present(u)) continue;
      out.distances.push_back(distances.Take(u));
      out.set_names.push_back(sets_.set(u).name());
      out.fingerprints.push_back(options_.fingerprints ? fingerprints_.at(static_cast<size_t>(u))
                                                       : 0);
    }
    if (distances.joint()) {
      out.joint_kind = joint_->kind();
      out.joint_build = joint_build_;
      out.joint_sets = joint_->set_names();
      out.joint_distances = std::move(distances.joint()->distances);
    }
    if (changed) DropChangedSets();
  } catch (const std::exception& e) {
    out = ShardAnswer();
    out.error = e.what();
  }
  return out;
}

void LocalMap::ForEachSet(
    const std::function<void(const StoredReferenceSet& set, uint64_t fingerprint)>& visit) const {
  MutexLock lock(&mutex_);
  for (int u = 0; u < sets_.num_sets(); ++u) {
    visit(sets_.set(u), options_.fingerprints ? fingerprints_.at(static_cast<size_t>(u)) : 0);
  }
}

int LocalMap::num_sets() const {
  MutexLock lock(&mutex_);
  return sets_.num_sets();
}

void LocalMap::ReadSets(const std::function<void(const ReferenceSets& sets)>& read) const {
  MutexLock lock(&mutex_);
  read(sets_);
}

std::shared_ptr<const ApproximateIndex> LocalMap::index() const {
  MutexLock lock(&mutex_);
  return index_;
}

}  // namespace bsf_vpr
