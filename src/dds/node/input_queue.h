#pragma once
/// @file
/// The hand-over between Fast DDS's listener threads and the node's input thread.

#include "mlmap/dds/wire/cloud_sample.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>
#include <variant>

namespace mlmap::dds::node {

/// A message as a listener takes it.
using Input = std::variant<CloudSample, sensor_msgs::Image_, sensor_msgs::CameraInfo_,
                           geometry_msgs::PoseStamped_, nav_msgs::Odometry_>;

/// True for the inputs that carry a frame (clouds, depth images).
bool isFrame(const Input& input);

/// A bounded queue of inputs. Frames are bounded apart (kMaxFrames: the oldest waiting frame is
/// dropped for a new one, the freshest data matters most) from poses and camera infos
/// (kMaxOther: further ones are refused; by then the input thread is stalled and poses are
/// worthless). Thread-safe.
class InputQueue {
 public:
  static constexpr std::size_t kMaxFrames = 3;
  static constexpr std::size_t kMaxOther = 1000;

  enum class PushResult {
    kQueued,
    kQueuedOldestFrameDropped,  ///< queued; the oldest waiting frame was dropped for it
    kRefused,                   ///< closed, or too many non-frame inputs waiting
  };
  /// Queues `input` (from a listener thread).
  PushResult push(Input&& input);
  /// The oldest input, waiting up to `timeout` for one; nullopt when none came.
  std::optional<Input> pop(std::chrono::milliseconds timeout);
  /// Refuses further inputs; what waits can still be popped.
  void close();
  /// Closed and drained: nothing more will come.
  [[nodiscard]] bool finished() const;

 private:
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Input> inputs_;
  std::size_t frames_ = 0;  ///< frames among inputs_
  bool closed_ = false;
};

}  // namespace mlmap::dds::node
