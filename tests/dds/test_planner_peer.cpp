// The planner peer on DDS (issue 45): the latest frame's points reach its planner (a cloud or a
// depth image with the pose at its stamp makes it plan at once), and malformed or unplaceable
// frames are counted;
// and it is a node of the ROS 2 graph: ros_discovery_info lists it with exactly its endpoints,
// its log lines reach /rosout. Each test talks to the peer from a participant of its own over
// loopback; domains 229 and 226.

#include "mlmap/dds/graph/ros_graph.h"
#include "mlmap/dds/nav/planner_peer.h"
#include "mlmap/dds/sim/sensor_messages.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include "dds_test_support.h"
#include "ros_graph_observer.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "rcl_interfaces/msg/Log_PubSubTypes.h"
#include "rmw_dds_common/msg/ParticipantEntitiesInfo_PubSubTypes.h"
#include "sensor_msgs/msg/CameraInfo_PubSubTypes.h"
#include "sensor_msgs/msg/Image_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
namespace rmw = ::rmw_dds_common::msg::dds_;
namespace rcl = ::rcl_interfaces::msg::dds_;
using test_support::gidsOf;
using test_support::localhostConfig;
using test_support::Observer;
using test_support::Received;
using test_support::waitFor;

/// A depth camera's usual mounting: optical z forward (body x), x right (body -y), y down.
Transform opticalMount() {
  Transform T_B_S = Transform::Identity();
  T_B_S.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return T_B_S;
}

/// A peer with a goal 8 m ahead of the origin at 1.5 m, reading clouds on "cloud" and depth
/// images on "depth" (with "camera_info"), the camera mounted as opticalMount().
PlannerPeerConfig peerConfig(int domain_id) {
  PlannerPeerConfig config;
  config.dds = localhostConfig(domain_id);
  config.goal_W = Eigen::Vector3d(8.0, 0.0, 1.5);
  config.cloud_topic = "cloud";
  config.depth_image_topic = "depth";
  config.camera_info_topic = "camera_info";
  config.T_B_S = opticalMount();
  return config;
}

/// The robot's side: a pose and a cloud writer, as a driver and an odometry publish them.
struct Robot {
  explicit Robot(int domain_id) {
    participant = createParticipant(localhostConfig(domain_id), "robot");
    fdds::Publisher* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    pose = createWriter<geometry_msgs::PoseStamped_PubSubType>(publisher, "rt/pose",
                                                               reliableWriterQos());
    cloud = createWriter<sensor_msgs::PointCloud2_PubSubType>(publisher, "rt/cloud",
                                                              reliableWriterQos());
    depth = createWriter<sensor_msgs::Image_PubSubType>(publisher, "rt/depth", reliableWriterQos());
    info = createWriter<sensor_msgs::CameraInfo_PubSubType>(publisher, "rt/camera_info",
                                                            reliableWriterQos());
  }
  void writePose(double stamp_s, const Eigen::Vector3d& p_W) {
    Transform T_W_B = Transform::Identity();
    T_W_B.translation() = p_W;
    geometry_msgs::PoseStamped_ msg = toPoseStamped(T_W_B, stamp_s, "map");
    pose->write(&msg);
  }
  ParticipantPtr participant;
  fdds::DataWriter* pose = nullptr;
  fdds::DataWriter* cloud = nullptr;
  fdds::DataWriter* depth = nullptr;
  fdds::DataWriter* info = nullptr;
};

