#pragma once
/// @file
/// The closed loop in one process: the simulated depth camera on the simulated vehicle -> the
/// mapping engine (MapEngine, synchronous) -> the reference planner (Navigator) -> the vehicle's
/// setpoints, in simulated time, scored against the ground truth. World frame W, metres, seconds.

#include "mlmap/core/config.h"
#include "mlmap/nav/nav_worlds.h"
#include "mlmap/nav/navigator.h"
#include "mlmap/nav/recent_obstacles.h"
#include "mlmap/sim/depth_camera.h"
#include "mlmap/sim/vehicle.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace mlmap::nav {

/// How to fly.
struct NavFlightOptions {
  MapConfig map;                  ///< the engine (navMapConfig() by default)
  NavigatorConfig planner;        ///< the reference planner
  sim::VehicleLimits vehicle;     ///< the vehicle model
  sim::DepthCameraModel camera;   ///< the camera (a 160 x 120 D435-like one by default)
  double camera_rate_hz = 10.0;   ///< frames per simulated second
  double control_dt_s = 0.02;     ///< vehicle and setpoint step [s]
  double timeout_s = 150.0;       ///< a flight not at its goal by then failed [s]
  double vehicle_radius_m = 0.3;  ///< a ground-truth clearance below this is a collision [m]
  /// Filled in by the constructor: navMapConfig(0.2), the small camera.
  NavFlightOptions();
};

/// The engine configuration the flights use at `resolution_m`: a 19 x 19 x 7 m window, the
/// ESDF's unknown voxels free (the local planner checks unknown space with the local map) and
/// updated with every frame, a height band of +-0.5 m around the body, synchronous.
[[nodiscard]] MapConfig navMapConfig(double resolution_m);

/// What a flight did.
struct NavFlightResult {
  std::string name;              ///< the world's
  bool reached = false;          ///< at the goal before the timeout
  int collisions = 0;            ///< times the ground-truth clearance fell below the vehicle radius
  double min_clearance_m = 0.0;  ///< smallest ground-truth clearance along the flight [m]
  double path_length_m = 0.0;    ///< length flown [m]
  double shortest_path_m = 0.0;  ///< ground-truth shortest route (same inflation) [m]; 0: none
  double time_s = 0.0;           ///< simulated time to the goal (or to the timeout) [s]
  std::uint64_t frames = 0;      ///< frames mapped
  std::uint64_t plans = 0;       ///< plans made
  std::uint64_t blocked_replans = 0;  ///< plans made at once because a frame blocked the segment
  std::uint64_t route_failures = 0;   ///< global searches without a route
  /// Wall time from a frame's submission to the end of the plan made from its snapshot [ms].
  std::vector<double> map_to_plan_ms;
  /// Thread CPU time of each part over the flight [s].
  double cpu_render_s = 0.0;
  double cpu_mapping_s = 0.0;
  double cpu_global_s = 0.0;
  double cpu_local_s = 0.0;
  double cpu_control_s = 0.0;
  std::vector<Eigen::Vector3d> trajectory_W;      ///< vehicle positions, one per control step
  std::vector<Eigen::Vector3d> replan_points_W;   ///< where a frame blocked the committed segment
  std::vector<Eigen::Vector2d> shortest_route_W;  ///< the ground-truth shortest route
  ProjectedGrid grid;                             ///< the planner's accumulated grid at the end
};

/// Flies `world` from its start to its goal. Deterministic for given world and options (apart
/// from the timings).
[[nodiscard]] NavFlightResult flyToGoal(const NavWorld& world,
                                        const NavFlightOptions& options = {});

}  // namespace mlmap::nav
