#include "mlmap/sim/vehicle.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace mlmap::sim {

namespace {
constexpr double kPi = 3.141592653589793238462643383279502884;
}  // namespace

double wrapAngle(double angle_rad) {
  const double two_pi = 2.0 * kPi;
  double a = std::fmod(angle_rad, two_pi);
  if (a <= -kPi) a += two_pi;
  if (a > kPi) a -= two_pi;
  return a;
}

Transform VehicleState::T_W_B() const {
  Transform T = Transform::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = position_W;
  return T;
}

Vehicle::Vehicle(const VehicleState& initial, const VehicleLimits& limits)
    : state_(initial), limits_(limits) {
  state_.velocity_W.setZero();
  state_.yaw_rad = wrapAngle(state_.yaw_rad);
}

void Vehicle::step(const Eigen::Vector3d& position_W, const Eigen::Vector3d& velocity_W,
                   double yaw_rad, double dt_s) {
  Eigen::Vector3d wanted =
      velocity_W + limits_.position_gain_per_s * (position_W - state_.position_W);
  if (wanted.norm() > limits_.max_speed_mps) wanted *= limits_.max_speed_mps / wanted.norm();
  Eigen::Vector3d dv = wanted - state_.velocity_W;
  const double max_dv = limits_.max_accel_mps2 * dt_s;
  if (dv.norm() > max_dv) dv *= max_dv / dv.norm();
  state_.velocity_W += dv;
  state_.position_W += state_.velocity_W * dt_s;
  const double turn = wrapAngle(yaw_rad - state_.yaw_rad);
  const double max_turn = limits_.max_yaw_rate_radps * dt_s;
  state_.yaw_rad = wrapAngle(state_.yaw_rad + std::clamp(turn, -max_turn, max_turn));
}

}  // namespace mlmap::sim