// A cloud stamped as a pose the peer has gives its points near the flight height to the
// Navigator, which plans at once on them (a Path without a new map or pose). A cloud that does
// not decode is rejected and counted, one without a pose at its stamp counted and not used. A
// depth image gives its points the same way once a CameraInfo came (before, it is rejected).
TEST(PlannerPeer, TheLatestFramesPointsReachThePlannerAndBadFramesAreCounted) {
  constexpr int kDomain = 229;
  PlannerPeer peer(peerConfig(kDomain));
  Robot robot(kDomain);
  ASSERT_TRUE(waitFor([&] {
    return test_support::writerMatched(robot.pose) && test_support::writerMatched(robot.cloud) &&
           test_support::writerMatched(robot.depth) && test_support::writerMatched(robot.info);
  })) << "the peer's readers were not found";

  const double t0_s = 1.8e9;  // a ROS epoch stamp, as over DDS
  robot.writePose(t0_s, Eigen::Vector3d(0.0, 0.0, 1.5));
  ASSERT_TRUE(waitFor([&] { return peer.stats().paths >= 1 && peer.stats().setpoints >= 1; }))
      << "the peer did not plan on its first pose";
  const std::uint64_t paths_before = peer.stats().paths;

  // A wall of points 2 m ahead at flight height, and points far below it, which are not
  // obstacles at that height; in the sensor frame.
  std::vector<Eigen::Vector3f> points_S;
  const Transform T_S_B = opticalMount().inverse();
  for (int i = -5; i <= 5; ++i) {
    const double y_B = 0.1 * i + 0.05;
    points_S.push_back((T_S_B * Eigen::Vector3d(2.0, y_B, 0.0)).cast<float>());
    points_S.push_back((T_S_B * Eigen::Vector3d(2.0, y_B, -1.4)).cast<float>());
  }
  sensor_msgs::PointCloud2_ cloud =
      encodePointCloud2(points_S, nullptr, t0_s, "camera_depth_optical_frame");
  robot.cloud->write(&cloud);
  ASSERT_TRUE(waitFor([&] { return peer.stats().recent_obstacle_frames == 1; }))
      << "the cloud's points did not reach the planner";
  EXPECT_EQ(peer.stats().recent_obstacles, 11u);  // the wall, one per 0.1 m cell
  EXPECT_TRUE(waitFor([&] { return peer.stats().paths > paths_before; }))
      << "the frame's points did not make the planner plan at once";

  // Malformed: data shorter than width * point_step says.
  sensor_msgs::PointCloud2_ bad = cloud;
  bad.data_().resize(bad.data_().size() / 2);
  robot.cloud->write(&bad);
  EXPECT_TRUE(waitFor([&] { return peer.stats().rejected == 1; }))
      << "a malformed cloud was not rejected";
  // Older than every pose the peer has: no pose to place it with.
  sensor_msgs::PointCloud2_ old = encodePointCloud2(points_S, nullptr, t0_s - 10.0, "camera");
  robot.cloud->write(&old);
  EXPECT_TRUE(waitFor([&] { return peer.stats().frames_without_pose == 1; }))
      << "a cloud without a pose was not counted";
  PlannerPeerStats s = peer.stats();
  EXPECT_EQ(s.clouds, 3u);
  EXPECT_EQ(s.recent_obstacle_frames, 1u);
  EXPECT_NE(s.last_rejection.find("PointCloud2"), std::string::npos) << s.last_rejection;

  // A 16 x 12 depth image of a wall 2 m ahead, 0.25 m between pixels there: 4 rows within 0.6 m
  // of the flight height, 16 pixels a row, each in a cell of its own.
  DepthFrame frame;
  frame.intrinsics = {8.0, 8.0, 7.5, 5.5, 16, 12};
  frame.encoding = DepthEncoding::kFloat32Metres;
  frame.depth_m.assign(16 * 12, 2.0F);
  sensor_msgs::Image_ image = depthImage(frame, t0_s, "camera_depth_optical_frame");
  robot.depth->write(&image);
  ASSERT_TRUE(waitFor([&] { return peer.stats().rejected == 2; }))
      << "a depth image before any CameraInfo was not rejected";
  EXPECT_NE(peer.stats().last_rejection.find("CameraInfo"), std::string::npos);
  sensor_msgs::CameraInfo_ info = cameraInfo(frame.intrinsics, t0_s, "camera_depth_optical_frame");
  robot.info->write(&info);
  // The CameraInfo and the image come on two topics, in either order: the image again until
  // one arrives after it.
  bool placed = false;
  for (int attempt = 0; attempt < 10 && !placed; ++attempt) {
    robot.depth->write(&image);
    placed = waitFor([&] { return peer.stats().recent_obstacle_frames >= 2; },
                     std::chrono::milliseconds(1000));
  }
  ASSERT_TRUE(placed) << "the depth image's points did not reach the planner";
  s = peer.stats();
  EXPECT_GE(s.depth_images, 2u);
  EXPECT_GT(s.recent_obstacles, 11u);
  EXPECT_EQ((s.recent_obstacles - 11u) % 64u, 0u) << s.recent_obstacles;
}

