#include "task_threads.h"

#include <algorithm>

namespace mlmap {

TaskThreads::TaskThreads(int threads) {
  for (int i = 1; i < threads; ++i) threads_.emplace_back([this, i] { loop(i); });
}

TaskThreads::~TaskThreads() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  go_.notify_all();
  for (std::thread& t : threads_) t.join();
}

void TaskThreads::run(int n, const std::function<void(int)>& job) {
  const int kept = std::min(n, size()) - 1;
  if (kept > 0) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = &job;
      jobs_ = n;
      pending_ = static_cast<int>(threads_.size());
      error_ = nullptr;
      ++generation_;
    }
    go_.notify_all();
  }
  std::exception_ptr own;
  if (n > 0) {
    try {
      job(0);
    } catch (...) {
      own = std::current_exception();
    }
  }
  if (kept <= 0) {
    if (own) std::rethrow_exception(own);
    return;
  }
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [this] { return pending_ == 0; });
  job_ = nullptr;
  if (own) std::rethrow_exception(own);
  if (error_) std::rethrow_exception(error_);
}

void TaskThreads::loop(int index) {
  std::uint64_t seen = 0;
  for (;;) {
    const std::function<void(int)>* job = nullptr;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      go_.wait(lock, [&] { return stopping_ || generation_ != seen; });
      if (stopping_) return;
      seen = generation_;
      if (index < jobs_) job = job_;
    }
    std::exception_ptr error;
    if (job != nullptr) {
      try {
        (*job)(index);
      } catch (...) {
        error = std::current_exception();
      }
    }
    bool last = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (error && !error_) error_ = error;
      last = --pending_ == 0;
    }
    if (last) done_.notify_one();
  }
}

}  // namespace mlmap
