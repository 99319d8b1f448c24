#pragma once
/// @file
/// What the mapping node counts (MappingNode::counters(), also in its status message): every
/// input taken or refused by reason, what it published and saved. Its own header so that the
/// node's parts count without depending on the class that composes them.

#include <cstdint>

namespace mlmap::dds {

/// What the node counted so far (the engine's own counters are in EngineStats).
struct NodeCounters {
  std::uint64_t clouds_received = 0;   ///< PointCloud2 samples taken
  std::uint64_t images_received = 0;   ///< depth Image samples taken
  std::uint64_t poses_received = 0;    ///< PoseStamped / Odometry samples taken
  std::uint64_t inputs_malformed = 0;  ///< cloud / image / camera info / pose that failed to decode
  std::uint64_t images_without_info = 0;  ///< depth image before any valid CameraInfo
  std::uint64_t frames_without_pose = 0;  ///< no pose within the tolerance (or none came in time)
  std::uint64_t frames_future = 0;        ///< stamp more than max_future_s after the newest pose
  std::uint64_t frames_across_pose_jump = 0;  ///< between two poses of a jump: not interpolated
  std::uint64_t frames_handover_dropped = 0;  ///< hand-over queue full: oldest frame dropped
  std::uint64_t poses_rejected = 0;           ///< out of order, far future, or invalid (PoseBuffer)
  std::uint64_t frames_submitted = 0;         ///< frames given to the engine
  std::uint64_t frames_engine_rejected = 0;   ///< refused by the engine (see EngineStats)
  std::uint64_t messages_published = 0;       ///< all outputs together
  std::uint64_t map_saves = 0;                ///< map files written (map_file.save_path)
  std::uint64_t map_saves_failed = 0;         ///< saves that failed (the previous file is kept)
  bool last_map_save_failed = false;  ///< the latest save failed (after stop(): the final one)
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

}  // namespace mlmap::dds
