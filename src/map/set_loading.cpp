#include "bsf_vpr/map/set_loading.h"

#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/reference_set_io.h"

namespace bsf_vpr {

void CheckSetDistance(const StoredReferenceSet& set, DistanceMetric metric,
                      const std::string& where) {
  const std::string name = ToString(metric);
  if (!set.distance().empty() && set.distance() != name) {
    throw std::invalid_argument("reference set '" + set.name() + "' (" + where + ") is meant for " +
                                set.distance() + " distance, the node uses " + name);
  }
}

ReferenceSet ReadRequestedSet(const DataDirectory* dir, const LoadRequest& req,
                              const ReadSetOptions& options) {
  if (!dir) {
    throw std::invalid_argument("no data directory is configured (parameter data_directory)");
  }
  ReferenceSet set = LoadReferenceSetFile(*dir, req.path, req.name, options);
  if (!req.condition.empty()) set.condition = req.condition;
  return set;
}

std::string TypeMismatch(const std::string& type, const PlaceLayout& layout) {
  if (type.empty()) return "";
  for (const SetLayout& s : layout.sets()) {
    if (!s.descriptor_type.empty() && s.descriptor_type != type) {
      return "descriptors of type " + QuotedForMessage(type, 60) + " meet set '" + s.name +
             "' of type '" + s.descriptor_type + "'";
    }
  }
  return "";
}

SetSummary Summarize(const StoredReferenceSet& set) {
  SetSummary s;
  s.layout = set.layout();
  s.memory_bytes = set.MemoryBytes();
  s.storage = ToString(set.precision()) + (set.mapped() ? " (memory-mapped)" : "");
  return s;
}

}  // namespace bsf_vpr
