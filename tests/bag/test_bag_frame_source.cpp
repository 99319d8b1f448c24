/// @file
/// BagFrameSource on the generated bags: the frames decoded from a bag are what the generator
/// wrote (points, depth pixels, intrinsics), with the poses of its trajectory and the extrinsics
/// of its /tf_static, whatever the storage; autoSelect() picks the inputs or says what to name.

#include "bag_fixtures.h"

#include "mlmap/bag/bag_frame_source.h"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using mlmap::Transform;
using mlmap::bag::BagFrameSource;
using mlmap::bag::BagFrameSourceOptions;
using mlmap::bag::BagInputs;
using mlmap::bag::openBag;
using mlmap::bag::testing::expected;
using mlmap::bag::testing::fixture;

/// T_W_B of the generator's vehicle at t seconds after t0_s: (t, 2t, 0.5), yaw 0.1 t.
Transform bodyPose(double t) {
  Transform T = Transform::Identity();
  T.translation() = Eigen::Vector3d(t, 2.0 * t, 0.5);
  T.linear() = Eigen::AngleAxisd(0.1 * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

Transform transformOf(const nlohmann::json& j) {
  const auto& t = j["translation"];
  const auto& q = j["rotation"];
  Transform T = Transform::Identity();
  T.translation() = Eigen::Vector3d(t["x"], t["y"], t["z"]);
  T.linear() = Eigen::Quaterniond(q["w"], q["x"], q["y"], q["z"]).normalized().toRotationMatrix();
  return T;
}

double secondsAfterT0(const std::string& stamp_ns) {
  const double t0_s = expected()["t0_s"];
  return static_cast<double>(std::stoull(stamp_ns) -
                             static_cast<std::uint64_t>(t0_s) * 1000000000ULL) *
         1e-9;
}

void expectNear(const Transform& a, const Transform& b, double tolerance) {
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), tolerance) << a.matrix() << "\n---\n"
                                                                        << b.matrix();
}

/// Every frame of `source` is the generator's cloud with its pose and the LiDAR's extrinsic.
void expectGeneratedClouds(const BagFrameSource& source) {
  const auto& clouds = expected()["clouds"];
  ASSERT_EQ(source.size(), clouds.size());
  for (std::size_t i = 0; i < source.size(); ++i) {
    SCOPED_TRACE(i);
    mlmap::datasets::SourceFrameInfo info;
    const auto frame = std::get<mlmap::PointCloudFrame>(source.read(i, &info));
    const double t = secondsAfterT0(clouds[i]["stamp_ns"]);
    EXPECT_NEAR(frame.stamp_s - static_cast<double>(expected()["t0_s"]), t, 1e-6);
    expectNear(frame.T_W_B, bodyPose(t), 1e-6);
    expectNear(frame.T_B_S, transformOf(expected()["T_B_lidar"]), 1e-12);
    const auto& points = clouds[i]["points"];
    ASSERT_EQ(frame.points_S.size(), points.size());
    EXPECT_EQ(info.points_in_file, points.size());
    for (std::size_t k = 0; k < points.size(); ++k) {
      EXPECT_EQ(frame.points_S[k], Eigen::Vector3f(points[k][0], points[k][1], points[k][2])) << k;
    }
  }
}

TEST(BagFrameSource, CloudsWithPosesFromEveryStorage) {
  for (const char* name : {"clouds_zstd.mcap", "clouds_noindex.mcap", "clouds_folder", "clouds.db3",
                           "clouds_db3_folder"}) {
    SCOPED_TRACE(name);
    const BagFrameSource source(openBag(fixture(name)), BagFrameSourceOptions{});
    EXPECT_EQ(source.inputs().cloud_topics, std::vector<std::string>{"/points"});
    EXPECT_EQ(source.inputs().pose_topic, "/pose");
    EXPECT_EQ(source.poseCount(), 9U);
    EXPECT_EQ(source.unpairedCount(), 0U);
    expectGeneratedClouds(source);
  }
}

