#include "task_threads.h"

#include <algorithm>
#include <utility>

namespace mlmap {

TaskThreads::TaskThreads(int threads) {
  for (int i = 1; i < threads; ++i) threads_.emplace_back([this] { loop(); });
}

TaskThreads::~TaskThreads() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  go_.notify_all();
  for (std::thread& t : threads_) t.join();
}

int TaskThreads::claim() { return next_ < jobs_ ? next_++ : -1; }

void TaskThreads::runClaimed(const std::function<void(int)>& job, int index) {
  std::exception_ptr error;
  try {
    job(index);
  } catch (...) {
    error = std::current_exception();
  }
  bool all = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (error && !error_) error_ = error;
    all = ++finished_ == jobs_;
  }
  if (all) done_.notify_one();
}

void TaskThreads::run(int n, const std::function<void(int)>& job) {
  if (n <= 0) return;
  bool alone = threads_.empty() || n == 1;  // nothing to hand over: no signal
  if (!alone) {
    std::lock_guard<std::mutex> lock(mutex_);
    alone = jobs_ != 0;  // another caller's run() holds the kept threads: do it all here
    if (!alone) {
      job_ = &job;
      jobs_ = n;
      next_ = 1;  // job 0 is the caller's
      finished_ = 0;
      error_ = nullptr;
      ++generation_;
    }
  }
  if (alone) {
    for (int i = 0; i < n; ++i) job(i);
    return;
  }
  if (n == 2) {
    go_.notify_one();
  } else {
    go_.notify_all();
  }
  runClaimed(job, 0);
  for (;;) {  // then whatever no kept thread has claimed yet
    int index = -1;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      index = claim();
    }
    if (index < 0) break;
    runClaimed(job, index);
  }
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [this] { return finished_ == jobs_; });
  job_ = nullptr;
  jobs_ = 0;
  next_ = 0;
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void TaskThreads::loop() {
  std::uint64_t seen = 0;
  for (;;) {
    const std::function<void(int)>* job = nullptr;
    int index = -1;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      go_.wait(lock, [&] { return stopping_ || (generation_ != seen && next_ < jobs_); });
      if (stopping_) return;
      seen = generation_;
      job = job_;
      index = claim();
    }
    while (index >= 0) {
      runClaimed(*job, index);
      std::lock_guard<std::mutex> lock(mutex_);
      index = seen == generation_ ? claim() : -1;
    }
  }
}

}  // namespace mlmap
