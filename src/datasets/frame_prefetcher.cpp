#include "mlmap/datasets/frame_prefetcher.h"

#include "mlmap/core/stopwatch.h"

#include <utility>

namespace mlmap::datasets {

FramePrefetcher::FramePrefetcher(const FrameSource& source, std::size_t count,
                                 std::size_t capacity_frames)
    : source_(source), count_(count), capacity_frames_(capacity_frames) {
  if (capacity_frames_ > 0) reader_ = std::thread([this] { readLoop(); });
}

FramePrefetcher::~FramePrefetcher() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  if (reader_.joinable()) reader_.join();
}

PrefetchedFrame FramePrefetcher::readFrame(std::size_t index) const {
  PrefetchedFrame f;
  const SteadyClock::time_point start = SteadyClock::now();
  f.frame = source_.read(index, &f.info);
  f.read_ms = msSince(start);
  return f;
}

void FramePrefetcher::readLoop() {
  for (std::size_t i = 0; i < count_; ++i) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [this] { return stopping_ || ready_.size() < capacity_frames_; });
      if (stopping_) return;
    }
    try {
      PrefetchedFrame f = readFrame(i);
      std::lock_guard<std::mutex> lock(mutex_);
      ready_.push_back(std::move(f));
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex_);
      error_ = std::current_exception();
      break;
    }
    changed_.notify_all();
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    reader_done_ = true;
  }
  changed_.notify_all();
}

bool FramePrefetcher::next(PrefetchedFrame* out) {
  if (next_index_ >= count_) return false;
  if (capacity_frames_ == 0) {
    *out = readFrame(next_index_);
    ++next_index_;
    return true;
  }
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return !ready_.empty() || reader_done_; });
  if (ready_.empty()) {
    if (error_) std::rethrow_exception(error_);
    return false;
  }
  *out = std::move(ready_.front());
  ready_.pop_front();
  ++next_index_;
  lock.unlock();
  changed_.notify_all();
  return true;
}

}  // namespace mlmap::datasets