/// Every frame of `source` is the generator's depth image with the camera and its extrinsic.
void expectGeneratedDepth(const BagFrameSource& source, bool millimetres) {
  const auto& depth = expected()["depth"];
  const auto& camera = expected()["camera"];
  ASSERT_EQ(source.size(), depth.size());
  for (std::size_t i = 0; i < source.size(); ++i) {
    SCOPED_TRACE(i);
    const auto frame = std::get<mlmap::DepthFrame>(source.read(i));
    const double t = secondsAfterT0(depth[i]["stamp_ns"]);
    expectNear(frame.T_W_B, bodyPose(t), 1e-6);
    expectNear(frame.T_B_S, transformOf(expected()["T_B_camera"]), 1e-12);
    EXPECT_EQ(frame.intrinsics.width, camera["width"]);
    EXPECT_EQ(frame.intrinsics.height, camera["height"]);
    EXPECT_EQ(frame.intrinsics.fx, camera["fx"]);
    EXPECT_EQ(frame.intrinsics.cy, camera["cy"]);
    const std::vector<int> want = depth[i]["depth_mm"];
    if (millimetres) {
      ASSERT_EQ(frame.depth_mm.size(), want.size());
      for (std::size_t k = 0; k < want.size(); ++k) EXPECT_EQ(frame.depth_mm[k], want[k]) << k;
    } else {
      ASSERT_EQ(frame.depth_m.size(), want.size());
      for (std::size_t k = 0; k < want.size(); ++k) {
        EXPECT_EQ(frame.depth_m[k], static_cast<float>(want[k] / 1000.0)) << k;
      }
    }
  }
}

TEST(BagFrameSource, DepthImagesWithCameraInfoAndOdometry) {
  for (const char* name : {"depth_lz4.mcap", "depth.db3"}) {
    SCOPED_TRACE(name);
    const BagFrameSource source(openBag(fixture(name)), BagFrameSourceOptions{});
    EXPECT_EQ(source.inputs().depth_topic, "/camera/depth/image_rect_raw");
    EXPECT_EQ(source.inputs().camera_info_topic, "/camera/depth/camera_info");
    EXPECT_EQ(source.inputs().pose_topic, "/odom");
    expectGeneratedDepth(source, true);
  }
}

TEST(BagFrameSource, DepthInMetresFromAnUnchunkedBag) {
  const BagFrameSource source(openBag(fixture("depth32_unchunked.mcap")), BagFrameSourceOptions{});
  EXPECT_EQ(source.inputs().pose_topic, "/pose");
  expectGeneratedDepth(source, false);
}

TEST(BagFrameSource, PosesFromTfWithTheNamedCloudTopic) {
  BagFrameSourceOptions options;
  options.inputs.cloud_topics = {"/points"};
  options.world_frame = "world";
  const BagFrameSource source(openBag(fixture("tf_unchunked.mcap")), options);
  EXPECT_TRUE(source.inputs().pose_from_tf);
  EXPECT_NE(source.describe().find("/tf world -> base_link"), std::string::npos);
  expectGeneratedClouds(source);
}

TEST(BagFrameSource, PosesThroughATfChain) {
  BagFrameSourceOptions options;
  options.world_frame = "world";
  const BagFrameSource source(openBag(fixture("tf_chain.mcap")), options);
  EXPECT_TRUE(source.inputs().pose_from_tf);
  EXPECT_EQ(source.poseCount(), 9U);  // at the stamps of odom -> base_link
  const auto& clouds = expected()["clouds"];
  ASSERT_EQ(source.size(), clouds.size());
  const Transform T_W_O = transformOf(expected()["T_world_odom"]);
  for (std::size_t i = 0; i < source.size(); ++i) {
    const auto frame = std::get<mlmap::PointCloudFrame>(source.read(i));
    expectNear(frame.T_W_B, T_W_O * bodyPose(secondsAfterT0(clouds[i]["stamp_ns"])), 1e-6);
    expectNear(frame.T_B_S, transformOf(expected()["T_B_lidar"]), 1e-12);
  }
  // From odom, the chain is one edge; from a frame not in the tree, the error shows the chain.
  options.world_frame = "odom";
  const BagFrameSource from_odom(openBag(fixture("tf_chain.mcap")), options);
  expectNear(std::get<mlmap::PointCloudFrame>(from_odom.read(0)).T_W_B,
             bodyPose(secondsAfterT0(clouds[0]["stamp_ns"])), 1e-6);
  options.world_frame = "map";
  try {
    const BagFrameSource from_map(openBag(fixture("tf_chain.mcap")), options);
    ADD_FAILURE() << "no error without a path to map";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no /tf path from 'map' to the body frame 'base_link' "
                                         "(found base_link <- odom <- world with no parent)"),
              std::string::npos)
        << e.what();
  }
}

