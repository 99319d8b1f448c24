// The node in a REP-105 TF tree: what it publishes on /tf and /tf_static in each tf_mode (a
// tf2-style tree check: every child has exactly one parent, the mode's edges and nothing else),
// map -> odom against T_W_B and the robot's odom -> base_link, sensor extrinsics resolved through
// a chain of /tf_static transforms, and the frame checks' counters. Participants on loopback only
// (DiscoveryRange::kLocalhost), domains 230..232 (the highest valid domain is 232).
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/node/mapping_node.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include "dds_test_support.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "mlmap_msgs/msg/Status_PubSubTypes.h"
#include "nav_msgs/msg/Odometry_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
using test_support::localhostConfig;
using test_support::waitFor;
using TfMessage = ::tf2_msgs::msg::dds_::TFMessage_;
using TfType = ::tf2_msgs::msg::dds_::TFMessage_PubSubType;

/// One transform as a tf2 listener keeps it.
struct Edge {
  std::string parent, child;
  double stamp_s;
  Transform T_parent_child;
  bool is_static;  // cppcheck-suppress unusedStructMember ; kept with the edge for failure output
};

/// Records every transform on rt/tf and rt/tf_static (absolute, as tf2 listens) and the node's
/// latest status, and has a reader on `<ns>/tf` to show that nothing is published there.
class TfRecorder {
 public:
  explicit TfRecorder(int domain_id, const std::string& ns = "")
      : participant_(createParticipant(localhostConfig(domain_id), "tf_recorder")),
        readers_(participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT),
                 [](const std::string& what) { ADD_FAILURE() << what; }) {
    tf_ = readers_.add<TfType>(ddsTopicName("", "tf"), reliableReaderQos(false, 100),
                               [this](TfMessage&& m) { take(m, false); });
    tf_static_ = readers_.add<TfType>(ddsTopicName("", "tf_static"), reliableReaderQos(true, 100),
                                      [this](TfMessage&& m) { take(m, true); });
    if (!ns.empty()) {
      namespaced_ = readers_.add<TfType>(ddsTopicName(ns, "tf"), reliableReaderQos(false, 100),
                                         [](TfMessage&&) {});
    }
    readers_.add<mlmap_msgs::Status_PubSubType>(ddsTopicName(ns, TopicNames{}.status),
                                                reliableReaderQos(false, 10),
                                                [this](mlmap_msgs::Status_&& status) {
                                                  std::lock_guard<std::mutex> lock(mutex_);
                                                  status_ = std::move(status);
                                                });
  }

  /// The node's latest mlmap_msgs/Status (all zero before the first).
  [[nodiscard]] mlmap_msgs::Status_ status() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return status_;
  }

  /// Publishers rt/tf's reader matches now.
  [[nodiscard]] int tfWriters() const { return matched(tf_); }
  [[nodiscard]] int namespacedTfWriters() const { return namespaced_ ? matched(namespaced_) : 0; }

  [[nodiscard]] std::vector<Edge> edges() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return edges_;
  }
  /// A transform parent -> child stamped `stamp_s` was received.
  [[nodiscard]] bool has(const std::string& parent, const std::string& child,
                         double stamp_s) const {
    for (const Edge& e : edges(parent, child)) {
      if (std::abs(e.stamp_s - stamp_s) < 1e-6) return true;
    }
    return false;
  }
  /// The transforms parent -> child received so far.
  [[nodiscard]] std::vector<Edge> edges(const std::string& parent, const std::string& child) const {
    std::vector<Edge> out;
    for (const Edge& e : edges()) {
      if (e.parent == parent && e.child == child) out.push_back(e);
    }
    return out;
  }

 private:
  static int matched(fdds::DataReader* reader) {
    fdds::SubscriptionMatchedStatus status;
    reader->get_subscription_matched_status(status);
    return status.current_count;
  }
  void take(const TfMessage& msg, bool is_static) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& t : msg.transforms_()) {
      Edge e{t.header_().frame_id_(), t.child_frame_id_(), 0.0, Transform::Identity(), is_static};
      EXPECT_TRUE(decodeTransform(t, &e.stamp_s, &e.T_parent_child).ok())
          << e.parent << " -> " << e.child;
      edges_.push_back(e);
    }
  }

  ParticipantPtr participant_;
  TakeReaders readers_;
  fdds::DataReader* tf_ = nullptr;
  fdds::DataReader* tf_static_ = nullptr;
  fdds::DataReader* namespaced_ = nullptr;
  mutable std::mutex mutex_;
  std::vector<Edge> edges_;
  mlmap_msgs::Status_ status_;
};

