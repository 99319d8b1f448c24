#pragma once
/// @file
/// Loads a simulation scenario (world, flight, depth camera, frame rate) from YAML.
///
/// Layout (every key optional except the ones a primitive or waypoint needs; unknown keys and
/// bad values are errors). Lengths in metres, angles in degrees, times in seconds:
/// @code
/// base: building.yaml         # start from this scenario (relative to this file's folder)
/// world:
///   boxes:        [{min_m: [x, y, z], max_m: [x, y, z]}]
///   cylinders:    [{center_xy_m: [x, y], radius_m: r, z_min_m: a, z_max_m: b}]
///   spheres:      [{center_m: [x, y, z], radius_m: r}]
///   moving_boxes: [{size_m: [sx, sy, sz], start_center_m: [x, y, z], velocity_mps: [vx, vy, vz],
///                   t_start_s: a, t_end_s: b}]
/// trajectory:                 # if present, waypoints are required
///   speed_mps: 1.0            # default 1.0
///   waypoints: [{position_m: [x, y, z], yaw_deg: 90}]   # yaw_deg optional (default: travel dir)
/// camera: {width: 640, height: 480, fx: 385, fy: 385, cx: 319.5, cy: 239.5,
///          min_depth_m: 0.2, max_depth_m: 15, noise_coeff_per_m: 0.0, seed: 1}
/// frame_rate_hz: 10
/// @endcode
/// Missing sections keep the base's (with `base`) or the defaults of Scenario (empty world, empty
/// trajectory, default DepthCameraModel, 10 Hz); a section given replaces the base's whole
/// section, so several flights can share one world file (config/worlds/fleet/). A null value
/// for a section or list counts as absent/empty. A chain of bases longer than 8 is an error
/// (a cycle), and errors in a base name that file.

#include "mlmap/sim/depth_camera.h"
#include "mlmap/sim/trajectory.h"
#include "mlmap/sim/world.h"

#include <string>

namespace mlmap::datasets {

/// Everything needed to run a simulated flight.
struct Scenario {
  sim::World world;              ///< static and moving obstacles
  sim::Trajectory trajectory;    ///< body flight path (T_W_B over time)
  sim::DepthCameraModel camera;  ///< depth camera parameters
  double frame_rate_hz = 10.0;   ///< depth frames per second [Hz], > 0
};

/// Loads a scenario from the YAML file at `path`. Throws std::runtime_error whose message starts
/// with the file name and names the offending key path, e.g.
/// "room.yaml: world.boxes[2]: unknown key 'sise_m'".
[[nodiscard]] Scenario loadScenarioYaml(const std::string& path);

/// Parses a scenario from YAML text; `source_name` prefixes error messages (as the file name
/// does in loadScenarioYaml), and a `base` is taken relative to the working folder. Throws
/// std::runtime_error on any error.
[[nodiscard]] Scenario parseScenarioYaml(const std::string& yaml_text,
                                         const std::string& source_name = "<string>");

/// World::defaultRoom() + Trajectory::defaultRoomFlight() + default DepthCameraModel at 10 Hz;
/// config/worlds/default_room.yaml describes the same scenario.
[[nodiscard]] Scenario defaultScenario();

}  // namespace mlmap::datasets
