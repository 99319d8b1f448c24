#pragma once
/// @file
/// The simulated vehicle in a closed loop over DDS (mlmap_sensor_publisher --closed-loop): it
/// flies sim::Vehicle through the setpoints a planner publishes (geometry_msgs/PoseStamped, see
/// toSetpointPose()), in real time, in a nav_worlds world, and publishes what a robot publishes
/// for mlmap_node: its pose (geometry_msgs/PoseStamped, every control step) and the depth camera
/// rendered from that pose (an organised PointCloud2, at the camera rate), both stamped with the
/// wall clock at capture, and the world's goal (geometry_msgs/PoseStamped, once a second, as an
/// operator in RViz2 would). Scored against the ground truth as the one-process flight is
/// (nav_flight.h): reached, collisions, clearance.
///
/// Until the first setpoint arrives the vehicle holds its start. Frames: W is the world (the
/// node's world_frame), metres, seconds.

#include "mlmap/dds/transport/dds_config.h"
#include "mlmap/nav/nav_flight.h"
#include "mlmap/nav/nav_worlds.h"

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace mlmap::dds {

/// How to fly the closed loop.
struct ClosedLoopOptions {
  DdsConfig dds;                      ///< participant, namespace, frames: the node's dds section
  std::string cloud_topic = "cloud";  ///< out: the camera's clouds (the node's topics.cloud)
  std::string pose_topic = "pose";    ///< out: the vehicle's pose (the node's topics.pose)
  std::string setpoint_topic = "mlmap/setpoint";  ///< in: the planner's setpoints
  std::string goal_topic = "goal_pose";           ///< out: the world's goal ("": not published)
  Transform T_B_S = Transform::Identity();        ///< the camera's mounting (the node's sensor.*)
  /// Camera, vehicle model, control step, camera rate, timeout, vehicle radius, and the goal
  /// tolerance (planner.goal_tolerance_m); its map and the rest of its planner are not used.
  nav::NavFlightOptions flight;
  /// Seconds to wait for the node's readers of the cloud and pose, and the planner's setpoint
  /// writer, before flying [s].
  double wait_s = 20.0;
};

/// What the closed-loop flight did.
struct ClosedLoopResult {
  bool matched = false;          ///< the node and the planner were found before flying
  bool reached = false;          ///< at the goal (horizontally within the tolerance) in time
  int collisions = 0;            ///< times the ground-truth clearance fell below the radius
  double min_clearance_m = 0.0;  ///< smallest ground-truth clearance along the flight [m]
  double path_length_m = 0.0;    ///< length flown [m]
  double time_s = 0.0;           ///< flight time to the goal (or to the end) [s]
  std::uint64_t frames = 0;      ///< clouds published
  std::uint64_t setpoints = 0;   ///< setpoints received
  std::uint64_t rejected_setpoints = 0;  ///< malformed setpoints (not flown)
  int late_steps = 0;                    ///< control steps that started more than one step late
  std::vector<Eigen::Vector3d> trajectory_W;  ///< one position per control step
  /// Per frame: wall clock from its capture stamp to the return of the cloud's write (the
  /// simulated driver's share of any latency measured from the stamp: rendering, encoding) [ms].
  std::vector<double> capture_to_write_ms;
};

/// Flies `world` from its start until the goal is reached, the timeout passes or `stop` returns
/// true (checked every control step). Throws std::runtime_error when a DDS entity cannot be
/// created.
[[nodiscard]] ClosedLoopResult flyClosedLoop(const nav::NavWorld& world,
                                             const ClosedLoopOptions& options,
                                             const std::function<bool()>& stop);

}  // namespace mlmap::dds
