#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "bsf_vpr/core/latest_job.h"

namespace bsf_vpr {
namespace {

// While a job runs, the jobs asked for wait; only the latest of them runs after it, on the
// job thread, and a job that throws does not end the thread.
TEST(LatestJob, RunsTheLatestWaitingJobAfterTheRunningOne) {
  std::mutex m;
  std::condition_variable cv;
  bool release = false, started = false;
  std::vector<int> ran;
  LatestJob job;
  job.Ask([&] {
    std::unique_lock<std::mutex> lock(m);
    started = true;
    cv.notify_all();
    cv.wait(lock, [&] { return release; });
    ran.push_back(1);
  });
  {
    std::unique_lock<std::mutex> lock(m);
    cv.wait(lock, [&] { return started; });
  }
  EXPECT_TRUE(job.busy());
  job.Ask([&] { ran.push_back(2); });
  job.Ask([&] { throw std::runtime_error("a failing job"); });
  job.Ask([&] { ran.push_back(4); });
  {
    std::lock_guard<std::mutex> lock(m);
    release = true;
  }
  cv.notify_all();
  job.Wait();
  EXPECT_FALSE(job.busy());
  EXPECT_EQ(ran, (std::vector<int>{1, 4}));
  job.Ask([&] { throw std::runtime_error("a failing job"); });
  job.Wait();
  job.Ask([&] { ran.push_back(5); });
  job.Wait();
  EXPECT_EQ(ran, (std::vector<int>{1, 4, 5}));
}

TEST(LatestJob, DestroyedWhileAJobWaitsDropsIt) {
  std::atomic<int> runs{0};
  std::mutex m;
  std::condition_variable cv;
  bool started = false;
  {
    LatestJob job;
    job.Ask([&] {
      {
        std::lock_guard<std::mutex> lock(m);
        started = true;
      }
      cv.notify_all();
      ++runs;
    });
    {
      std::unique_lock<std::mutex> lock(m);
      cv.wait(lock, [&] { return started; });
    }
    job.Wait();
    job.Ask([&] { ++runs; });  // may run or be dropped, but never after the destructor
  }
  EXPECT_GE(runs.load(), 1);
  EXPECT_LE(runs.load(), 2);
}

}  // namespace
}  // namespace bsf_vpr
