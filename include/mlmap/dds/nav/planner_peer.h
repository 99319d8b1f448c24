#pragma once
/// @file
/// The reference planner (mlmap_nav's Navigator) as a DDS peer of mlmap_node, the way a ROS 2
/// planner runs: it reads the node's 2D grid (nav_msgs/OccupancyGrid, `topics.grid`) and ESDF
/// (mlmap_msgs/VoxelBlock, `topics.esdf_block`), the vehicle's pose (geometry_msgs/PoseStamped,
/// `topics.pose`, the one the node maps with) and a goal (geometry_msgs/PoseStamped, RViz2's
/// `/goal_pose`), and publishes its route (nav_msgs/Path) and a setpoint for every pose
/// (geometry_msgs/PoseStamped, see toSetpointPose()).
///
/// Each ESDF block (with the latest grid) becomes a MapSnapshot (plan_messages.h) and is planned
/// on at once from the latest pose; every pose also updates the plan (periodic and blocked
/// replans, as in the one-process flight) and gets a setpoint. The Path carries the stamp of the
/// map state it was planned on (the last mapped frame's stamp), so wall clock - stamp at its
/// publication is the map-to-plan latency, which the peer records.
///
/// With `cloud_topic` (or `depth_image_topic`) set it also reads the sensor's clouds (depth
/// images) the node maps (sensor_msgs/PointCloud2, sensor_msgs/Image): each frame is placed with
/// the pose at its stamp (a PoseBuffer of the pose topic, as the node pairs them; the mounting
/// T_B_S from the configuration), and its measured points near the flight height become the
/// Navigator's recent obstacles (nav::recentObstacles()), planned on at once at the frame's stamp:
/// as in the one-process flight, a person crossing in front is seen before the map's occupancy has
/// them, and a stale obstacle's cell that a frame hits again stays an obstacle.
///
/// In the ROS 2 graph it is the node `node_name` (ros_discovery_info lists its readers and
/// writers; `ros2 node list` shows it) and its log lines go to /rosout (mlmap_dds_graph).
///
/// Threads: Fast DDS's listener threads only hand the samples over; one thread of the peer's
/// decodes, plans and publishes. Malformed messages are counted and logged (rate-limited), never
/// planned on. QoS as ROS 2 publishers and subscribers of these topics use by default (RELIABLE,
/// VOLATILE, KEEP_LAST 10; the grid TRANSIENT_LOCAL as the node latches it; the pose best-effort
/// as the node reads it). Frames: W is the node's world frame, metres, seconds.

#include "mlmap/core/pose_buffer.h"
#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/nav/navigator.h"
#include "mlmap/pipeline/rate_limited_log.h"

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace mlmap::dds {

/// What the peer reads and writes, and how it plans.
struct PlannerPeerConfig {
  DdsConfig dds;  ///< participant, namespace, frames: the node's dds section
  std::string grid_topic = "mlmap/grid";          ///< in: the node's rolling grid (topics.grid)
  std::string esdf_topic = "mlmap/esdf/block";    ///< in: the node's ESDF (topics.esdf_block)
  std::string pose_topic = "pose";                ///< in: the vehicle's pose (topics.pose)
  std::string goal_topic = "goal_pose";           ///< in: the goal (RViz2's default)
  std::string path_topic = "mlmap/plan";          ///< out: nav_msgs/Path, the route
  std::string setpoint_topic = "mlmap/setpoint";  ///< out: PoseStamped setpoints
  nav::NavigatorConfig planner;                   ///< the reference planner
  /// How the node's ESDF counts unknown voxels (its esdf.unknown_as): the field is computed again
  /// the same way (the navigation setting: free).
  UnknownAs esdf_unknown_as = UnknownAs::kFree;
  /// Gain of the vehicle's position controller [1/s]: setpoints carry the velocity as a lead of
  /// velocity / gain (toSetpointPose()).
  double position_gain_per_s = 1.5;
  std::optional<Eigen::Vector3d> goal_W;  ///< a goal from the start (else wait for goal_topic)
  /// in: the sensor's clouds the node maps (its topics.cloud; sensor_msgs/PointCloud2 in the
  /// sensor frame, BEST_EFFORT as the node reads them); "": off, the Navigator gets no frame's
  /// points (it then sees a moving obstacle only once the map has it).
  std::string cloud_topic;
  /// in: the sensor's depth images the node maps (its topics.depth_image; sensor_msgs/Image
  /// 16UC1 or 32FC1, back-projected with the latest CameraInfo of camera_info_topic), as
  /// cloud_topic; "": off. Both or neither.
  std::string depth_image_topic;
  std::string camera_info_topic;            ///< in: sensor_msgs/CameraInfo of the depth images
  Transform T_B_S = Transform::Identity();  ///< the sensor's mounting (the node's sensor.*)
  /// Pairing a cloud's stamp with the poses of pose_topic (the node's: poseBufferConfig()).
  PoseBufferConfig pose_buffer;
  /// One recent obstacle per cell of this size (the node's local_map.resolution_m) [m].
  double recent_cell_m = 0.1;
  std::string node_name = "mlmap_planner";  ///< its ROS 2 node name (ros_discovery_info, /rosout)
  /// Receives its log lines (they also go to /rosout); called from its threads. Default: none.
  LogSink log;
};

/// What the peer did.
struct PlannerPeerStats {
  std::uint64_t maps = 0;          ///< ESDF blocks planned on
  std::uint64_t grids = 0;         ///< grids received
  std::uint64_t poses = 0;         ///< poses received
  std::uint64_t goals = 0;         ///< goals taken
  std::uint64_t paths = 0;         ///< Paths published
  std::uint64_t setpoints = 0;     ///< setpoints published
  std::uint64_t rejected = 0;      ///< malformed messages (not planned on)
  std::uint64_t clouds = 0;        ///< clouds received (cloud_topic)
  std::uint64_t depth_images = 0;  ///< depth images received (depth_image_topic)
  /// Sensor frames (clouds, depth images) whose points went to the Navigator as its recent
  /// obstacles.
  std::uint64_t recent_obstacle_frames = 0;
  std::uint64_t recent_obstacles = 0;  ///< points those frames gave it, in all
  /// Sensor frames not used: no pose within the tolerance of their stamp, still none 0.5 s after
  /// they arrived, or a newer frame arrived while they waited for it. (A frame that does not
  /// decode, or a depth image before any CameraInfo, is rejected.)
  std::uint64_t frames_without_pose = 0;
  std::string last_rejection;  ///< why the last one was rejected
  bool reached = false;        ///< the last pose was at the goal
  /// Per planned ESDF block: wall clock at the Path's publication - the map state's stamp [ms].
  std::vector<double> map_to_plan_ms;
  /// Per planned ESDF block: wall clock at its arrival - the map state's stamp [ms].
  std::vector<double> map_arrival_ms;
};

/// The planner peer; runs from construction to destruction.
class PlannerPeer {
 public:
  /// Joins the DDS graph (participant "mlmap_planner_peer"), creates the readers and writers,
  /// announces them as the ROS 2 node `node_name` and starts planning. Throws std::runtime_error
  /// when an entity cannot be created, std::invalid_argument for a bad configuration.
  explicit PlannerPeer(const PlannerPeerConfig& config);
  /// Stops the thread and leaves the graph.
  ~PlannerPeer();
  PlannerPeer(const PlannerPeer&) = delete;
  PlannerPeer& operator=(const PlannerPeer&) = delete;

  /// A copy of the statistics so far (thread-safe).
  [[nodiscard]] PlannerPeerStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlmap::dds
