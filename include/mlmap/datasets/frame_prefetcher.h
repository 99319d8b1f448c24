#pragma once
/// @file
/// Reading ahead of the mapping: a FrameSource's frames read and decoded (PNG, PCD / PLY) on a
/// thread of their own, at most a few frames ahead, and handed over in order. On two cores a
/// replay then takes about the longer of reading and mapping instead of their sum, with the same
/// frames in the same order as reading them in turn.

#include "mlmap/datasets/frame_source.h"

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>

namespace mlmap::datasets {

/// A frame as read, with what the source said of it and how long reading it took.
struct PrefetchedFrame {
  SourceFrame frame;
  SourceFrameInfo info;
  double read_ms = 0.0;  ///< FrameSource::read() of this frame, on whichever thread ran it
};

/// Frames 0 .. count - 1 of a source, in order, read ahead on a reader thread (see the file
/// comment). The source must outlive the prefetcher and is read from the reader thread only.
class FramePrefetcher {
 public:
  /// Starts reading `count` frames of `source`: with `capacity_frames` > 0 on a reader thread
  /// that keeps at most that many frames waiting; with 0 there is no thread and next() reads
  /// each frame itself (the sequential replay).
  FramePrefetcher(const FrameSource& source, std::size_t count, std::size_t capacity_frames);
  /// Stops the reader thread (after the frame it is reading) and waits for it.
  ~FramePrefetcher();
  FramePrefetcher(const FramePrefetcher&) = delete;
  FramePrefetcher& operator=(const FramePrefetcher&) = delete;

  /// Moves the next frame into `out` and returns true; returns false after the last one. When
  /// the next frame could not be read, throws what FrameSource::read() threw for it (the
  /// message names the file), after every frame before it was handed over.
  bool next(PrefetchedFrame* out);

 private:
  [[nodiscard]] PrefetchedFrame readFrame(std::size_t index) const;
  void readLoop();

  const FrameSource& source_;
  std::size_t count_;
  std::size_t capacity_frames_;
  std::size_t next_index_ = 0;  ///< the next frame next() hands over

  std::mutex mutex_;  // guards what follows
  std::condition_variable changed_;
  std::deque<PrefetchedFrame> ready_;
  std::exception_ptr error_;  ///< what reading the frame after those in ready_ threw
  bool reader_done_ = false;  ///< the reader thread read its last frame (or failed)
  bool stopping_ = false;
  std::thread reader_;
};

}  // namespace mlmap::datasets
