#include "bsf_vpr/core/latest_job.h"

#include <utility>

namespace bsf_vpr {

LatestJob::LatestJob() : thread_([this] { Run(); }) {}

LatestJob::~LatestJob() {
  {
    MutexLock lock(&mutex_);
    stop_ = true;
    waiting_.reset();
  }
  changed_.notify_all();
  thread_.join();
}

void LatestJob::Ask(std::function<void()> job) {
  {
    MutexLock lock(&mutex_);
    waiting_ = std::move(job);
  }
  changed_.notify_all();
}

bool LatestJob::busy() const {
  MutexLock lock(&mutex_);
  return running_ || waiting_.has_value();
}

void LatestJob::Wait() const {
  MutexLock lock(&mutex_);
  lock.Await(changed_, [this] {
    mutex_.AssertHeld();
    return !running_ && !waiting_;
  });
}

void LatestJob::Run() {
  for (;;) {
    std::function<void()> job;
    {
      MutexLock lock(&mutex_);
      lock.Await(changed_, [this] {
        mutex_.AssertHeld();
        return stop_ || waiting_.has_value();
      });
      if (stop_) return;
      job = std::move(*waiting_);
      waiting_.reset();
      running_ = true;
    }
    try {
      job();
    } catch (...) {  // a job's failure must not end the thread
    }
    job = nullptr;  // what the job holds (a snapshot of sets) goes before it is reported done
    {
      MutexLock lock(&mutex_);
      running_ = false;
    }
    changed_.notify_all();
  }
}

}  // namespace bsf_vpr
