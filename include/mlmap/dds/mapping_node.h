#pragma once
/// @file
/// The onboard mapping node: one DomainParticipant, ROS 2 topics in, map layers out.
///
/// Threads (paper Figure 5):
/// - Fast DDS's listener threads only take samples and hand them over (a bounded queue);
/// - the input thread decodes and validates messages, pairs clouds and depth images with poses
///   (PoseBuffer) and submits frames to the engine;
/// - the engine's awareness and local-global threads map;
/// - the publishing thread turns snapshots and layer copies into messages at the configured
///   rates, so a slow or vanished subscriber never blocks mapping.
///
/// Every rejected input is counted (NodeCounters, also in the status message) and logged at most
/// once per second per reason.

#include "mlmap/dds/node_config.h"
#include "mlmap/dds/participant.h"
#include "mlmap/dds/ros_services.h"
#include "mlmap/pipeline/map_engine.h"
#include "mlmap/core/pose_buffer.h"

#include <atomic>
#include <cstdint>
#include <memory>

namespace mlmap::dds {

/// What the node counted so far (the engine's own counters are in EngineStats).
struct NodeCounters {
  std::uint64_t clouds_received = 0;      ///< PointCloud2 samples taken
  std::uint64_t images_received = 0;      ///< depth Image samples taken
  std::uint64_t poses_received = 0;       ///< PoseStamped / Odometry samples taken
  std::uint64_t inputs_malformed = 0;     ///< cloud / image / camera info / pose that failed to decode
  std::uint64_t images_without_info = 0;  ///< depth image before any valid CameraInfo
  std::uint64_t frames_without_pose = 0;  ///< no pose within the tolerance (or none came in time)
  std::uint64_t frames_future = 0;        ///< stamp more than max_future_s after the newest pose
  std::uint64_t frames_across_pose_jump = 0;  ///< between two poses of a jump: not interpolated
  std::uint64_t frames_handover_dropped = 0;  ///< hand-over queue full: oldest frame dropped
  std::uint64_t poses_rejected = 0;       ///< out of order, far future, or invalid (PoseBuffer)
  std::uint64_t frames_submitted = 0;     ///< frames given to the engine
  std::uint64_t frames_engine_rejected = 0;  ///< refused by the engine (see EngineStats)
  std::uint64_t messages_published = 0;   ///< all outputs together
  std::uint64_t map_saves = 0;            ///< map files written (map_file.save_path)
  std::uint64_t map_saves_failed = 0;     ///< saves that failed (the previous file is kept)
  bool last_map_save_failed = false;      ///< the latest save failed (after stop(): the final one)
  /// Publishers the input readers match now, all input topics together (a level, not a count
  /// of events). Each change is logged: a sensor or odometry source that never matches shows.
  std::uint64_t publishers_matched = 0;
  /// Subscribers of the node's outputs that request a QoS their writer does not offer (each
  /// logged with the policy): they receive nothing.
  std::uint64_t subscribers_incompatible = 0;
  /// Transforms taken from rt/tf and rt/tf_static (when the node listens: tf_mode map_odom,
  /// sensor_extrinsic tf_static); malformed ones count in inputs_malformed instead.
  std::uint64_t tf_transforms_received = 0;
  /// tf_mode map_odom: poses whose odom -> body transform the robot's /tf did not give (in time),
  /// so no world -> odom was published for them.
  std::uint64_t tf_odom_missing = 0;
  /// sensor_extrinsic config: clouds / images whose frame_id is not the sensor frame (mapped with
  /// the configured extrinsic all the same).
  std::uint64_t frames_unexpected_frame_id = 0;
  /// sensor_extrinsic tf_static: clouds / images whose frame_id no chain of transforms joins to
  /// the body frame (dropped).
  std::uint64_t frames_unresolved_frame_id = 0;
  /// Odometry messages whose child_frame_id is not the body frame (used all the same).
  std::uint64_t odometry_child_frame_mismatch = 0;
  /// dds.fleet.publish: mlmap_msgs/Submap samples written (changed submaps) and their
  /// serialized bytes (serializedSubmapBytes(), RTPS headers not included).
  std::uint64_t fleet_submaps_sent = 0;
  std::uint64_t fleet_bytes_sent = 0;
  /// dds.fleet.subscribe: other vehicles' submaps taken as prior knowledge, and samples refused
  /// (malformed, another grid; each kind logged once a second at most).
  std::uint64_t fleet_priors_received = 0;
  std::uint64_t fleet_samples_refused = 0;
};

/// The node's pairing of clouds and depth images with poses, from the `dds` section:
/// pose_tolerance_s, pose_buffer_s, max_future_s and the pose-jump limits.
PoseBufferConfig poseBufferConfig(const DdsConfig& dds);

/// Runs the mapping node until destroyed (or stop()).
class MappingNode {
 public:
  /// Creates the participant, the engine, the readers and writers, publishes rt/tf_static (with
  /// dds.publish_sensor_tf) and starts the threads. Throws std::invalid_argument (bad config) or std::runtime_error (DDS).
  explicit MappingNode(const NodeConfig& config, const LogSink& log = {});
  ~MappingNode();
  MappingNode(const MappingNode&) = delete;
  MappingNode& operator=(const MappingNode&) = delete;

  /// Stops taking input, drains the engine, publishes the last state and joins every thread.
  /// Idempotent.
  void stop();

  [[nodiscard]] NodeCounters counters() const;
  [[nodiscard]] EngineStats engineStats() const;
  /// The engine's latest snapshot (what the layers are published from); any thread, any time.
  [[nodiscard]] std::shared_ptr<const MapSnapshot> snapshot() const;
  /// The domain the participant joined.
  [[nodiscard]] int domainId() const;
  /// What the node's ROS 2 services (~/save_map, ~/clear_map, the parameter services) counted.
  [[nodiscard]] ServiceCounters serviceCounters() const;
  /// Logs a line as the node logs its own: to the LogSink and, until stop() deletes the
  /// participant, to /rosout (a program's progress lines, so that ROS 2 tools see them too).
  void log(LogLevel level, const std::string& message) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlmap::dds
