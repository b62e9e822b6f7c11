#include "bsf_vpr/core/joint_builder.h"

#include <chrono>
#include <exception>

namespace bsf_vpr {

JointBuilder::JointBuilder(std::function<void(Result)> done)
    : done_(std::move(done)), thread_([this] { Run(); }) {}

JointBuilder::~JointBuilder() {
  {
    MutexLock lock(&mutex_);
    stop_ = true;
    waiting_.reset();
  }
  changed_.notify_all();
  thread_.join();
}

void JointBuilder::Request(JointKind kind, std::vector<StoredReferenceSet> sets, int num_places,
                           JointOptions options, uint64_t generation) {
  {
    MutexLock lock(&mutex_);
    waiting_ = Request_{kind, std::move(sets), num_places, std::move(options), generation};
  }
  changed_.notify_all();
}

bool JointBuilder::busy() const {
  MutexLock lock(&mutex_);
  return running_ || waiting_.has_value();
}

void JointBuilder::Wait() const {
  MutexLock lock(&mutex_);
  lock.Await(changed_, [this] {
    mutex_.AssertHeld();
    return !running_ && !waiting_;
  });
}

void JointBuilder::Run() {
  for (;;) {
    Request_ request;
    {
      MutexLock lock(&mutex_);
      lock.Await(changed_, [this] {
        mutex_.AssertHeld();
        return stop_ || waiting_.has_value();
      });
      if (stop_) return;
      request = std::move(*waiting_);
      waiting_.reset();
      running_ = true;
    }
    Result result;
    result.generation = request.generation;
    result.kind = request.kind;
    const auto start = std::chrono::steady_clock::now();
    try {
      std::vector<const StoredReferenceSet*> sets;
      for (const StoredReferenceSet& s : request.sets) sets.push_back(&s);
      result.joint = std::make_shared<const JointRepresentation>(
          JointRepresentation::Build(request.kind, sets, request.num_places, request.options));
    } catch (const std::exception& e) {
      result.error = e.what();
    }
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    request.sets.clear();  // the snapshot's rows go before the result is handed on
    try {
      done_(std::move(result));
    } catch (...) {  // a callback's failure must not end the builder
    }
    {
      MutexLock lock(&mutex_);
      running_ = false;
    }
    changed_.notify_all();
  }
}

}  // namespace bsf_vpr
