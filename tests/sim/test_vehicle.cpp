#include "mlmap/sim/vehicle.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mlmap::sim {
namespace {

TEST(Vehicle, NeverExceedsItsLimitsWhateverTheSetpoints) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  VehicleLimits limits;
  Vehicle vehicle(VehicleState{}, limits);
  const double dt = 0.02;
  for (int k = 0; k < 5000; ++k) {
    if (k % 50 == 0) rng.discard(1);
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    const Eigen::Vector3d v(u(rng), u(rng), u(rng));
    const VehicleState before = vehicle.state();
    vehicle.step(p, v, u(rng), dt);
    const VehicleState& after = vehicle.state();
    ASSERT_LE(after.velocity_W.norm(), limits.max_speed_mps + 1e-9);
    ASSERT_LE((after.velocity_W - before.velocity_W).norm(), limits.max_accel_mps2 * dt + 1e-9);
    ASSERT_LE(std::abs(wrapAngle(after.yaw_rad - before.yaw_rad)),
              limits.max_yaw_rate_radps * dt + 1e-9);
    ASSERT_TRUE((after.position_W - before.position_W).isApprox(after.velocity_W * dt));
  }
}

TEST(Vehicle, ReachesAPositionSetpointAndTurnsTheShorterWay) {
  VehicleState start;
  start.yaw_rad = 3.0;
  Vehicle vehicle(start);
  const Eigen::Vector3d target(4.0, -3.0, 1.5);
  double yaw_min = 3.0;
  for (int k = 0; k < 1000; ++k) {
    vehicle.step(target, Eigen::Vector3d::Zero(), -3.0, 0.02);  // -3 rad is 0.28 rad away past pi
    yaw_min = std::min(yaw_min, std::abs(vehicle.state().yaw_rad));
  }
  EXPECT_LT((vehicle.state().position_W - target).norm(), 1e-3);
  EXPECT_NEAR(vehicle.state().yaw_rad, -3.0, 1e-9);
  EXPECT_GT(yaw_min, 2.9);  // through pi, not through 0
  const Transform T = vehicle.state().T_W_B();
  EXPECT_TRUE(T.translation().isApprox(target, 1e-3));
  EXPECT_TRUE((T.linear() * Eigen::Vector3d::UnitX())
                  .isApprox(Eigen::Vector3d(std::cos(-3.0), std::sin(-3.0), 0.0)));
}

TEST(Vehicle, WrapAngleMapsIntoMinusPiToPi) {
  EXPECT_NEAR(wrapAngle(3.0 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrapAngle(-M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrapAngle(0.5 - 4.0 * M_PI), 0.5, 1e-12);
}

}  // namespace
}  // namespace mlmap::sim
