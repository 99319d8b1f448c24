#include "mlmap/sim/depth_camera.h"
#include "mlmap/sim/trajectory.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace mlmap::sim {
namespace {

using Eigen::Vector3d;

/// A wall facing -x whose near face is the plane x = distance_m, larger than any frustum.
World wallAt(double distance_m) {
  World world;
  EXPECT_TRUE(
      world.addBox({Vector3d(distance_m, -100, -100), Vector3d(distance_m + 0.2, 100, 100)}));
  return world;
}

/// Camera at the world origin looking along +x (body = world, optical frame via opticalToBody).
Transform forwardCamera() { return opticalToBody(); }

/// Point in S of pixel (u, v) at z-depth z.
Vector3d backProjectPixel(const PinholeIntrinsics& K, int u, int v, double z) {
  return Vector3d((u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z);
}

TEST(OpticalToBody, MapsOpticalAxesToFlu) {
  const Transform T_B_S = opticalToBody();
  EXPECT_TRUE((T_B_S * Vector3d::UnitZ()).isApprox(Vector3d::UnitX()));
  EXPECT_TRUE((T_B_S * Vector3d::UnitX()).isApprox(-Vector3d::UnitY()));
  EXPECT_TRUE((T_B_S * Vector3d::UnitY()).isApprox(-Vector3d::UnitZ()));
  EXPECT_TRUE(T_B_S.translation().isZero());
  EXPECT_NEAR(T_B_S.linear().determinant(), 1.0, 1e-12);
}

TEST(DepthCamera, FillsFrameMetadataAndKeepsPoses) {
  const DepthCamera camera;
  const World world = wallAt(3.0);
  DepthFrame frame;
  frame.T_W_B.translation() = Vector3d(1, 2, 3);
  frame.T_B_S = opticalToBody();
  frame.depth_mm.assign(5, 7);
  camera.render(world, forwardCamera(), 12.5, &frame);
  EXPECT_EQ(frame.encoding, DepthEncoding::kFloat32Metres);
  EXPECT_DOUBLE_EQ(frame.stamp_s, 12.5);
  EXPECT_EQ(frame.intrinsics.width, 640);
  EXPECT_EQ(frame.intrinsics.height, 480);
  EXPECT_DOUBLE_EQ(frame.intrinsics.fx, 385.0);
  EXPECT_DOUBLE_EQ(frame.intrinsics.cy, 239.5);
  EXPECT_EQ(frame.depth_m.size(), 640u * 480u);
  EXPECT_TRUE(frame.depth_mm.empty());
  EXPECT_TRUE(frame.T_W_B.translation().isApprox(Vector3d(1, 2, 3)));
  EXPECT_TRUE(frame.T_B_S.isApprox(opticalToBody()));
  camera.render(world, forwardCamera(), 0.0, nullptr);  // no crash
}

TEST(DepthCamera, WallGivesConstantZDepthNotRayLength) {
  const DepthCamera camera;
  const double kDistance_m = 4.0;
  const World world = wallAt(kDistance_m);
  DepthFrame frame;
  camera.render(world, forwardCamera(), 0.0, &frame);
  const PinholeIntrinsics& K = frame.intrinsics;
  for (int v = 0; v < K.height; ++v) {
    for (int u = 0; u < K.width; ++u) {
      ASSERT_NEAR(frame.depth_m[v * K.width + u], kDistance_m, 1e-5) << u << "," << v;
    }
  }
  // Corner ray length is ~27% longer than the z-depth; make sure the test can tell them apart.
  const double corner_ray_length = backProjectPixel(K, 0, 0, kDistance_m).norm();
  EXPECT_GT(corner_ray_length, kDistance_m * 1.2);
}

TEST(DepthCamera, BackProjectionLandsOnSurfaces) {
  const World world = World::defaultRoom();
  const Trajectory trajectory = Trajectory::defaultRoomFlight();
  const DepthCamera camera;
  const Transform T_B_S = opticalToBody();
  int checked = 0;
  for (double t : {0.0, 3.0, 18.0, 27.0, 40.0, 58.0}) {
    const Transform T_W_S = trajectory.poseAt(t) * T_B_S;
    DepthFrame frame;
    camera.render(world, T_W_S, t, &frame);
    const PinholeIntrinsics& K = frame.intrinsics;
    int valid = 0;
    for (int v = 0; v < K.height; v += 7) {
      for (int u = 0; u < K.width; u += 7) {
        const float z = frame.depth_m[v * K.width + u];
        if (z == 0.0f) continue;
        ++valid;
        ASSERT_GE(z, camera.model().min_depth_m);
        ASSERT_LE(z, camera.model().max_depth_m);
        const Vector3d p_W = T_W_S * backProjectPixel(K, u, v, z);
        // Float storage limits precision to ~1e-6 relative.
        ASSERT_LT(world.distance(p_W), 1e-4) << "t=" << t << " pixel " << u << "," << v;
        ++checked;
      }
    }
    EXPECT_GT(valid, 1000) << "t=" << t;  // the room is visible
  }
  EXPECT_GT(checked, 10000);
}

TEST(DepthCamera, TiledRenderEqualsPerPixelRaycast) {
  // The renderer culls per image tile; it must give exactly what World::raycast gives per pixel.
  const World world = World::defaultRoom();
  const Trajectory trajectory = Trajectory::defaultRoomFlight();
  DepthCameraModel model;
  model.intrinsics = PinholeIntrinsics{300.0, 310.0, 200.3, 150.7, 401, 299};  // odd tiles
  model.max_depth_m = 9.0;
  const DepthCamera camera(model);
  const PinholeIntrinsics& K = model.intrinsics;
  for (double t : {1.0, 10.5, 22.0, 33.3, 61.0}) {
    Transform T_W_S = trajectory.poseAt(t) * opticalToBody();
    if (t > 30.0) {  // also a tilted view
      T_W_S = T_W_S * Transform(Eigen::AngleAxisd(0.4, Vector3d::UnitX()));
    }
    DepthFrame frame;
    camera.render(world, T_W_S, t, &frame);
    int mismatches = 0;
    for (int v = 0; v < K.height; ++v) {
      for (int u = 0; u < K.width; ++u) {
        const Vector3d ray_S = backProjectPixel(K, u, v, 1.0);
        const double length_per_z = ray_S.norm();
        double t_hit = 0.0;
        float expected = 0.0f;
        if (world.raycast(T_W_S.translation(), T_W_S.linear() * (ray_S / length_per_z),
                          model.max_depth_m * length_per_z, t, &t_hit)) {
          const double z = t_hit / length_per_z;
          expected = z < model.min_depth_m ? 0.0f : static_cast<float>(z);
        }
        mismatches += (frame.depth_m[v * K.width + u] != expected);
      }
    }
    EXPECT_EQ(mismatches, 0) << "t=" << t;
  }
}

TEST(DepthCamera, SeesTheCrossingPerson) {
  const World world = World::defaultRoom();
  const Trajectory trajectory = Trajectory::defaultRoomFlight();
  const DepthCamera camera;
  const MovingBox& person = world.movingBoxes().at(0);
  const double t = 10.5;  // the person crosses the flight path
  const Transform T_W_S = trajectory.poseAt(t) * opticalToBody();
  DepthFrame frame;
  camera.render(world, T_W_S, t, &frame);
  const PinholeIntrinsics& K = frame.intrinsics;
  int on_person = 0;
  for (int v = 0; v < K.height; ++v) {
    for (int u = 0; u < K.width; ++u) {
      const float z = frame.depth_m[v * K.width + u];
      if (z == 0.0f) continue;
      const Vector3d p_W = T_W_S * backProjectPixel(K, u, v, z);
      const Vector3d excess = (p_W - person.centerAt(t)).cwiseAbs() - 0.5 * person.size_m;
      if (excess.maxCoeff() < 1e-4) ++on_person;
    }
  }
  EXPECT_GT(on_person, 10000);
  // Same pose without the person (after its window) sees none of it.
  DepthFrame later;
  camera.render(world, T_W_S, 16.0, &later);
  EXPECT_NE(frame.depth_m, later.depth_m);
}

TEST(DepthCamera, MinAndMaxDepthGiveZero) {
  DepthCameraModel model;
  model.min_depth_m = 0.5;
  model.max_depth_m = 6.0;
  const DepthCamera camera(model);
  DepthFrame frame;
  auto countValid = [&frame]() {
    int n = 0;
    for (float z : frame.depth_m) n += (z != 0.0f);
    return n;
  };
  const int all = model.intrinsics.width * model.intrinsics.height;
  camera.render(wallAt(0.4), forwardCamera(), 0.0, &frame);
  EXPECT_EQ(countValid(), 0);
  camera.render(wallAt(6.1), forwardCamera(), 0.0, &frame);
  EXPECT_EQ(countValid(), 0);
  // Limits are on z-depth: corner rays longer than 6 m still return at z = 5.9.
  camera.render(wallAt(5.9), forwardCamera(), 0.0, &frame);
  EXPECT_EQ(countValid(), all);
  camera.render(wallAt(0.6), forwardCamera(), 0.0, &frame);
  EXPECT_EQ(countValid(), all);
  camera.render(World(), forwardCamera(), 0.0, &frame);
  EXPECT_EQ(countValid(), 0);
  // A tilted floor: valid pixels are exactly those with z-depth in [min, max].
  World floor;
  ASSERT_TRUE(floor.addBox({Vector3d(-100, -100, -1), Vector3d(100, 100, 0)}));
  Transform T_W_B = Transform::Identity();
  T_W_B.translation() = Vector3d(0, 0, 1.0);
  T_W_B.linear() = Eigen::AngleAxisd(0.3, Vector3d::UnitY()).toRotationMatrix();  // pitch down
  const Transform T_W_S = T_W_B * opticalToBody();
  camera.render(floor, T_W_S, 0.0, &frame);
  const PinholeIntrinsics& K = frame.intrinsics;
  int mismatches = 0;
  int in_range = 0;
  for (int v = 0; v < K.height; ++v) {
    for (int u = 0; u < K.width; ++u) {
      // Analytic z-depth of the floor plane z_W = 0 along this pixel's ray.
      const Vector3d ray_W = T_W_S.linear() * backProjectPixel(K, u, v, 1.0);
      const double z_true = ray_W.z() < 0 ? -T_W_S.translation().z() / ray_W.z() : 1e9;
      const bool expect_valid = z_true >= model.min_depth_m && z_true <= model.max_depth_m;
      const float z = frame.depth_m[v * K.width + u];
      if (std::abs(z_true - model.max_depth_m) < 1e-6) continue;  // knife edge
      mismatches += (expect_valid != (z != 0.0f));
      if (expect_valid) {
        ++in_range;
        ASSERT_NEAR(z, z_true, 1e-5 * z_true);
      }
    }
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(in_range, 1000);
  EXPECT_LT(in_range, all);
}

/// Mean and standard deviation of a wall render with noise.
void wallStats(double distance_m, double k, std::uint32_t seed, double time_s, double* mean,
               double* stddev, std::vector<float>* image = nullptr) {
  DepthCameraModel model;
  model.noise_coeff_per_m = k;
  model.seed = seed;
  const DepthCamera camera(model);
  DepthFrame frame;
  camera.render(wallAt(distance_m), forwardCamera(), time_s, &frame);
  double sum = 0.0;
  double sum_sq = 0.0;
  for (float z : frame.depth_m) {
    sum += z;
    sum_sq += static_cast<double>(z) * z;
  }
  const double n = static_cast<double>(frame.depth_m.size());
  *mean = sum / n;
  *stddev = std::sqrt(sum_sq / n - *mean * *mean);
  if (image != nullptr) *image = frame.depth_m;
}

TEST(DepthCamera, NoiseSigmaGrowsWithDepthSquared) {
  const double k = 0.01;
  for (double d : {2.0, 4.0, 8.0}) {
    double mean = 0.0;
    double stddev = 0.0;
    wallStats(d, k, 7, 0.0, &mean, &stddev);
    const double sigma = k * d * d;
    const double n = 640.0 * 480.0;
    EXPECT_NEAR(mean, d, 5.0 * sigma / std::sqrt(n)) << "d=" << d;
    EXPECT_NEAR(stddev, sigma, 0.02 * sigma) << "d=" << d;
  }
  double mean = 0.0;
  double stddev = 0.0;
  wallStats(4.0, 0.0, 7, 0.0, &mean, &stddev);
  EXPECT_LT(stddev, 1e-5);  // off when k = 0
}

TEST(DepthCamera, NoiseIsDeterministicPerSeedAndTime) {
  double mean = 0.0;
  double stddev = 0.0;
  std::vector<float> a;
  std::vector<float> b;
  std::vector<float> c;
  std::vector<float> d;
  wallStats(3.0, 0.01, 5, 1.0, &mean, &stddev, &a);
  wallStats(3.0, 0.01, 5, 1.0, &mean, &stddev, &b);
  wallStats(3.0, 0.01, 6, 1.0, &mean, &stddev, &c);
  wallStats(3.0, 0.01, 5, 1.1, &mean, &stddev, &d);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  EXPECT_NE(a, d);
  // Neighbouring pixels are uncorrelated.
  double cov = 0.0;
  double var = 0.0;
  // cppcheck-suppress unsignedLessThanZero ; it reads "i + 1 < size", not "< 0"
  for (std::size_t i = 0; i + 1 < a.size(); ++i) {
    cov += (a[i] - 3.0) * (a[i + 1] - 3.0);
    var += (a[i] - 3.0) * (a[i] - 3.0);
  }
  EXPECT_LT(std::abs(cov / var), 0.01);
}

TEST(DepthCamera, InvalidIntrinsicsGiveEmptyImage) {
  DepthCameraModel model;
  model.intrinsics.width = 0;
  const DepthCamera camera(model);
  DepthFrame frame;
  frame.depth_m.assign(10, 1.0f);
  camera.render(wallAt(2.0), forwardCamera(), 0.0, &frame);
  EXPECT_TRUE(frame.depth_m.empty());
}

TEST(DepthCamera, PixelCentreConvention) {
  // A small sphere on the optical axis of a camera with an odd-sized image and integer centre.
  DepthCameraModel model;
  model.intrinsics = PinholeIntrinsics{100.0, 100.0, 2.0, 2.0, 5, 5};
  const DepthCamera camera(model);
  World world;
  ASSERT_TRUE(world.addSphere({Vector3d(5, 0, 0), 0.01}));
  DepthFrame frame;
  camera.render(world, forwardCamera(), 0.0, &frame);
  for (int v = 0; v < 5; ++v) {
    for (int u = 0; u < 5; ++u) {
      const float z = frame.depth_m[v * 5 + u];
      if (u == 2 && v == 2) {
        EXPECT_NEAR(z, 4.99, 1e-6);
      } else {
        EXPECT_EQ(z, 0.0f) << u << "," << v;
      }
    }
  }
  // Pixel (3, 2) looks right (-y_W for a forward camera), i.e. towards +x_S.
  World right;
  ASSERT_TRUE(right.addSphere({Vector3d(5, -0.05, 0), 0.01}));
  camera.render(right, forwardCamera(), 0.0, &frame);
  EXPECT_GT(frame.depth_m[2 * 5 + 3], 0.0f);
  EXPECT_EQ(frame.depth_m[2 * 5 + 2], 0.0f);
  // Pixel (2, 3) looks down (-z_W).
  World down;
  ASSERT_TRUE(down.addSphere({Vector3d(5, 0, -0.05), 0.01}));
  camera.render(down, forwardCamera(), 0.0, &frame);
  EXPECT_GT(frame.depth_m[3 * 5 + 2], 0.0f);
}

}  // namespace
}  // namespace mlmap::sim
