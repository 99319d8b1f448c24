#include "mlmap/pipeline/stage_threads.h"

#include <algorithm>
#include <utility>

namespace mlmap {

StageThreads::StageThreads(int input_capacity, int batch_capacity, AwarenessStep awareness,
                           LocalStep local)
    : input_capacity_(static_cast<std::size_t>(std::max(1, input_capacity))),
      batch_capacity_(static_cast<std::size_t>(std::max(1, batch_capacity))),
      awareness_step_(std::move(awareness)),
      local_step_(std::move(local)) {
  for (std::size_t i = 0; i < batch_capacity_ + 1; ++i) {
    pool_.push_back(std::make_unique<MeasurementBatch>());
  }
  awareness_thread_ = std::thread([this] { awarenessLoop(); });
  local_thread_ = std::thread([this] { localLoop(); });
}

StageThreads::~StageThreads() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  if (awareness_thread_.joinable()) awareness_thread_.join();
  if (local_thread_.joinable()) local_thread_.join();
}

StageThreads::Queued StageThreads::push(EngineInput input) {
  bool dropped = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return Queued::kStopped;
    if (inputs_.size() >= input_capacity_) {
      inputs_.pop_front();  // the oldest waiting frame gives way to the newest
      dropped = true;
    }
    inputs_.push_back(std::move(input));
  }
  changed_.notify_all();
  return dropped ? Queued::kDroppedOldest : Queued::kQueued;
}

void StageThreads::waitIdle() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return stopping_ || (inputs_.empty() && in_flight_ == 0); });
}

std::unique_lock<std::mutex> StageThreads::holdIdle() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return stopping_ || (inputs_.empty() && in_flight_ == 0); });
  return lock;
}

void StageThreads::awarenessLoop() {
  for (;;) {
    EngineInput input;
    std::unique_ptr<MeasurementBatch> batch;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return stopping_ || (!inputs_.empty() && !pool_.empty()); });
      if (stopping_) return;
      input = std::move(inputs_.front());
      inputs_.pop_front();
      batch = std::move(pool_.back());
      pool_.pop_back();
      ++in_flight_;
    }
    awareness_step_(input, batch.get());
    {
      std::unique_lock<std::mutex> lock(mutex_);
      // Back-pressure: wait for room rather than drop computed measurements.
      changed_.wait(lock, [&] { return stopping_ || batches_.size() < batch_capacity_; });
      // cppcheck-suppress knownConditionTrueFalse ; stop() sets it while wait() has the lock
      // released
      if (stopping_) return;
      batches_.push_back(std::move(batch));
    }
    changed_.notify_all();
  }
}

void StageThreads::localLoop() {
  for (;;) {
    std::unique_ptr<MeasurementBatch> batch;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return stopping_ || !batches_.empty(); });
      if (stopping_) return;
      batch = std::move(batches_.front());
      batches_.pop_front();
    }
    local_step_(*batch);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      pool_.push_back(std::move(batch));
      --in_flight_;
    }
    changed_.notify_all();
  }
}

}  // namespace mlmap