/// The message of the std::runtime_error `make` throws ("" when it throws none).
template <typename Make>
std::string errorOf(Make&& make) {
  try {
    make();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

// Static edges above a dynamic one are composed in order (they are multiplied into one).
TEST(BagFrameSource, StaticEdgesAboveTheDynamicOneComposeInOrder) {
  BagFrameSourceOptions options;
  options.world_frame = "world";
  const BagFrameSource source(openBag(fixture("tf_static_chain.mcap")), options);
  const auto& clouds = expected()["clouds"];
  ASSERT_EQ(source.size(), clouds.size());
  const Transform T_W_O =
      transformOf(expected()["T_world_w1"]) * transformOf(expected()["T_w1_odom"]);
  for (std::size_t i = 0; i < source.size(); ++i) {
    expectNear(std::get<mlmap::PointCloudFrame>(source.read(i)).T_W_B,
               T_W_O * bodyPose(secondsAfterT0(clouds[i]["stamp_ns"])), 1e-6);
  }
}

// A cycle in the transforms, dynamic or static, is refused with the loop it found, at once (the
// walk up the tree used to go round a dynamic cycle for ever, and to compose a static one).
TEST(BagFrameSource, TfCyclesAreRefusedWithTheLoop) {
  for (const char* bag : {"tf_cycle.mcap", "tf_static_cycle.mcap"}) {
    for (const char* world : {"world", "map"}) {
      BagFrameSourceOptions options;
      options.world_frame = world;
      const std::string error = [&] {
        try {
          const BagFrameSource source(openBag(fixture(bag)), options);
          ADD_FAILURE() << bag << ": poses were taken from a cycle";
        } catch (const std::runtime_error& e) {
          return std::string(e.what());
        }
        return std::string();
      }();
      EXPECT_NE(error.find("loop back to"), std::string::npos) << bag << ": " << error;
      EXPECT_NE(error.find("cycle"), std::string::npos) << bag << ": " << error;
    }
  }
}

TEST(BagFrameSource, AmbiguousInputsNameTheOptionAndListTheTopics) {
  const std::shared_ptr<const mlmap::bag::BagReader> bag = openBag(fixture("tf_unchunked.mcap"));
  const std::string clouds = errorOf([&] { (void)autoSelect(*bag, BagInputs{}, "world"); });
  EXPECT_NE(clouds.find("2 PointCloud2 topics (/points, /points_aux)"), std::string::npos)
      << clouds;
  EXPECT_NE(clouds.find("cloud_topics"), std::string::npos) << clouds;
  EXPECT_NE(clouds.find("/tf (tf2_msgs/msg/TFMessage, 9 messages)"), std::string::npos) << clouds;

  BagInputs named;
  named.cloud_topics = {"/points"};
  const std::string frames = errorOf([&] { (void)autoSelect(*bag, named, ""); });
  EXPECT_NE(frames.find("world_frame"), std::string::npos) << frames;

  named.cloud_topics = {"/tf"};
  const std::string type = errorOf([&] { (void)autoSelect(*bag, named, "world"); });
  EXPECT_NE(type.find("'/tf' is a tf2_msgs/msg/TFMessage, not a sensor_msgs/msg/PointCloud2"),
            std::string::npos)
      << type;
}

TEST(BagFrameSource, MissingExtrinsicSaysWhatToSet) {
  BagFrameSourceOptions options;
  options.body_frame = "imu";
  const std::string error =
      errorOf([&] { BagFrameSource(openBag(fixture("clouds_zstd.mcap")), options); });
  EXPECT_NE(error.find("no /tf_static path from the body frame 'imu' to the sensor frame 'lidar'"),
            std::string::npos)
      << error;
  options.T_B_S = Transform::Identity();
  const BagFrameSource source(openBag(fixture("clouds_zstd.mcap")), options);
  expectNear(std::get<mlmap::PointCloudFrame>(source.read(0)).T_B_S, Transform::Identity(), 1e-15);
}

TEST(BagFrameSource, SeveralCloudTopicsAndFramesWithoutAPose) {
  BagFrameSourceOptions options;
  options.inputs.cloud_topics = {"/points", "/points_aux"};
  options.world_frame = "world";
  const BagFrameSource source(openBag(fixture("tf_unchunked.mcap")), options);
  // /points_aux: one cloud at 1.05 s (between poses), one at 1.5 s (after the last pose, 1.35 s).
  ASSERT_EQ(source.size(), 5U);
  EXPECT_EQ(source.unpairedCount(), 1U);
  ASSERT_EQ(source.warnings().size(), 1U);
  EXPECT_NE(source.warnings()[0].find("1 of 6 input frames have no pose"), std::string::npos);
  mlmap::datasets::SourceFrameInfo info;
  const auto aux = std::get<mlmap::PointCloudFrame>(source.read(1, &info));
  EXPECT_EQ(info.name, "/points_aux@1700000001.050000");
  expectNear(aux.T_W_B, bodyPose(1.05), 1e-6);
  EXPECT_THROW((void)source.read(5), std::out_of_range);
}

}  // namespace