// ros_discovery_info, read by a reader of the test's own as `ros2 node list` reads it: the
// peer's participant GID, one node (its name, the namespace from dds.ns) and exactly the GIDs of
// its readers and writers as discovery reports them; its start-up line on /rosout under the
// node's logger name.
TEST(PlannerPeer, IsANodeOfTheRosGraphWithExactlyItsEndpoints) {
  constexpr int kDomain = 226;
  Received<rmw::ParticipantEntitiesInfo_> infos;  // outlive the observer's readers
  Received<rcl::Log_> lines;
  Observer observer(kDomain, "mlmap_planner_peer");
  ASSERT_TRUE(observer.participant);
  createReader<rmw::ParticipantEntitiesInfo_PubSubType>(
      observer.subscriber, "ros_discovery_info", reliableReaderQos(true, 1), &infos.listener);
  createReader<rcl::Log_PubSubType>(observer.subscriber, "rt/rosout", reliableReaderQos(true, 1000),
                                    &lines.listener);
  PlannerPeerConfig config = peerConfig(kDomain);
  config.dds.ns = "uav1";
  config.node_name = "planner_a";
  PlannerPeer peer(config);

  bool agreed = false;
  const std::optional<rmw::ParticipantEntitiesInfo_> info =
      agreeingDiscoveryInfo(infos, observer.log, &agreed);
  ASSERT_TRUE(info) << "no ros_discovery_info sample arrived";
  ASSERT_TRUE(observer.log.participant()) << "the peer's participant was not discovered";
  EXPECT_TRUE(agreed) << "ros_discovery_info never listed exactly the discovered endpoints";
  EXPECT_EQ(info->gid_().data_(), toGid(*observer.log.participant()));
  ASSERT_EQ(info->node_entities_info_seq_().size(), 1u);
  const rmw::NodeEntitiesInfo_& n = info->node_entities_info_seq_()[0];
  EXPECT_EQ(n.node_name_().to_string(), "planner_a");
  EXPECT_EQ(n.node_namespace_().to_string(), "/uav1");
  for (const char* topic : {"rt/uav1/mlmap/plan", "rt/uav1/mlmap/setpoint", "rt/rosout"}) {
    const std::optional<test_support::Endpoint> w = observer.log.on(topic, true);
    ASSERT_TRUE(w) << topic;
    EXPECT_EQ(gidsOf(n.writer_gid_seq_()).count(w->gid), 1u) << topic;
  }
  for (const char* topic : {"rt/uav1/mlmap/grid", "rt/uav1/mlmap/esdf/block", "rt/uav1/pose",
                            "rt/uav1/goal_pose", "rt/uav1/cloud"}) {
    const std::optional<test_support::Endpoint> r = observer.log.on(topic, false);
    ASSERT_TRUE(r) << topic;
    EXPECT_EQ(gidsOf(n.reader_gid_seq_()).count(r->gid), 1u) << topic;
  }
  EXPECT_EQ(n.reader_gid_seq_().size(), 7u);  // and the depth image and its CameraInfo
  EXPECT_EQ(n.writer_gid_seq_().size(), 3u);

  auto line = [&](const std::string& part) -> std::optional<rcl::Log_> {
    for (const rcl::Log_& l : lines.all()) {
      if (l.msg_().find(part) != std::string::npos) return l;
    }
    return std::nullopt;
  };
  ASSERT_TRUE(waitFor([&] { return line("planning on").has_value(); }))
      << "the peer's start-up line did not reach /rosout";
  EXPECT_EQ(line("planning on")->name_(), "uav1.planner_a");
  EXPECT_EQ(line("planning on")->level_(), 20);
}

TEST(PlannerPeer, RefusesANodeNameRosCannotShowAndADepthTopicWithoutItsCameraInfo) {
  PlannerPeerConfig config = peerConfig(226);
  config.node_name = "mlmap planner";
  EXPECT_THROW(PlannerPeer peer(config), std::invalid_argument);
  config = peerConfig(226);
  config.camera_info_topic = "";
  EXPECT_THROW(PlannerPeer peer(config), std::invalid_argument);
}

}  // namespace
}  // namespace mlmap::dds