/// What a recorder received, for a failure's message.
std::string describe(const TfRecorder& recorder) {
  std::string out = std::to_string(recorder.tfWriters()) + " tf writers;";
  for (const Edge& e : recorder.edges()) {
    out += " " + e.parent + "->" + e.child + "@" + std::to_string(e.stamp_s);
  }
  return out;
}

/// The tf2 rule: each child has exactly one parent. Returns the set of (parent, child) edges and
/// adds a failure for every child with more than one parent.
std::set<std::pair<std::string, std::string>> treeEdges(const std::vector<Edge>& edges) {
  std::map<std::string, std::set<std::string>> parents;
  std::set<std::pair<std::string, std::string>> out;
  for (const Edge& e : edges) {
    parents[e.child].insert(e.parent);
    out.insert({e.parent, e.child});
  }
  for (const auto& [child, of] : parents) {
    EXPECT_EQ(of.size(), 1u) << "frame " << child << " has " << of.size() << " parents";
  }
  return out;
}

Transform pose(double x_m, double yaw_rad, double z_m = 1.0) {
  Transform T = Transform::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x_m, 0.0, z_m);
  return T;
}

/// The robot's side: pose or odometry, clouds of a wall 3 m ahead, and its own /tf and /tf_static
/// (an EKF's odom -> base_link, robot_state_publisher's and a camera driver's static frames).
class Robot {
 public:
  Robot(int domain_id, const NodeConfig& node)
      : node_(node), participant_(createParticipant(localhostConfig(domain_id), "robot")) {
    fdds::Publisher* publisher = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    const DdsConfig& d = node.dds;
    cloud_ = createWriter<sensor_msgs::PointCloud2_PubSubType>(
        publisher, ddsTopicName(d.ns, d.topics.cloud), reliableWriterQos(50));
    if (!d.topics.pose.empty()) {
      pose_ = createWriter<geometry_msgs::PoseStamped_PubSubType>(
          publisher, ddsTopicName(d.ns, d.topics.pose), reliableWriterQos(50));
    }
    if (!d.topics.odometry.empty()) {
      odometry_ = createWriter<nav_msgs::Odometry_PubSubType>(
          publisher, ddsTopicName(d.ns, d.topics.odometry), reliableWriterQos(50));
    }
    tf_ = createWriter<TfType>(publisher, ddsTopicName("", "tf"), reliableWriterQos(100));
    tf_static_ = createWriter<TfType>(publisher, ddsTopicName("", "tf_static"), latchedWriterQos());
  }

  /// Every input writer matched the readers of `nodes` nodes, and `node`'s readers matched every
  /// input writer: the node's inputs are BEST_EFFORT, so a sample sent before both sides know
  /// each other is lost.
  bool matched(const MappingNode& node, int nodes = 1) const {
    const std::uint64_t inputs = (pose_ ? 1 : 0) + (odometry_ ? 1 : 0) + 1;
    return waitFor([&] {
      for (fdds::DataWriter* w : {cloud_, pose_, odometry_}) {
        if (w == nullptr) continue;
        fdds::PublicationMatchedStatus status;
        w->get_publication_matched_status(status);
        if (status.current_count != nodes) return false;
      }
      return node.counters().publishers_matched == inputs;
    });
  }

  /// Subscribers the robot's rt/tf writer matches now (a tf2 listener, a node in map_odom).
  [[nodiscard]] int tfReaders() const {
    fdds::PublicationMatchedStatus status;
    tf_->get_publication_matched_status(status);
    return status.current_count;
  }

