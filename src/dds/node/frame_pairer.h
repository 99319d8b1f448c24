#pragma once
/// @file
/// The input thread's work: decode and check each input, pair clouds and depth images with
/// poses by stamp (PoseBuffer), submit paired frames to the engine.

#include "counter_sink.h"
#include "input_queue.h"
#include "node_log.h"
#include "tf_listener.h"

#include "mlmap/core/pose_buffer.h"
#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/pipeline/map_engine.h"

#include <chrono>
#include <cstddef>
#include <deque>
#include <variant>

namespace mlmap::dds::node {

/// Pairs frames with poses. A frame whose pose has not come yet waits (at most kMaxPending
/// frames, at most kPoseWait_s of wall time); frames far ahead of the newest pose, across a pose
/// jump or without a pose within the tolerance are dropped, counted and logged. Not thread-safe:
/// the input thread owns it.
class FramePairer {
 public:
  static constexpr std::size_t kMaxPending = 8;  ///< decoded frames waiting for their pose
  static constexpr double kPoseWait_s = 0.5;     ///< wall time a frame may wait for its pose

  /// `T_B_S`: the sensor's configured mounting. With sensor_extrinsic tf_static each frame's
  /// mounting is instead looked up in `tf` (body -> the message's frame_id; a frame it cannot
  /// resolve is dropped and counted); with config a frame in another frame than the sensor frame
  /// is counted. `engine` receives the paired frames. `tf` may be null with sensor_extrinsic
  /// config.
  FramePairer(const DdsConfig& dds, const Transform& T_B_S, const TfListener* tf, MapEngine& engine,
              CounterSink& counters, NodeLog& log);

  /// Takes one input: a frame is paired or waits, a pose may release waiting frames, a camera
  /// info is kept for the depth images after it.
  void handle(Input& input);
  /// Drops (and counts) the frames that waited longer than kPoseWait_s.
  void expireWaiting();
  /// Shutting down: what still waits for a pose will not get one (counted).
  void dropWaiting();

 private:
  using Frame = std::variant<PointCloudFrame, DepthFrame>;
  struct Waiting {
    Frame frame;
    std::chrono::steady_clock::time_point since;
  };

  void handle(CloudSample& msg);
  void handle(sensor_msgs::Image_& msg);
  void handle(sensor_msgs::CameraInfo_& msg);
  template <typename PoseMsg>
  void handle(PoseMsg& msg);
  void malformed(const char* what, const DecodeStatus& status);
  /// The mounting of a frame in `frame_id` stamped `stamp_s` (see the constructor); false when
  /// it has none (counted and logged).
  bool extrinsicFor(const std::string& frame_id, double stamp_s, Transform* T_B_S);
  /// Counts and logs an Odometry whose child frame is not the body frame.
  void checkChildFrame(const nav_msgs::Odometry_& msg);
  void checkChildFrame(const geometry_msgs::PoseStamped_&) {}
  void addPose(double stamp_s, const Transform& T_W_B);
  void place(Frame&& frame);
  /// Submits the frame when its pose is known; kPending leaves it to the caller.
  PoseBuffer::LookupResult tryPlace(Frame& frame);
  /// Submits the waiting frames, oldest first, up to the first whose pose is still pending.
  void releaseWaiting();
  void noPose(double stamp_s);

  const DdsConfig& dds_;
  FrameNames frames_;
  ExtrinsicSource extrinsic_;
  Transform T_B_S_;
  const TfListener* tf_;
  MapEngine& engine_;
  CounterSink& counters_;
  NodeLog& log_;
  PoseBuffer poses_;
  std::deque<Waiting> waiting_;
  sensor_msgs::CameraInfo_ camera_info_;
  bool have_camera_info_ = false;
};

}  // namespace mlmap::dds::node
