#include "src/core/internal/worker_pool.h"

#include <algorithm>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

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
      std::lock_guard<std::mutex> lock(mutex_);
      quit_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : workers_) t.join();
  }

  void Run(int count, int threads, const std::function<void(int)>& task) {
    std::lock_guard<std::mutex> serial(run_mutex_);  // one job at a time
    const int helpers = std::max(0, std::min(threads, count) - 1);
    {
      std::lock_guard<std::mutex> lock(mutex_);
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
    std::unique_lock<std::mutex> lock(mutex_);
    wanted_ = joined_;  // a worker that wakes only now is not needed any more
    done_.wait(lock, [this] { return running_ == 0; });
    task_ = nullptr;
    if (error_) std::rethrow_exception(error_);
  }

 private:
  // Takes task indices until none are left.
  void Drain() {
    for (;;) {
      int i;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (next_ >= count_) return;
        i = next_++;
      }
      try {
        RunTask(*task_, i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!error_) error_ = std::current_exception();
      }
    }
  }

  void Work() {
    std::unique_lock<std::mutex> lock(mutex_);
    long seen = generation_;
    for (;;) {
      wake_.wait(lock, [&] { return quit_ || generation_ != seen; });
      if (quit_) return;
      seen = generation_;
      if (joined_ >= wanted_) continue;  // enough helpers for this job
      ++joined_;
      ++running_;
      lock.unlock();
      Drain();
      lock.lock();
      if (--running_ == 0) done_.notify_all();
    }
  }

  std::mutex run_mutex_, mutex_;
  std::condition_variable wake_, done_;
  std::vector<std::thread> workers_;
  const std::function<void(int)>* task_ = nullptr;
  int count_ = 0, next_ = 0, wanted_ = 0, joined_ = 0, running_ = 0;
  long generation_ = 0;
  bool quit_ = false;
  std::exception_ptr error_;
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
