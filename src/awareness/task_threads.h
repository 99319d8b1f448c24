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

/// `threads` - 1 kept threads and the caller. run(n, job) calls job(0) .. job(n - 1), each once,
/// on whichever of the caller and the kept threads claims it first, and returns when every call
/// has returned. run() may be called by two threads at once (the threaded engine's two halves of
/// the awareness stage): the kept threads serve the first caller, the other runs its jobs itself.
///
/// The caller claims jobs too, and takes every job not yet claimed when it is done with its own:
/// a kept thread that is slow to wake (it waits for a core, e.g. while the engine's local thread
/// runs) delays nothing, the caller does its part instead.
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

  /// Calls job(0) .. job(n - 1) (any n >= 0), each exactly once, job(0) first on the calling
  /// thread and the others on whichever thread claims them first (in increasing order); returns
  /// once all have returned. While another caller's run() is under way, all on the calling
  /// thread, in order. An exception of a job is rethrown here (the first one caught, after all
  /// returned).
  void run(int n, const std::function<void(int)>& job);

 private:
  void loop();
  /// The next unclaimed job of the current run() (under mutex_), or -1 when none is left.
  int claim();
  /// Runs job `index` and records its end (and its exception) under mutex_.
  void runClaimed(const std::function<void(int)>& job, int index);

  std::mutex mutex_;
  std::condition_variable go_;
  std::condition_variable done_;
  const std::function<void(int)>* job_ = nullptr;  // the current jobs, while run() waits
  int jobs_ = 0;                                   // jobs of the current run() (0: none)
  int next_ = 0;                                   // the next job to claim
  int finished_ = 0;                               // jobs of the current run() that returned
  std::uint64_t generation_ = 0;                   // counts run() calls: a kept thread's signal
  bool stopping_ = false;
  std::exception_ptr error_;  // the first exception of a job
  std::vector<std::thread> threads_;
};

}  // namespace mlmap
