#include "mlmap/sim/lidar.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace mlmap::sim {
namespace {

using Eigen::Vector3d;

constexpr double kPi = 3.141592653589793238462643383279502884;

/// A closed room: the free interior is [lo, hi]; walls, floor and ceiling 0.5 m thick outside it.
World closedRoom(const Vector3d& lo, const Vector3d& hi) {
  World world;
  const Vector3d t(0.5, 0.5, 0.5);
  for (int axis = 0; axis < 3; ++axis) {
    Vector3d a_min = lo - t, a_max = hi + t;
    a_max[axis] = lo[axis];  // the wall below the interior along `axis`
    EXPECT_TRUE(world.addBox({a_min, a_max}));
    a_min = lo - t;
    a_max = hi + t;
    a_min[axis] = hi[axis];  // the wall above
    EXPECT_TRUE(world.addBox({a_min, a_max}));
  }
  return world;
}

/// Reference: distance from `origin` along unit `dir` to the inside of the box [lo, hi].
double exitDistance(const Vector3d& origin, const Vector3d& dir, const Vector3d& lo,
                    const Vector3d& hi) {
  double t = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (dir[a] > 1e-12) t = std::min(t, (hi[a] - origin[a]) / dir[a]);
    if (dir[a] < -1e-12) t = std::min(t, (lo[a] - origin[a]) / dir[a]);
  }
  return t;
}

/// Calls f(beam, step, direction in S) for every ray, in render()'s order (beam-major).
template <typename F>
void forEachRay(const Lidar& lidar, F f) {
  for (int b = 0; b < lidar.model().beams; ++b) {
    for (int a = 0; a < lidar.model().azimuth_steps; ++a) f(b, a, lidar.rayDirection_S(b, a));
  }
}

TEST(Lidar, DefaultModelIs128By640With30MetreRange) {
  const Lidar lidar;
  EXPECT_EQ(lidar.model().rayCount(), 81920u);
  EXPECT_DOUBLE_EQ(lidar.model().max_range_m, 30.0);
}

TEST(Lidar, RayAnglesFollowTheModel) {
  LidarModel model;
  model.beams = 5;
  model.azimuth_steps = 8;
  model.vertical_min_deg = -20.0;
  model.vertical_max_deg = 20.0;
  const Lidar lidar(model);
  for (int b = 0; b < 5; ++b) {
    for (int a = 0; a < 8; ++a) {
      const Vector3d d = lidar.rayDirection_S(b, a);
      EXPECT_NEAR(d.norm(), 1.0, 1e-12);
      EXPECT_NEAR(std::asin(d.z()) * 180.0 / kPi, -20.0 + 10.0 * b, 1e-9);
      const double azimuth_deg = std::atan2(d.y(), d.x()) * 180.0 / kPi;
      EXPECT_NEAR(std::remainder(azimuth_deg - 45.0 * a, 360.0), 0.0, 1e-9);
    }
  }
  model.beams = 1;
  EXPECT_NEAR(Lidar(model).rayDirection_S(0, 0).z(), 0.0, 1e-12);  // the middle elevation
}

TEST(Lidar, EveryRayInAClosedRoomReturnsItsWallDistance) {
  const Vector3d lo(-4.0, -3.0, -1.0), hi(5.0, 6.0, 2.5);
  const World world = closedRoom(lo, hi);
  LidarModel model;
  model.beams = 32;
  model.azimuth_steps = 180;
  model.vertical_min_deg = -60.0;
  model.vertical_max_deg = 60.0;
  const Lidar lidar(model);
  // A rotated, offset sensor.
  Transform T_W_S = Transform::Identity();
  T_W_S.linear() =
      (Eigen::AngleAxisd(0.7, Vector3d::UnitZ()) * Eigen::AngleAxisd(0.2, Vector3d::UnitY()) *
       Eigen::AngleAxisd(-0.1, Vector3d::UnitX()))
          .toRotationMatrix();
  T_W_S.translation() = Vector3d(1.0, 0.5, 0.3);
  PointCloudFrame frame;
  frame.T_B_S.translation() = Vector3d(9, 9, 9);  // untouched by render
  lidar.render(world, T_W_S, 3.5, &frame);
  EXPECT_DOUBLE_EQ(frame.stamp_s, 3.5);
  EXPECT_TRUE(frame.T_B_S.translation().isApprox(Vector3d(9, 9, 9)));
  ASSERT_EQ(frame.points_S.size(), model.rayCount());  // closed room, all within 30 m
  std::size_t i = 0;
  forEachRay(lidar, [&](int b, int a, const Vector3d& dir_S) {
    const double expected = exitDistance(T_W_S.translation(), T_W_S.linear() * dir_S, lo, hi);
    const Vector3d p_S = frame.points_S[i++].cast<double>();
    EXPECT_NEAR(p_S.norm(), expected, 1e-5) << "beam " << b << " step " << a;
    EXPECT_NEAR((p_S.normalized() - dir_S).norm(), 0.0, 1e-6);
  });
}

