// A process-wide pool of worker threads for the core's parallel loops (distances): started
// once, so a query does not pay for creating threads.
#pragma once

#include <functional>

namespace bsf_vpr {

// Runs task(0), ..., task(count - 1) on up to `threads` threads (the caller's among them)
// and returns when all have finished. The first exception a task throws is rethrown here
// after the others finish. Calls from several threads are served one at a time; a call
// from inside a task runs its tasks inline on that thread.
void RunParallel(int count, int threads, const std::function<void(int)>& task);

}  // namespace bsf_vpr
