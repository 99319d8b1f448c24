#pragma once
/// @file
/// Kept threads for the awareness stage's parallel parts (private to the stage): a frame hands
/// its parts over to threads that already run, instead of starting and joining a thread per part
/// (tens of microseconds each, per frame).

#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace mlmap {

/// `threads` - 1 kept threads and the caller. run(n, job) calls job(0) on the caller and
/// job(1) .. job(n - 1) on the kept threads, and returns when every call has returned. Used by
/// one thread at a time (the stage's owner).
class TaskThreads {
 public:
  /// Starts `threads` - 1 threads (none for 1 or less).
  explicit TaskThreads(int threads);
  /// Stops and joins the threads.
  ~TaskThreads();
  TaskThreads(const TaskThreads&) = delete;
  TaskThreads& operator=(const TaskThreads&) = delete;

  /// The caller and the kept threads.
  [[nodiscard]] int size() const { return static_cast<int>(threads_.size()) + 1; }

  /// Calls job(0) .. job(n - 1), n <= size(), job(0) on the calling thread; returns once all
  /// have returned. An exception of a job is rethrown here (the first one, after all returned).
  void run(int n, const std::function<void(int)>& job);

 private:
  void loop(int index);

  std::mutex mutex_;
  std::condition_variable go_;
  std::condition_variable done_;
  const std::function<void(int)>* job_ = nullptr;  // the current jobs, while run() waits
  int jobs_ = 0;
  int pending_ = 0;               // kept threads still in the current jobs
  std::uint64_t generation_ = 0;  // counts run() calls: a kept thread's signal to start
  bool stopping_ = false;
  std::exception_ptr error_;  // the first exception of a kept thread's job
  std::vector<std::thread> threads_;
};

}  // namespace mlmap
