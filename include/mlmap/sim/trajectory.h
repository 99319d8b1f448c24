#pragma once
/// @file
/// Piecewise-linear constant-speed flight path with smooth yaw, for the simulator.

#include "mlmap/core/types.h"

#include <cstddef>
#include <vector>

namespace mlmap::sim {

/// A point the vehicle flies through, optionally with the yaw it must have there.
struct Waypoint {
  Eigen::Vector3d position_W = Eigen::Vector3d::Zero();  ///< position in W [m]
  double yaw_rad = 0.0;  ///< heading about W +z, 0 = facing +x [rad]; used only if has_yaw
  bool has_yaw = false;  ///< false: face the direction of travel
};

/// Flies straight lines between waypoints at constant speed, starting at t = 0 at the first one.
///
/// Yaw: each segment has a start and end yaw — a waypoint's given yaw, otherwise the segment's
/// horizontal direction of travel — interpolated along the segment by the shortest angle. Around
/// each interior waypoint the yaw blends smoothly (smoothstep, shortest angle) from the incoming
/// to the outgoing segment over a window of `yaw_blend_s` centred on the corner (shortened to at
/// most half of either adjacent segment), so the camera never snaps. Roll = pitch = 0.
class Trajectory {
 public:
  /// Default yaw blending window at corners [s].
  static constexpr double kDefaultYawBlend_s = 2.0;

  /// An empty trajectory: duration 0 and identity pose.
  Trajectory() = default;

  /// Builds the trajectory. Load-time only: throws std::invalid_argument with a clear message
  /// when there is no waypoint, a value is not finite, speed_mps <= 0, yaw_blend_s < 0, or two
  /// consecutive waypoints coincide.
  Trajectory(std::vector<Waypoint> waypoints, double speed_mps,
             double yaw_blend_s = kDefaultYawBlend_s);

  /// Total flight time [s] (0 for fewer than two waypoints).
  [[nodiscard]] double duration_s() const { return duration_s_; }
  /// Total path length [m].
  [[nodiscard]] double length_m() const { return length_m_; }
  /// Flight speed [m/s] (0 for an empty trajectory).
  [[nodiscard]] double speed_mps() const { return speed_mps_; }
  /// Yaw blending window at corners [s].
  [[nodiscard]] double yawBlend_s() const { return yaw_blend_s_; }
  /// The waypoints it was built from.
  [[nodiscard]] const std::vector<Waypoint>& waypoints() const { return waypoints_; }

  /// Position in W at time `t_s` (clamped to [0, duration_s()]).
  [[nodiscard]] Eigen::Vector3d positionAt(double t_s) const;
  /// Yaw in (-pi, pi] at time `t_s` (clamped to [0, duration_s()]).
  [[nodiscard]] double yawAt(double t_s) const;
  /// Body pose T_W_B (FLU body, z up, roll = pitch = 0) at time `t_s` (clamped).
  [[nodiscard]] Transform poseAt(double t_s) const;

  /// Loop through World::defaultRoom() at 1 m/s, 63 m / ~63 s: (4, 4.5, 1.5) -> east through the
  /// x = 10 doorway to (25, 4.5, 1.5) -> north through the y = 10 doorway to (25, 15.5, 1.8) ->
  /// west through the second x = 10 doorway, descending to (4, 15.5, 1.2) -> south to
  /// (4, 5.5, 1.5), 1 m from the start. Keeps >= 1 m from every obstacle (moving one included).
  [[nodiscard]] static Trajectory defaultRoomFlight();

 private:
  /// Index of the segment containing `t_s` (already clamped).
  [[nodiscard]] std::size_t segmentAt(double t_s) const;
  /// Un-blended yaw of segment `k` at `t_s` (held constant outside the segment).
  [[nodiscard]] double segmentYaw(std::size_t k, double t_s) const;

  std::vector<Waypoint> waypoints_;
  std::vector<double> start_times_s_;  ///< start time of each segment, plus the end time
  std::vector<double> start_yaw_rad_;  ///< yaw at the start of each segment
  std::vector<double> end_yaw_rad_;    ///< yaw at the end of each segment
  std::vector<double> blend_half_s_;   ///< half blending window at waypoint i (0 at ends)
  double speed_mps_ = 0.0;
  double yaw_blend_s_ = kDefaultYawBlend_s;
  double duration_s_ = 0.0;
  double length_m_ = 0.0;
};

}  // namespace mlmap::sim