  /// T_W_B at `stamp_s` (both sides of it, so that the pairing finds it), as a PoseStamped or an
  /// Odometry whose child frame is `child_frame`.
  void pose(double stamp_s, const Transform& T_W_B, const std::string& child_frame = "") {
    for (const double t_s : {stamp_s - 0.01, stamp_s + 0.01}) {
      geometry_msgs::PoseStamped_ p = toPoseStamped(T_W_B, t_s, node_.dds.world_frame);
      if (pose_ != nullptr) {
        ASSERT_TRUE(pose_->write(&p));
      } else {
        nav_msgs::Odometry_ msg;
        msg.header_(p.header_());
        msg.child_frame_id_(child_frame);
        msg.pose_().pose_(p.pose_());
        ASSERT_TRUE(odometry_->write(&msg));
      }
    }
  }
  /// The robot's odometry: odom -> base_link at `stamp_s` (both sides of it).
  void odom(double stamp_s, const Transform& T_O_B, const std::string& odom_frame,
            const std::string& body_frame) {
    for (const double t_s : {stamp_s - 0.01, stamp_s + 0.01}) {
      TfMessage msg;
      msg.transforms_().push_back(toTransformStamped(T_O_B, t_s, odom_frame, body_frame));
      ASSERT_TRUE(tf_->write(&msg));
    }
  }
  /// Latched static transforms, as robot_state_publisher and a camera driver publish them.
  void staticTransforms(const std::vector<Edge>& edges) {
    TfMessage msg;
    for (const Edge& e : edges) {
      msg.transforms_().push_back(toTransformStamped(e.T_parent_child, 0.0, e.parent, e.child));
    }
    ASSERT_TRUE(tf_static_->write(&msg));
  }
  /// The wall 3 m ahead of the body at `T_W_B`, in the sensor frame of the node's config, stamped
  /// `stamp_s`, with `frame_id`. Its points sit between voxel borders.
  void cloud(double stamp_s, const Transform& T_W_B, const std::string& frame_id) {
    const Transform T_S_W = (T_W_B * node_.map.sensor.T_B_S()).inverse();
    std::vector<Eigen::Vector3f> points_S;
    for (double y = -0.975; y <= 1.0; y += 0.05) {
      for (double z = 0.525; z <= 1.5; z += 0.05) {
        points_S.push_back((T_S_W * (T_W_B * Eigen::Vector3d(3.03, y, z - 1.0))).cast<float>());
      }
    }
    sensor_msgs::PointCloud2_ msg = encodePointCloud2(points_S, nullptr, stamp_s, frame_id);
    ASSERT_TRUE(cloud_->write(&msg));
  }

 private:
  NodeConfig node_;
  ParticipantPtr participant_;
  fdds::DataWriter* cloud_ = nullptr;
  fdds::DataWriter* pose_ = nullptr;
  fdds::DataWriter* odometry_ = nullptr;
  fdds::DataWriter* tf_ = nullptr;
  fdds::DataWriter* tf_static_ = nullptr;
};

NodeConfig nodeConfig(int domain_id) {
  NodeConfig config;
  config.dds = localhostConfig(domain_id);
  return config;
}

/// Most frames a test sends until the node's first transform reaches its recorder.
constexpr int kMaxFrames = 40;

bool mapped(const MappingNode& node, std::uint64_t frames) {
  return waitFor([&] { return node.engineStats().frames_mapped == frames; });
}

/// The node's input counters, for a failure's message.
std::string describe(const MappingNode& node) {
  const NodeCounters c = node.counters();
  return "clouds " + std::to_string(c.clouds_received) + ", poses " +
         std::to_string(c.poses_received) + ", submitted " + std::to_string(c.frames_submitted) +
         ", without pose " + std::to_string(c.frames_without_pose) + ", engine rejected " +
         std::to_string(c.frames_engine_rejected) + ", unresolved frame_id " +
         std::to_string(c.frames_unresolved_frame_id) + ", mapped " +
         std::to_string(node.engineStats().frames_mapped);
}

bool counted(const MappingNode& node, std::uint64_t NodeCounters::*counter, std::uint64_t value) {
  return waitFor([&] { return node.counters().*counter == value; });
}

/// A case of the tree check: the node's configuration, what the robot publishes itself, and the
/// edges the whole tree must have.
struct TreeCase {
  const char* name;
  std::string tf_mode;
  bool publish_sensor_tf;
  bool odometry_input;  ///< pose from nav_msgs/Odometry instead of PoseStamped
  bool robot_publishes_odom;
  std::set<std::pair<std::string, std::string>> expected;
  std::string ns;              ///< dds.ns and dds.frame_prefix both
  std::string odometry_child;  ///< the Odometry's child_frame_id
};

