// A mutex whose locking clang checks at compile time (-Wthread-safety), as cartographer's
// absl::Mutex is: members are declared GUARDED_BY the mutex that protects them, functions
// that expect it held REQUIRES it, and clang refuses code that reads a guarded member
// without the lock. GCC compiles the annotations to nothing; the CI's clang pass
// (scripts/thread_safety) checks every translation unit.
//
//   Mutex mutex_;
//   int count_ GUARDED_BY(mutex_) = 0;
//   void Bump() REQUIRES(mutex_);
//   ...
//   MutexLock lock(&mutex_);  // held to the end of the scope
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>

#if defined(__clang__)
#define BSF_THREAD_ANNOTATION(x) __attribute__((x))
#else
#define BSF_THREAD_ANNOTATION(x)
#endif

#define CAPABILITY(x) BSF_THREAD_ANNOTATION(capability(x))
#define SCOPED_CAPABILITY BSF_THREAD_ANNOTATION(scoped_lockable)
#define GUARDED_BY(x) BSF_THREAD_ANNOTATION(guarded_by(x))
#define PT_GUARDED_BY(x) BSF_THREAD_ANNOTATION(pt_guarded_by(x))
#define ACQUIRED_BEFORE(...) BSF_THREAD_ANNOTATION(acquired_before(__VA_ARGS__))
#define ACQUIRED_AFTER(...) BSF_THREAD_ANNOTATION(acquired_after(__VA_ARGS__))
#define REQUIRES(...) BSF_THREAD_ANNOTATION(requires_capability(__VA_ARGS__))
#define ACQUIRE(...) BSF_THREAD_ANNOTATION(acquire_capability(__VA_ARGS__))
#define RELEASE(...) BSF_THREAD_ANNOTATION(release_capability(__VA_ARGS__))
#define EXCLUDES(...) BSF_THREAD_ANNOTATION(locks_excluded(__VA_ARGS__))
#define ASSERT_CAPABILITY(x) BSF_THREAD_ANNOTATION(assert_capability(x))
#define RETURN_CAPABILITY(x) BSF_THREAD_ANNOTATION(lock_returned(x))
#define NO_THREAD_SAFETY_ANALYSIS BSF_THREAD_ANNOTATION(no_thread_safety_analysis)

namespace bsf_vpr {

class CAPABILITY("mutex") Mutex {
 public:
  Mutex() = default;
  Mutex(const Mutex&) = delete;
  Mutex& operator=(const Mutex&) = delete;

  void Lock() ACQUIRE() { mutex_.lock(); }
  void Unlock() RELEASE() { mutex_.unlock(); }
  // Tells the analysis that the caller holds the lock where it cannot see it (a condition
  // variable's predicate, which runs under the lock its wait took).
  void AssertHeld() const ASSERT_CAPABILITY(this) {}

 private:
  friend class MutexLock;
  std::mutex mutex_;
};

// Holds `mutex` from construction to the end of the scope. Await* wait on a condition
// variable, the lock released while waiting and held again when they return.
class SCOPED_CAPABILITY MutexLock {
 public:
  explicit MutexLock(Mutex* mutex) ACQUIRE(mutex) : lock_(mutex->mutex_) {}
  ~MutexLock() RELEASE() {}
  MutexLock(const MutexLock&) = delete;
  MutexLock& operator=(const MutexLock&) = delete;

  // Releases the lock for a while (Lock takes it again before the scope ends).
  void Unlock() RELEASE() { lock_.unlock(); }
  void Lock() ACQUIRE() { lock_.lock(); }

  template <class Predicate>
  void Await(std::condition_variable& cv, Predicate ready) {
    cv.wait(lock_, ready);
  }
  // False when `timeout` passed with `ready` still false.
  template <class Rep, class Period, class Predicate>
  bool AwaitFor(std::condition_variable& cv, std::chrono::duration<Rep, Period> timeout,
                Predicate ready) {
    return cv.wait_for(lock_, timeout, ready);
  }
  template <class Clock, class Duration, class Predicate>
  bool AwaitUntil(std::condition_variable& cv, std::chrono::time_point<Clock, Duration> deadline,
                  Predicate ready) {
    return cv.wait_until(lock_, deadline, ready);
  }

 private:
  std::unique_lock<std::mutex> lock_;
};

}  // namespace bsf_vpr
