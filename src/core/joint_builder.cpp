#include "bsf_vpr/core/joint_builder.h"

#include <chrono>
#include <exception>

namespace bsf_vpr {

void JointBuilder::Request(JointKind kind, std::vector<StoredReferenceSet> sets, int num_places,
                           JointOptions options, uint64_t generation) {
  // The job owns its snapshot of the sets (shared rows); it is dropped with the job.
  auto snapshot = std::make_shared<std::vector<StoredReferenceSet>>(std::move(sets));
  job_.Ask([this, kind, snapshot, num_places, options, generation] {
    Result result;
    result.generation = generation;
    result.kind = kind;
    const auto start = std::chrono::steady_clock::now();
    try {
      std::vector<const StoredReferenceSet*> pointers;
      for (const StoredReferenceSet& s : *snapshot) pointers.push_back(&s);
      result.joint = std::make_shared<const JointRepresentation>(
          JointRepresentation::Build(kind, pointers, num_places, options));
    } catch (const std::exception& e) {
      result.error = e.what();
    }
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    snapshot->clear();  // the snapshot's rows go before the result is handed on
    done_(std::move(result));
  });
}

}  // namespace bsf_vpr
