#pragma once
/// @file
/// A simple multirotor model for closed-loop simulation: it tracks position / velocity / yaw
/// setpoints within velocity, acceleration and yaw-rate limits, its yaw following the commanded
/// heading (the direction of travel), roll = pitch = 0. World frame W (z up), metres, seconds,
/// radians (yaw about W +z, 0 facing +x).

#include "mlmap/core/types.h"

#include <Eigen/Core>

namespace mlmap::sim {

/// Limits and gains of the vehicle model.
struct VehicleLimits {
  double max_speed_mps = 1.5;        ///< speed never exceeded [m/s]
  double max_accel_mps2 = 2.0;       ///< acceleration never exceeded [m/s^2]
  double max_yaw_rate_radps = 2.0;   ///< yaw rate never exceeded [rad/s]
  double position_gain_per_s = 1.5;  ///< velocity per metre of position error [1/s]
};

/// Position, velocity and yaw of the vehicle.
struct VehicleState {
  Eigen::Vector3d position_W = Eigen::Vector3d::Zero();  ///< [m]
  Eigen::Vector3d velocity_W = Eigen::Vector3d::Zero();  ///< [m/s]
  double yaw_rad = 0.0;                                  ///< in (-pi, pi] [rad]

  /// The body pose: FLU body at position_W, rotated by yaw_rad about W +z.
  [[nodiscard]] Transform T_W_B() const;
};

/// Integrates the vehicle over time steps.
class Vehicle {
 public:
  /// A vehicle at rest in `initial`.
  explicit Vehicle(const VehicleState& initial, const VehicleLimits& limits = {});

  /// Advances by dt_s towards the setpoint: the commanded velocity is velocity_W +
  /// position_gain_per_s * (position_W - position), capped at max_speed_mps; the velocity moves
  /// towards it by at most max_accel_mps2 * dt_s; the position integrates the new velocity; the
  /// yaw turns towards yaw_rad by the shorter way, at most max_yaw_rate_radps * dt_s.
  void step(const Eigen::Vector3d& position_W, const Eigen::Vector3d& velocity_W, double yaw_rad,
            double dt_s);

  /// The current state.
  [[nodiscard]] const VehicleState& state() const { return state_; }
  /// The limits.
  [[nodiscard]] const VehicleLimits& limits() const { return limits_; }

 private:
  VehicleState state_;
  VehicleLimits limits_;
};

/// `angle_rad` wrapped to (-pi, pi].
[[nodiscard]] double wrapAngle(double angle_rad);

}  // namespace mlmap::sim
