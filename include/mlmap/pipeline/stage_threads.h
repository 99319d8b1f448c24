#pragma once
/// @file
/// Part of the mapping engine (MapEngine, map_engine.h): the threaded mode's two threads and the
/// hand-over between them. Frames wait in a bounded input queue (the oldest gives way when it is
/// full); the awareness thread turns each into a MeasurementBatch taken from a pool; the
/// local-global thread maps the batches in order and returns them to the pool. Between the two,
/// a bounded queue with back-pressure: the awareness thread waits for room rather than drop
/// measurements it computed.

#include "mlmap/core/types.h"
#include "mlmap/core/measurement_batch.h"

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <variant>
#include <vector>

namespace mlmap {

/// A frame as submitted to the engine: a point cloud or a depth image.
using EngineInput = std::variant<PointCloudFrame, DepthFrame>;

/// The two stage threads and their queues. Starts the threads on construction and stops them
/// (frames still queued are not mapped) on destruction. push(), waitIdle() and holdIdle() may
/// be called from any thread.
class StageThreads {
 public:
  /// The awareness stage of one frame: fills the batch (awareness thread).
  using AwarenessStep = std::function<void(EngineInput& input, MeasurementBatch* batch)>;
  /// The local-global stage of one batch (local-global thread); it may finish the batch first.
  using LocalStep = std::function<void(MeasurementBatch& batch)>;
  /// What push() did.
  enum class Queued {
    kQueued,         ///< the frame waits for the awareness thread
    kDroppedOldest,  ///< the same, the oldest waiting frame dropped to make room
    kStopped,        ///< not queued: the threads are stopping
  };

  /// Starts both threads: at most `input_capacity` frames wait for the awareness stage and
  /// `batch_capacity` batches for the local-global stage (each at least 1).
  StageThreads(int input_capacity, int batch_capacity, AwarenessStep awareness, LocalStep local);
  /// Stops and joins both threads.
  ~StageThreads();
  StageThreads(const StageThreads&) = delete;
  StageThreads& operator=(const StageThreads&) = delete;

  /// Queues a frame for the awareness stage.
  Queued push(EngineInput input);
  /// Waits until no frame is queued or in flight (or the threads are stopping).
  void waitIdle();
  /// waitIdle(), then keeps both stages from starting a frame until the lock returned is
  /// released (what the engine's clear() empties the layers under).
  [[nodiscard]] std::unique_lock<std::mutex> holdIdle();

 private:
  /// The awareness thread: takes a frame and a batch, runs the stage, hands the batch over.
  void awarenessLoop();
  /// The local-global thread: maps the batches in order and returns them to the pool.
  void localLoop();

  const std::size_t input_capacity_;
  const std::size_t batch_capacity_;
  AwarenessStep awareness_step_;
  LocalStep local_step_;
  std::mutex mutex_;  ///< guards everything below but the threads
  std::condition_variable changed_;
  std::deque<EngineInput> inputs_;
  std::deque<std::unique_ptr<MeasurementBatch>> batches_;
  std::vector<std::unique_ptr<MeasurementBatch>> pool_;
  std::size_t in_flight_ = 0;  ///< frames taken from the input queue, not yet mapped
  bool stopping_ = false;
  std::thread awareness_thread_;  ///< (last: started once everything above is set)
  std::thread local_thread_;
};

}  // namespace mlmap
