// One thread that runs the latest job asked of it: the background builds of what depends on
// a map's sets (the joint representation, the first stage's index), so that whoever holds
// the map goes on answering queries meanwhile. A job asked for while another runs waits;
// only the latest waiting one runs (a burst of loads builds once more, not once each).
//
// Thread-safe. Jobs run on the thread one at a time, in the order asked, never at once; an
// exception a job throws is swallowed (a job reports its own failures).
#pragma once

#include <condition_variable>
#include <functional>
#include <optional>
#include <thread>

#include "bsf_vpr/core/mutex.h"

namespace bsf_vpr {

class LatestJob {
 public:
  LatestJob();
  // Lets a running job finish; drops a waiting one.
  ~LatestJob();
  LatestJob(const LatestJob&) = delete;
  LatestJob& operator=(const LatestJob&) = delete;

  // Replaces the job still waiting, if any, by `job`.
  void Ask(std::function<void()> job);
  // Whether a job runs or waits.
  bool busy() const;
  // Blocks until no job runs or waits (tests, orderly shutdown).
  void Wait() const;

 private:
  void Run();

  mutable Mutex mutex_;
  mutable std::condition_variable changed_;
  std::optional<std::function<void()>> waiting_ GUARDED_BY(mutex_);
  bool running_ GUARDED_BY(mutex_) = false;
  bool stop_ GUARDED_BY(mutex_) = false;
  std::thread thread_;  // last member: starts once the others exist
};

}  // namespace bsf_vpr
