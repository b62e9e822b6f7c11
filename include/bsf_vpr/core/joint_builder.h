// Builds joint representations of a map's sets (joint_representation.h) on a thread of its
// own, so that whoever holds the map goes on answering queries meanwhile, with the
// representation it had. A request carries a snapshot of the sets (copies of
// StoredReferenceSet share their rows) and a generation that names it; a request made while
// a build runs waits, and only the latest waiting one is built: a burst of loads builds
// once more, not once each.
//
// Thread-safe. `done` runs on the builder's thread, one result at a time, in request order.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "bsf_vpr/core/joint_representation.h"
#include "bsf_vpr/core/mutex.h"
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

  explicit JointBuilder(std::function<void(Result)> done);
  ~JointBuilder();  // lets a running build finish (its result still goes to done); drops a waiting
                    // one
  JointBuilder(const JointBuilder&) = delete;
  JointBuilder& operator=(const JointBuilder&) = delete;

  // Asks for `kind` of `sets` (a map of `num_places` places) under `generation`; replaces a
  // request still waiting.
  void Request(JointKind kind, std::vector<StoredReferenceSet> sets, int num_places,
               JointOptions options, uint64_t generation);
  // Whether a build runs or waits.
  bool busy() const;
  // Blocks until no build runs or waits (tests, orderly shutdown).
  void Wait() const;

 private:
  struct Request_ {
    JointKind kind;
    std::vector<StoredReferenceSet> sets;
    int num_places = 0;
    JointOptions options;
    uint64_t generation = 0;
  };
  void Run();

  const std::function<void(Result)> done_;
  mutable Mutex mutex_;
  mutable std::condition_variable changed_;
  std::optional<Request_> waiting_ GUARDED_BY(mutex_);
  bool running_ GUARDED_BY(mutex_) = false;
  bool stop_ GUARDED_BY(mutex_) = false;
  std::thread thread_;               // last member: starts once the others exist
};

}  // namespace bsf_vpr
