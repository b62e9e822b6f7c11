// Builds joint representations of a map's sets (joint_representation.h) on a thread of its
// own, so that whoever holds the map goes on answering queries meanwhile, with the
// representation it had. A request carries a snapshot of the sets (copies of
// StoredReferenceSet share their rows) and a generation that names it; a request made while
// a build runs waits, and only the latest waiting one is built: a burst of loads builds
// once more, not once each.
//
// Thread-safe. `done` runs on the builder's thread, one result at a time, in request order.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "bsf_vpr/core/joint_representation.h"
#include "bsf_vpr/core/latest_job.h"
#include "bsf_vpr/core/stored_reference_set.h"

namespace bsf_vpr {

class JointBuilder {
 public:
  struct Result {
    uint64_t generation = 0;
    JointKind kind = JointKind::kDiscriminant;
    std::shared_ptr<const JointRepresentation> joint;  // null when it could not be built
    std::string error;                                 // why not ("" when built)
    double seconds = 0;                                // the build's wall time
  };

  explicit JointBuilder(std::function<void(Result)> done) : done_(std::move(done)) {}
  // Lets a running build finish (its result still goes to done); drops a waiting one.
  ~JointBuilder() = default;
  JointBuilder(const JointBuilder&) = delete;
  JointBuilder& operator=(const JointBuilder&) = delete;

  // Asks for `kind` of `sets` (a map of `num_places` places) under `generation`; replaces a
  // request still waiting.
  void Request(JointKind kind, std::vector<StoredReferenceSet> sets, int num_places,
               JointOptions options, uint64_t generation);
  // Whether a build runs or waits.
  bool busy() const { return job_.busy(); }
  // Blocks until no build runs or waits (tests, orderly shutdown).
  void Wait() const { job_.Wait(); }

 private:
  const std::function<void(Result)> done_;
  LatestJob job_;  // last member: its thread ends before done_ goes
};

}  // namespace bsf_vpr