TEST(Lidar, RangeLimitsDropReturnsBeyondMaxAndBelowMin) {
  // Long corridor along x: the +x end is 40 m away, beyond the 30 m range.
  const Vector3d lo(-2.0, -1.0, -1.0), hi(40.0, 1.0, 1.0);
  const World world = closedRoom(lo, hi);
  LidarModel model;
  model.beams = 16;
  model.azimuth_steps = 90;
  model.min_range_m = 1.05;  // also drops the nearest wall hits (1 m to y = +-1 straight sideways)
  const Lidar lidar(model);
  PointCloudFrame frame;
  lidar.render(world, Transform::Identity(), 0.0, &frame);
  std::size_t expected = 0;
  forEachRay(lidar, [&](int, int, const Vector3d& dir_S) {
    const double t = exitDistance(Vector3d::Zero(), dir_S, lo, hi);
    if (t >= model.min_range_m && t <= model.max_range_m) ++expected;
  });
  EXPECT_LT(expected, model.rayCount());
  EXPECT_GT(expected, model.rayCount() / 2);
  ASSERT_EQ(frame.points_S.size(), expected);
  for (const Eigen::Vector3f& p : frame.points_S) {
    EXPECT_LE(p.norm(), 30.0f + 1e-4f);
    EXPECT_GE(p.norm(), 1.05f - 1e-4f);
  }
  PointCloudFrame empty;
  lidar.render(World{}, Transform::Identity(), 0.0, &empty);
  EXPECT_TRUE(empty.points_S.empty());
  lidar.render(world, Transform::Identity(), 0.0, nullptr);  // no crash
}

TEST(Lidar, NoiseIsDeterministicUnbiasedAndHasTheGivenSigma) {
  const Vector3d lo(-10.0, -10.0, -10.0), hi(10.0, 10.0, 10.0);
  const World world = closedRoom(lo, hi);
  LidarModel model;
  model.beams = 64;
  model.azimuth_steps = 256;
  model.noise_sigma_m = 0.05;
  const Lidar lidar(model);
  PointCloudFrame a, b, c;
  lidar.render(world, Transform::Identity(), 1.0, &a);
  lidar.render(world, Transform::Identity(), 1.0, &b);
  lidar.render(world, Transform::Identity(), 1.1, &c);
  ASSERT_EQ(a.points_S.size(), model.rayCount());
  ASSERT_EQ(a.points_S.size(), c.points_S.size());
  double sum = 0.0, sum_sq = 0.0;
  std::size_t differing = 0;
  std::size_t i = 0;
  forEachRay(lidar, [&](int, int, const Vector3d& dir_S) {
    EXPECT_EQ(a.points_S[i], b.points_S[i]);
    if (a.points_S[i] != c.points_S[i]) ++differing;
    const double error =
        a.points_S[i].cast<double>().norm() - exitDistance(Vector3d::Zero(), dir_S, lo, hi);
    sum += error;
    sum_sq += error * error;
    ++i;
  });
  const double n = static_cast<double>(i);
  EXPECT_GT(differing, i * 9 / 10);
  EXPECT_NEAR(sum / n, 0.0, 0.002);
  EXPECT_NEAR(std::sqrt(sum_sq / n), 0.05, 0.002);
}

TEST(Lidar, BadModelIsRefusedNamingTheKeys) {
  LidarModel model;
  model.beams = 0;
  model.max_range_m = std::nan("");
  try {
    Lidar lidar(model);
    FAIL() << "accepted a bad model";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("lidar.beams"), std::string::npos) << what;
    EXPECT_NE(what.find("lidar.max_range_m"), std::string::npos) << what;
  }
  model = LidarModel{};
  model.vertical_min_deg = 10.0;
  model.vertical_max_deg = 5.0;
  EXPECT_THROW(Lidar{model}, std::invalid_argument);
}

}  // namespace
}  // namespace mlmap::sim