// For each mode, the node and a robot publish what they would on a real vehicle; a tf2 listener
// must see a tree (one parent per child) with exactly the mode's edges. Under a namespace, tf and
// tf_static stay absolute (rt/tf: what tf2 listens to) while the inputs keep the namespace, and
// the frames carry the vehicle's prefix. An Odometry whose child_frame_id is not the body frame
// is counted and logged, and its pose used.
TEST(TfModes, EachModePublishesItsEdgesAndEveryChildKeepsOneParent) {
  constexpr int kDomain = 230;
  const std::vector<TreeCase> cases = {
      {"world_body, sensor frame published (the simulator)",
       "world_body",
       true,
       false,
       false,
       {{"map", "base_link"}, {"base_link", "camera_depth_optical_frame"}},
       "",
       "base_link"},
      {"map_odom (a localisation over the robot's EKF)",
       "map_odom",
       false,
       false,
       true,
       {{"map", "odom"}, {"odom", "base_link"}},
       "",
       "base_link"},
      {"none (the pose source owns the TF)",
       "none",
       false,
       false,
       true,
       {{"odom", "base_link"}},
       "",
       "base_link"},
      {"auto with an odometry input: none; its child frame not the body",
       "auto",
       false,
       true,
       true,
       {{"odom", "base_link"}},
       "",
       "base_footprint"},
      {"auto with a pose input: world_body",
       "auto",
       false,
       false,
       false,
       {{"map", "base_link"}},
       "",
       "base_link"},
      {"world_body under the namespace uav1 with its frame prefix",
       "world_body",
       true,
       false,
       false,
       {{"map", "uav1/base_link"}, {"uav1/base_link", "uav1/camera_depth_optical_frame"}},
       "uav1",
       "base_link"},
  };
  for (const TreeCase& c : cases) {
    // A precaution, not a measured need: the last case's participants say goodbye before new
    // ones (which may take their freed participant ids) join the same domain in this process.
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    SCOPED_TRACE(c.name);
    NodeConfig config = nodeConfig(kDomain);
    config.dds.tf_mode = c.tf_mode;
    config.dds.publish_sensor_tf = c.publish_sensor_tf;
    config.dds.ns = c.ns;
    config.dds.frame_prefix = c.ns;
    if (c.odometry_input) {
      config.dds.topics.pose = "";
      config.dds.topics.odometry = "odom";
    }
    const FrameNames frames = resolveFrames(config.dds);
    TfRecorder recorder(kDomain, c.ns);
    std::mutex mutex;
    std::vector<std::string> lines;
    MappingNode node(config, [&](LogLevel, const std::string& line) {
      std::lock_guard<std::mutex> lock(mutex);
      lines.push_back(line);
    });
    Robot robot(kDomain, config);
    ASSERT_TRUE(robot.matched(node));
    const bool node_publishes_tf = c.tf_mode == "world_body" || c.tf_mode == "map_odom" ||
                                   (c.tf_mode == "auto" && !c.odometry_input);
    // The robot's tf writer, and the node's when it has one; the node reads the robot's in
    // map_odom.
    ASSERT_TRUE(waitFor([&] { return recorder.tfWriters() == 1 + (node_publishes_tf ? 1 : 0); }));
    ASSERT_TRUE(
        waitFor([&] { return robot.tfReaders() == 1 + (c.tf_mode == "map_odom" ? 1 : 0); }));
    // Frames until the node's transform of one arrives (at least 3): a volatile writer sends
    // nothing to a reader it has not matched yet, and the reader may know the writer before the
    // writer knows the reader.
    const std::string child = c.tf_mode == "map_odom" ? frames.odom : frames.body;
    for (int k = 0; k < kMaxFrames; ++k) {
      const double t_s = 10.0 + 0.1 * k;
      const Transform T_W_B = pose(0.1 * k, 0.05 * k);
      if (c.robot_publishes_odom) robot.odom(t_s, pose(0.1 * k, 0.0), "odom", "base_link");
      robot.pose(t_s, T_W_B, c.odometry_child);
      robot.cloud(t_s, T_W_B, frames.sensor);
      ASSERT_TRUE(mapped(node, static_cast<std::uint64_t>(k) + 1)) << describe(node);
      if (k >= 2 && (!node_publishes_tf || waitFor([&] { return recorder.has("map", child, t_s); },
                                                   std::chrono::milliseconds(500)))) {
        break;
      }
    }
    if (node_publishes_tf) {
      ASSERT_FALSE(recorder.edges("map", child).empty())
          << "no transform of the node in " << kMaxFrames << " frames: " << describe(recorder);
    }
    if (c.publish_sensor_tf) {
      ASSERT_TRUE(waitFor([&] { return !recorder.edges(frames.body, frames.sensor).empty(); }));
      const Edge mounting = recorder.edges(frames.body, frames.sensor).front();
      EXPECT_LT((mounting.T_parent_child.matrix() - config.map.sensor.T_B_S().matrix())
                    .cwiseAbs()
                    .maxCoeff(),
                1e-9);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // anything else would show
    EXPECT_EQ(treeEdges(recorder.edges()), c.expected);
    EXPECT_EQ(recorder.namespacedTfWriters(), 0) << "nothing is published on rt/<ns>/tf";
    const NodeCounters counters = node.counters();
    EXPECT_EQ(counters.tf_odom_missing, 0u);
    EXPECT_EQ(counters.frames_unexpected_frame_id, 0u) << "clouds in the (prefixed) sensor frame";
    const bool mismatch = c.odometry_input && c.odometry_child != frames.body;
    EXPECT_EQ(counters.odometry_child_frame_mismatch, mismatch ? 6u : 0u)
        << "two poses a frame, 3 frames";
    if (mismatch) {  // the status carries it too (status_hz 1)
      EXPECT_TRUE(waitFor([&] { return recorder.status().odometry_child_frame_mismatch_() == 6; }));
      EXPECT_EQ(recorder.status().version_(), 3u);
    }
    std::lock_guard<std::mutex> lock(mutex);
    int warned = 0;
    for (const std::string& line : lines) {
      warned += line.find("child_frame_id 'base_footprint', not the body frame 'base_link'") !=
                std::string::npos;
    }
    EXPECT_EQ(warned > 0, mismatch);
  }
}

// map -> odom = T_W_B * inverse(T_O_B), T_O_B the robot's odom -> base_link at the pose's stamp
// (both drift apart from frame to frame); a pose whose odometry never comes is counted and gets
// no map -> odom.
TEST(TfModes, MapOdomIsThePoseTimesTheInverseOfTheRobotsOdometryAtItsStamp) {
  constexpr int kDomain = 231;
  NodeConfig config = nodeConfig(kDomain);
  config.dds.tf_mode = "map_odom";
  TfRecorder recorder(kDomain);
  MappingNode node(config);
  Robot robot(kDomain, config);
  ASSERT_TRUE(robot.matched(node));
  ASSERT_TRUE(waitFor([&] { return recorder.tfWriters() == 2; }));
  ASSERT_TRUE(waitFor([&] { return robot.tfReaders() == 2; })) << "the recorder and the node";
  std::map<double, Transform> expected_T_W_O;
  double t_s = 20.0;
  std::uint64_t frames = 0;
  // Frames (at least 4) until the node's map -> odom of one arrives (see the tree test).
  for (int k = 0; k < kMaxFrames; ++k) {
    t_s = 20.0 + 0.1 * k;
    const Transform T_W_B = pose(0.2 * k, 0.1 * k);
    Transform T_O_B = pose(0.25 * k, 0.13 * k, 1.02);  // the odometry drifts from the map
    T_O_B.translation().y() = 0.01 * k;
    robot.odom(t_s, T_O_B, "odom", "base_link");
    robot.pose(t_s, T_W_B);
    robot.cloud(t_s, T_W_B, config.dds.sensor_frame);
    ASSERT_TRUE(mapped(node, ++frames)) << describe(node);
    expected_T_W_O[t_s] = T_W_B * T_O_B.inverse();
    if (k >= 3 &&
        waitFor([&] { return recorder.has("map", "odom", t_s); }, std::chrono::milliseconds(500))) {
      break;
    }
  }
  const std::size_t published = recorder.edges("map", "odom").size();
  ASSERT_GE(published, 1u) << describe(recorder);
  for (const Edge& e : recorder.edges("map", "odom")) {
    const auto found = expected_T_W_O.lower_bound(e.stamp_s - 1e-6);
    ASSERT_NE(found, expected_T_W_O.end()) << "map -> odom stamped " << e.stamp_s;
    EXPECT_NEAR(found->first, e.stamp_s, 1e-6);
    EXPECT_LT((e.T_parent_child.matrix() - found->second.matrix()).cwiseAbs().maxCoeff(), 1e-6)
        << "stamp " << e.stamp_s;
  }
  EXPECT_EQ(node.counters().tf_odom_missing, 0u);

  // The odometry stops: the next pose waits for it, then is counted; nothing is published for it.
  t_s += 1.0;
  robot.pose(t_s, pose(1.0, 0.4));
  robot.cloud(t_s, pose(1.0, 0.4), config.dds.sensor_frame);
  ASSERT_TRUE(mapped(node, frames + 1));
  ASSERT_TRUE(counted(node, &NodeCounters::tf_odom_missing, 1));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  // cppcheck-suppress knownConditionTrueFalse ; the recorder's reader thread could add edges
  EXPECT_EQ(recorder.edges("map", "odom").size(), published);
  EXPECT_EQ(node.counters().tf_transforms_received, 2 * frames) << "two odometry samples a frame";
}

// A realsense-style chain on /tf_static (robot_state_publisher's base_link -> camera_link, the
// driver's camera_link -> camera_depth_frame -> camera_depth_optical_frame) that composes to the
// configured extrinsic: a node taking its extrinsic from /tf_static maps exactly what a node
// with the configured one maps. A cloud in a frame no chain reaches is dropped and counted by the
// first, mapped and counted by the second.
TEST(TfExtrinsic, AChainOnTfStaticMapsAsTheConfiguredExtrinsicAndUnknownFramesAreCounted) {
  constexpr int kDomain = 232;
  NodeConfig from_tf = nodeConfig(kDomain);
  from_tf.dds.tf_mode = "none";  // two nodes on one robot: neither publishes TF
  from_tf.dds.sensor_extrinsic = "tf_static";
  NodeConfig from_config = from_tf;
  from_config.dds.sensor_extrinsic = "config";
  const Transform T_B_S = from_tf.map.sensor.T_B_S();
  Transform T_B_L = Transform::Identity();  // base_link -> camera_link
  T_B_L.translation() = Eigen::Vector3d(0.05, 0.02, 0.01);
  T_B_L.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
  Transform T_L_D = Transform::Identity();  // camera_link -> camera_depth_frame
  T_L_D.translation() = Eigen::Vector3d(0.0, -0.015, 0.0);
  const Transform T_D_S = (T_B_L * T_L_D).inverse() * T_B_S;  // -> the optical frame

  MappingNode node_tf(from_tf);
  MappingNode node_config(from_config);
  Robot robot(kDomain, from_tf);
  robot.staticTransforms({{"base_link", "camera_link", 0.0, T_B_L, true},
                          {"camera_link", "camera_depth_frame", 0.0, T_L_D, true},
                          {"camera_depth_frame", "camera_depth_optical_frame", 0.0, T_D_S, true}});
  ASSERT_TRUE(robot.matched(node_tf, 2));
  ASSERT_TRUE(robot.matched(node_config, 2));
  ASSERT_TRUE(counted(node_tf, &NodeCounters::tf_transforms_received, 3));
  EXPECT_EQ(node_config.counters().tf_transforms_received, 0u) << "it does not listen";

  for (int k = 0; k < 3; ++k) {
    const double t_s = 30.0 + 0.1 * k;
    const Transform T_W_B = pose(0.1 * k, 0.2 * k);
    robot.pose(t_s, T_W_B);
    robot.cloud(t_s, T_W_B, "camera_depth_optical_frame");
    ASSERT_TRUE(mapped(node_tf, static_cast<std::uint64_t>(k) + 1)) << describe(node_tf);
    ASSERT_TRUE(mapped(node_config, static_cast<std::uint64_t>(k) + 1)) << describe(node_config);
  }
  const auto a = node_tf.snapshot();
  const auto b = node_config.snapshot();
  ASSERT_TRUE(a && b);
  ASSERT_EQ(a->frame(), b->frame());
  EXPECT_EQ(a->window().min_index, b->window().min_index);
  EXPECT_TRUE(a->window().log_odds == b->window().log_odds)
      << "the extrinsic composed from /tf_static mapped otherwise than the configured one";
  EXPECT_GT(node_tf.engineStats().points.hit_voxels, 0u);

  // A frame no /tf_static chain reaches.
  robot.pose(31.0, pose(0.3, 0.6));
  robot.cloud(31.0, pose(0.3, 0.6), "camera_color_optical_frame");
  ASSERT_TRUE(counted(node_tf, &NodeCounters::frames_unresolved_frame_id, 1));
  ASSERT_TRUE(mapped(node_config, 4)) << "the configured extrinsic maps it all the same";
  EXPECT_EQ(node_config.counters().frames_unexpected_frame_id, 1u);
  EXPECT_EQ(node_tf.counters().frames_unexpected_frame_id, 0u);
  EXPECT_EQ(node_config.counters().frames_unresolved_frame_id, 0u);
  EXPECT_EQ(node_tf.engineStats().frames_mapped, 3u);
}

}  // namespace
}  // namespace mlmap::dds
