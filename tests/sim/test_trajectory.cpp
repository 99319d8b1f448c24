#include "mlmap/sim/trajectory.h"
#include "mlmap/sim/world.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mlmap::sim {
namespace {

using Eigen::Vector3d;

constexpr double kPi = 3.14159265358979323846;

double angleDiff(double a, double b) {
  double d = std::remainder(a - b, 2.0 * kPi);
  return std::abs(d);
}

/// Independent reference distances (not World::distance).
double distanceToBox(const Vector3d& p, const Vector3d& lo, const Vector3d& hi) {
  Vector3d q;
  for (int i = 0; i < 3; ++i) q[i] = std::clamp(p[i], lo[i], hi[i]);
  return (p - q).norm();
}

double referenceDistance(const World& world, const Vector3d& p, double time_s) {
  double best = 1e9;
  for (const Box& b : world.boxes()) best = std::min(best, distanceToBox(p, b.min_W, b.max_W));
  for (const Sphere& s : world.spheres()) {
    best = std::min(best, std::max(0.0, (p - s.center_W).norm() - s.radius_m));
  }
  for (const Cylinder& c : world.cylinders()) {
    const double dz = std::max({0.0, c.z_min_m - p.z(), p.z() - c.z_max_m});
    const double dr = std::max(0.0, (p.head<2>() - c.center_xy_W).norm() - c.radius_m);
    best = std::min(best, std::sqrt(dz * dz + dr * dr));
  }
  for (const MovingBox& m : world.movingBoxes()) {
    if (!m.isActiveAt(time_s)) continue;
    const Vector3d c = m.centerAt(time_s);
    best = std::min(best, distanceToBox(p, c - 0.5 * m.size_m, c + 0.5 * m.size_m));
  }
  return best;
}

Trajectory square() {
  return Trajectory({{Vector3d(0, 0, 1), 0.0, false},
                     {Vector3d(10, 0, 1), 0.0, false},
                     {Vector3d(10, 10, 1), 0.0, false},
                     {Vector3d(0, 10, 2), 0.0, false}},
                    2.0);
}

TEST(Trajectory, DurationAndEndpoints) {
  const Trajectory traj = square();
  const double length = 10 + 10 + std::sqrt(101.0);
  EXPECT_NEAR(traj.length_m(), length, 1e-12);
  EXPECT_NEAR(traj.duration_s(), length / 2.0, 1e-12);
  EXPECT_TRUE(traj.positionAt(0.0).isApprox(Vector3d(0, 0, 1)));
  EXPECT_TRUE(traj.positionAt(traj.duration_s()).isApprox(Vector3d(0, 10, 2)));
  EXPECT_TRUE(traj.positionAt(-5.0).isApprox(Vector3d(0, 0, 1)));  // clamped
  EXPECT_TRUE(traj.positionAt(1e6).isApprox(Vector3d(0, 10, 2)));
  EXPECT_TRUE(traj.positionAt(5.0).isApprox(Vector3d(10, 0, 1)));  // corner at 10 m / 2 m/s
  EXPECT_TRUE(traj.positionAt(2.5).isApprox(Vector3d(5, 0, 1)));
}

TEST(Trajectory, ConstantSpeedAndContinuity) {
  const Trajectory traj = square();
  const double dt = 0.01;
  double max_yaw_rate = 0.0;
  for (double t = 0.0; t + dt <= traj.duration_s(); t += dt) {
    const double step = (traj.positionAt(t + dt) - traj.positionAt(t)).norm();
    EXPECT_LE(step, 2.0 * dt + 1e-9) << "t=" << t;  // never faster than the speed
    max_yaw_rate = std::max(max_yaw_rate, angleDiff(traj.yawAt(t + dt), traj.yawAt(t)) / dt);
  }
  // Exactly the speed away from corners.
  for (double t : {0.3, 2.0, 4.9, 5.1, 7.7, 10.2, 14.0}) {
    const double step = (traj.positionAt(t + 1e-3) - traj.positionAt(t)).norm();
    EXPECT_NEAR(step / 1e-3, 2.0, 1e-6) << "t=" << t;
  }
  // A 90 deg turn blended over 2 s (smoothstep peak rate 1.5 x mean) stays below ~1.2 rad/s.
  EXPECT_LT(max_yaw_rate, 1.25);
  EXPECT_GT(max_yaw_rate, 0.5);  // it does turn
}

TEST(Trajectory, YawFollowsSegmentDirections) {
  const Trajectory traj = square();
  EXPECT_NEAR(traj.yawAt(2.5), 0.0, 1e-12);                   // +x
  EXPECT_NEAR(traj.yawAt(7.5), kPi / 2, 1e-12);               // +y
  EXPECT_NEAR(angleDiff(traj.yawAt(12.5), kPi), 0.0, 1e-12);  // -x
  EXPECT_NEAR(traj.yawAt(0.0), 0.0, 1e-12);
  EXPECT_NEAR(angleDiff(traj.yawAt(traj.duration_s()), kPi), 0.0, 1e-12);
  // Half way through the turn at the corner the yaw is half way.
  EXPECT_NEAR(traj.yawAt(5.0), kPi / 4, 1e-9);
  // Yaw is in (-pi, pi].
  for (double t = 0.0; t <= traj.duration_s(); t += 0.1) {
    EXPECT_GT(traj.yawAt(t), -kPi);
    EXPECT_LE(traj.yawAt(t), kPi);
  }
}

TEST(Trajectory, ShortestAngleAcrossPi) {
  // Heading 170 deg then -170 deg: the turn is 20 deg through 180, not 340 deg through 0.
  const double a = 170.0 * kPi / 180.0;
  const Trajectory traj({{Vector3d(0, 0, 1), 0.0, false},
                         {Vector3d(10 * std::cos(a), 10 * std::sin(a), 1), 0.0, false},
                         {Vector3d(10 * std::cos(a), 10 * std::sin(a), 1) +
                              10 * Vector3d(std::cos(-a), std::sin(-a), 0),
                          0.0, false}},
                        1.0);
  for (double t = 8.0; t <= 12.0; t += 0.05) {
    EXPECT_LT(angleDiff(traj.yawAt(t), kPi), 10.0 * kPi / 180.0 + 1e-9) << "t=" << t;
  }
}

TEST(Trajectory, GivenYawIsReachedAtItsWaypoint) {
  const Trajectory traj({{Vector3d(0, 0, 1), 0.0, false},
                         {Vector3d(10, 0, 1), kPi / 2, true},
                         {Vector3d(20, 0, 1), 0.0, false}},
                        1.0);
  EXPECT_NEAR(traj.yawAt(0.0), 0.0, 1e-12);
  EXPECT_NEAR(traj.yawAt(10.0), kPi / 2, 1e-9);
  EXPECT_NEAR(traj.yawAt(5.0), kPi / 4, 1e-9);  // interpolated along the segment
  EXPECT_NEAR(traj.yawAt(20.0), 0.0, 1e-12);    // back to the direction of travel
  const Transform T = traj.poseAt(10.0);
  EXPECT_TRUE((T.linear() * Vector3d::UnitX()).isApprox(Vector3d::UnitY(), 1e-9));
}

TEST(Trajectory, PoseIsLevelWithYawOnly) {
  const Trajectory traj = square();
  for (double t = 0.0; t <= traj.duration_s(); t += 0.37) {
    const Transform T = traj.poseAt(t);
    EXPECT_TRUE(T.translation().isApprox(traj.positionAt(t)));
    EXPECT_TRUE((T.linear() * Vector3d::UnitZ()).isApprox(Vector3d::UnitZ(), 1e-12));  // z up
    const Vector3d forward = T.linear() * Vector3d::UnitX();
    EXPECT_NEAR(forward.z(), 0.0, 1e-12);
    EXPECT_NEAR(std::atan2(forward.y(), forward.x()), traj.yawAt(t), 1e-9);
    EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
  }
}

TEST(Trajectory, VerticalSegmentKeepsHeading) {
  const Trajectory traj({{Vector3d(0, 0, 1), 0.0, false},
                         {Vector3d(0, 5, 1), 0.0, false},
                         {Vector3d(0, 5, 3), 0.0, false}},
                        1.0);
  EXPECT_NEAR(traj.yawAt(6.0), kPi / 2, 1e-12);
  EXPECT_NEAR(traj.yawAt(7.0), kPi / 2, 1e-12);
}

TEST(Trajectory, RejectsBadInput) {
  EXPECT_THROW(Trajectory({}, 1.0), std::invalid_argument);
  EXPECT_THROW(Trajectory({{Vector3d::Zero(), 0.0, false}, {Vector3d::UnitX(), 0.0, false}}, 0.0),
               std::invalid_argument);
  EXPECT_THROW(Trajectory({{Vector3d::Zero(), 0.0, false}, {Vector3d::UnitX(), 0.0, false}}, -1.0),
               std::invalid_argument);
  EXPECT_THROW(Trajectory({{Vector3d::Zero(), 0.0, false}, {Vector3d::Zero(), 0.0, false}}, 1.0),
               std::invalid_argument);
  EXPECT_THROW(Trajectory({{Vector3d(std::nan(""), 0, 0), 0.0, false}}, 1.0),
               std::invalid_argument);
  // A single waypoint is a hover: duration 0, constant pose.
  const Trajectory hover({{Vector3d(1, 2, 3), 0.5, true}}, 1.0);
  EXPECT_EQ(hover.duration_s(), 0.0);
  EXPECT_TRUE(hover.poseAt(7.0).translation().isApprox(Vector3d(1, 2, 3)));
  EXPECT_NEAR(hover.yawAt(7.0), 0.5, 1e-12);
  const Trajectory empty;
  EXPECT_EQ(empty.duration_s(), 0.0);
  EXPECT_TRUE(empty.poseAt(1.0).isApprox(Transform::Identity()));
}

TEST(Trajectory, DefaultRoomFlightShape) {
  const Trajectory traj = Trajectory::defaultRoomFlight();
  EXPECT_DOUBLE_EQ(traj.speed_mps(), 1.0);
  EXPECT_GE(traj.length_m(), 50.0);
  EXPECT_LE(traj.length_m(), 70.0);
  EXPECT_NEAR(traj.duration_s(), traj.length_m(), 1e-9);
  EXPECT_LE((traj.positionAt(traj.duration_s()) - traj.positionAt(0.0)).norm(), 1.5);
  for (double t = 0.0; t <= traj.duration_s(); t += 0.1) {
    const double z = traj.positionAt(t).z();
    EXPECT_GE(z, 1.2 - 1e-9);
    EXPECT_LE(z, 1.8 + 1e-9);
  }
}

TEST(Trajectory, DefaultRoomFlightKeepsOneMetreClearance) {
  const World world = World::defaultRoom();
  const Trajectory traj = Trajectory::defaultRoomFlight();
  double min_static = 1e9;
  double min_moving = 1e9;
  for (double t = 0.0; t <= traj.duration_s(); t += 0.02) {
    const Vector3d p = traj.positionAt(t);
    const double d = referenceDistance(world, p, t);
    EXPECT_GE(d, 1.0) << "t=" << t << " p=" << p.transpose();
    EXPECT_GE(world.distance(p), 1.0) << "t=" << t;
    min_static = std::min(min_static, world.distance(p));
    min_moving = std::min(min_moving, d);
  }
  EXPECT_GE(min_moving, 1.0);
  // The flight really passes close to things (through the doorways).
  EXPECT_LT(min_static, 2.0);
}

TEST(Trajectory, DefaultFlightSeesThePersonCrossAhead) {
  const World world = World::defaultRoom();
  const Trajectory traj = Trajectory::defaultRoomFlight();
  ASSERT_EQ(world.movingBoxes().size(), 1u);
  const MovingBox& person = world.movingBoxes()[0];
  // At the crossing time the person is in front of the vehicle (body +x) within a few metres.
  const double t = 10.5;
  ASSERT_TRUE(person.isActiveAt(t));
  const Vector3d p_B = traj.poseAt(t).inverse() * person.centerAt(t);
  EXPECT_GT(p_B.x(), 1.5);
  EXPECT_LT(p_B.x(), 4.0);
  EXPECT_LT(std::abs(p_B.y()), 0.5);
}

}  // namespace
}  // namespace mlmap::sim
