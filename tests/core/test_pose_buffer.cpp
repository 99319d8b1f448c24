#include "mlmap/core/pose_buffer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace mlmap {
namespace {

Transform pose(double x, double yaw_rad) {
  Transform T = Transform::Identity();
  T.translation() = Eigen::Vector3d(x, 2.0 * x, -x);
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

/// pose() moves 2.4 m per unit of x: these tests fly at hundreds of m/s, which the default
/// PoseBufferConfig takes for a jump (tests/faults checks that limit).
PoseBufferConfig fastVehicle() {
  PoseBufferConfig config;
  config.max_speed_mps = 1e4;
  return config;
}

double yawOf(const Transform& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

TEST(PoseBuffer, ExactStampsAndInterpolationBetweenNeighbours) {
  PoseBuffer buffer(fastVehicle());
  ASSERT_EQ(buffer.add(10.0, pose(0.0, 0.0)), PoseBuffer::AddResult::kAdded);
  ASSERT_EQ(buffer.add(10.04, pose(4.0, 0.4)), PoseBuffer::AddResult::kAdded);
  ASSERT_EQ(buffer.add(10.08, pose(8.0, 0.8)), PoseBuffer::AddResult::kAdded);

  Transform T;
  ASSERT_EQ(buffer.lookup(10.04, &T), PoseBuffer::LookupResult::kFound);
  EXPECT_NEAR(T.translation().x(), 4.0, 1e-9);
  ASSERT_EQ(buffer.lookup(10.08, &T), PoseBuffer::LookupResult::kFound);
  EXPECT_NEAR(T.translation().x(), 8.0, 1e-9);
  ASSERT_EQ(buffer.lookup(10.0, &T), PoseBuffer::LookupResult::kFound);
  EXPECT_NEAR(T.translation().x(), 0.0, 1e-9);

  // A quarter of the way from 10.04 to 10.08: translation linear, yaw along the shortest arc.
  ASSERT_EQ(buffer.lookup(10.05, &T), PoseBuffer::LookupResult::kFound);
  EXPECT_NEAR(T.translation().x(), 5.0, 1e-6);
  EXPECT_NEAR(T.translation().y(), 10.0, 1e-6);
  EXPECT_NEAR(yawOf(T), 0.5, 1e-6);
  EXPECT_TRUE(isValidPose(T));
}

TEST(PoseBuffer, NewerThanEveryPoseIsPendingNeverExtrapolated) {
  PoseBuffer buffer(fastVehicle());
  Transform T = pose(123.0, 0.0);
  const Transform untouched = T;
  EXPECT_EQ(buffer.lookup(1.0, &T), PoseBuffer::LookupResult::kPending);  // no pose yet
  buffer.add(1.0, pose(1.0, 0.0));
  EXPECT_EQ(buffer.lookup(1.01, &T), PoseBuffer::LookupResult::kPending);
  EXPECT_TRUE(T.isApprox(untouched));
  buffer.add(1.02, pose(2.0, 0.0));
  EXPECT_EQ(buffer.lookup(1.01, &T), PoseBuffer::LookupResult::kFound);
  EXPECT_NEAR(T.translation().x(), 1.5, 1e-6);
}

TEST(PoseBuffer, GapsAndOldStampsHaveNoPose) {
  PoseBufferConfig config;
  config.tolerance_s = 0.05;
  PoseBuffer buffer(config);
  buffer.add(1.0, pose(1.0, 0.0));
  buffer.add(1.5, pose(2.0, 0.0));  // the pose stream paused for 0.5 s
  Transform T;
  EXPECT_EQ(buffer.lookup(1.25, &T), PoseBuffer::LookupResult::kNoPose);
  EXPECT_EQ(buffer.lookup(1.04, &T), PoseBuffer::LookupResult::kFound);  // 40 ms after a pose
  EXPECT_EQ(buffer.lookup(1.46, &T), PoseBuffer::LookupResult::kFound);  // 40 ms before one
  EXPECT_EQ(buffer.lookup(1.06, &T), PoseBuffer::LookupResult::kNoPose);
  EXPECT_EQ(buffer.lookup(0.99, &T), PoseBuffer::LookupResult::kNoPose);  // before the buffer
  EXPECT_EQ(buffer.lookup(std::numeric_limits<double>::quiet_NaN(), &T),
            PoseBuffer::LookupResult::kNoPose);
}

TEST(PoseBuffer, RejectsAndCountsBadPoses) {
  PoseBuffer buffer(PoseBufferConfig{});
  ASSERT_EQ(buffer.add(5.0, pose(0.0, 0.0)), PoseBuffer::AddResult::kAdded);
  EXPECT_EQ(buffer.add(5.0, pose(1.0, 0.0)), PoseBuffer::AddResult::kOutOfOrder);
  EXPECT_EQ(buffer.add(4.0, pose(1.0, 0.0)), PoseBuffer::AddResult::kOutOfOrder);
  EXPECT_EQ(buffer.add(500.0, pose(1.0, 0.0)), PoseBuffer::AddResult::kFuture);
  Transform scaled = pose(1.0, 0.0);
  scaled.linear() *= 1.1;  // not a rotation
  EXPECT_EQ(buffer.add(5.1, scaled), PoseBuffer::AddResult::kInvalid);
  Transform nan = pose(1.0, 0.0);
  nan.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(buffer.add(5.2, nan), PoseBuffer::AddResult::kInvalid);
  EXPECT_EQ(buffer.add(std::numeric_limits<double>::infinity(), pose(1.0, 0.0)),
            PoseBuffer::AddResult::kInvalid);
  // Good poses still go in after all of that.
  EXPECT_EQ(buffer.add(5.3, pose(1.0, 0.0)), PoseBuffer::AddResult::kAdded);

  const PoseBufferCounters& c = buffer.counters();
  EXPECT_EQ(c.poses_added, 2u);
  EXPECT_EQ(c.rejected_out_of_order, 2u);
  EXPECT_EQ(c.rejected_future, 1u);
  EXPECT_EQ(c.rejected_invalid, 3u);
}

TEST(PoseBuffer, KeepsOnlyTheHorizon) {
  PoseBufferConfig config;
  config.horizon_s = 1.0;
  PoseBuffer buffer(config);
  for (int i = 0; i <= 300; ++i) buffer.add(i * 0.01, pose(i, 0.0));  // 3 s at 100 Hz
  EXPECT_LE(buffer.size(), 102u);
  EXPECT_GE(buffer.size(), 100u);
  Transform T;
  EXPECT_EQ(buffer.lookup(2.5, &T), PoseBuffer::LookupResult::kFound);
  EXPECT_EQ(buffer.lookup(0.5, &T), PoseBuffer::LookupResult::kNoPose);
}

TEST(PoseBuffer, InvalidConfigurationNamesTheKey) {
  PoseBufferConfig config;
  config.tolerance_s = -1.0;
  config.max_future_s = std::numeric_limits<double>::quiet_NaN();
  try {
    PoseBuffer buffer(config);
    FAIL() << "accepted an invalid configuration";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("tolerance_s"), std::string::npos) << what;
    EXPECT_NE(what.find("max_future_s"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace mlmap
