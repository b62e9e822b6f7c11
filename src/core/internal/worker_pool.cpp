#include "src/core/internal/worker_pool.h"

#include <algorithm>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include "bsf_vpr/core/mutex.h"

namespace bsf_vpr {
namespace {

thread_local bool t_in_task = false;  // this thread is running a task of the pool

// Runs task(i) marked as inside the pool (a nested RunParallel then runs inline).
void RunTask(const std::function<void(int)>& task, int i) {
  const bool outer = t_in_task;
  t_in_task = true;
  try {
    task(i);
  } catch (...) {
    t_in_task = outer;
    throw;
  }
  t_in_task = outer;
}

class WorkerPool {
 public:
  ~WorkerPool() {
    {
      MutexLock lock(&mutex_);
      quit_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : workers_) t.join();
  }

  void Run(int count, int threads, const std::function<void(int)>& task) {
    MutexLock serial(&run_mutex_);  // one job at a time
    const int helpers = std::max(0, std::min(threads, count) - 1);
    {
      MutexLock lock(&mutex_);
      while (static_cast<int>(workers_.size()) < helpers) {
        workers_.emplace_back([this] { Work(); });
      }
      task_ = &task;
      count_ = count;
      next_ = 0;
      wanted_ = helpers;
      joined_ = 0;
      error_ = nullptr;
      ++generation_;
    }
    if (helpers > 0) wake_.notify_all();
    Drain();
    MutexLock lock(&mutex_);
    wanted_ = joined_;  // a worker that wakes only now is not needed any more
    lock.Await(done_, [this] {
      mutex_.AssertHeld();
      return running_ == 0;
    });
    task_ = nullptr;
    if (error_) std::rethrow_exception(error_);
  }

 private:
  // Takes task indices until none are left.
  void Drain() {
    for (;;) {
      int i;
      {
        MutexLock lock(&mutex_);
        if (next_ >= count_) return;
        i = next_++;
      }
      try {
        RunTask(*task_, i);
      } catch (...) {
        MutexLock lock(&mutex_);
        if (!error_) error_ = std::current_exception();
      }
    }
  }

  void Work() {
    MutexLock lock(&mutex_);
    long seen = generation_;
    for (;;) {
      lock.Await(wake_, [&] {
        mutex_.AssertHeld();
        return quit_ || generation_ != seen;
      });
      if (quit_) return;
      seen = generation_;
      if (joined_ >= wanted_) continue;  // enough helpers for this job
      ++joined_;
      ++running_;
      lock.Unlock();
      Drain();
      lock.Lock();
      if (--running_ == 0) done_.notify_all();
    }
  }

  Mutex run_mutex_ ACQUIRED_BEFORE(mutex_);  // one job at a time
  Mutex mutex_;
  std::condition_variable wake_, done_;
  std::vector<std::thread> workers_ GUARDED_BY(mutex_);
  // Set under mutex_ before the helpers wake, read by them while the job runs (Run waits for
  // every helper before it clears it).
  const std::function<void(int)>* task_ = nullptr;
  int count_ GUARDED_BY(mutex_) = 0;
  int next_ GUARDED_BY(mutex_) = 0;
  int wanted_ GUARDED_BY(mutex_) = 0;
  int joined_ GUARDED_BY(mutex_) = 0;
  int running_ GUARDED_BY(mutex_) = 0;
  long generation_ GUARDED_BY(mutex_) = 0;
  bool quit_ GUARDED_BY(mutex_) = false;
  std::exception_ptr error_ GUARDED_BY(mutex_);
};

}  // namespace

void RunParallel(int count, int threads, const std::function<void(int)>& task) {
  if (count <= 0) return;
  if (threads <= 1 || count == 1 || t_in_task) {  // nested calls run inline
    for (int i = 0; i < count; ++i) task(i);
    return;
  }
  static WorkerPool pool;
  pool.Run(count, threads, task);
}

}  // namespace bsf_vpr
