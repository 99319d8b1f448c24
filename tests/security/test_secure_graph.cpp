// A secured mapping node (enclave /mlmap/node of the test keystore, strategy Enforce) among
// peers of every kind, in one process, on loopback (domains 190..197):
// - /mlmap/sensor feeds it, /ground/monitor (from the YAML keys) and a peer secured by an XML
//   profile alone read its layers;
// - a participant without credentials and one with the /stranger identity (a different CA)
//   neither match nor read anything, and their clouds and poses never reach the node;
// - /ground/viewer_readonly reads the layers, but its permissions refuse it writers of clouds
//   and poses;
// - the services are called as the permissions say (domain 191).
// The node's counters show what reached it. Encryption on the wire: capture_plaintext.sh.
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/node/mapping_node.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/wire/ros_conversions.h"
#include "mlmap/dds/graph/ros_graph.h"
#include "mlmap/dds/node/ros_services.h"

#include "dds_test_support.h"
#include "scoped_env.h"
#include "secure_peer.h"
#include "service_client.h"
#include "temp_dir.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "rcl_interfaces/srv/GetParameters_PubSubTypes.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"
#include "std_srvs/srv/Trigger_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
using test_support::ScopedEnv;
using test_support::waitFor;

using test_support::kKeystore;
using test_support::kSecureTimeout;
using test_support::peerConfig;

/// The same identity as `enclave`, but secured only by a Fast DDS XML profile's properties (the
/// way a Fast DDS program without mlmap's options, or a ROS 2 XML profile, would do it).
DdsConfig xmlProfileConfig(int domain_id, const std::string& enclave) {
  const std::string dir = std::filesystem::absolute(kKeystore).string() + "/enclaves" + enclave;
  const std::string xml =
      std::filesystem::temp_directory_path().string() + "/mlmap_secure_profile.xml";
  std::ofstream out(xml);
  out << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<dds xmlns=\"http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles\"><profiles>\n"
         "<participant profile_name=\"secured_by_xml\"><rtps><propertiesPolicy><properties>\n";
  auto property = [&out](const std::string& name, const std::string& value) {
    out << "  <property><name>" << name << "</name><value>" << value << "</value></property>\n";
  };
  property("dds.sec.auth.plugin", "builtin.PKI-DH");
  property("dds.sec.auth.builtin.PKI-DH.identity_ca", "file://" + dir + "/identity_ca.cert.pem");
  property("dds.sec.auth.builtin.PKI-DH.identity_certificate", "file://" + dir + "/cert.pem");
  property("dds.sec.auth.builtin.PKI-DH.private_key", "file://" + dir + "/key.pem");
  property("dds.sec.access.plugin", "builtin.Access-Permissions");
  property("dds.sec.access.builtin.Access-Permissions.permissions_ca",
           "file://" + dir + "/permissions_ca.cert.pem");
  property("dds.sec.access.builtin.Access-Permissions.governance",
           "file://" + dir + "/governance.p7s");
  property("dds.sec.access.builtin.Access-Permissions.permissions",
           "file://" + dir + "/permissions.p7s");
  property("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
  out << "</properties></propertiesPolicy></rtps></participant>\n</profiles></dds>\n";
  DdsConfig config = peerConfig(domain_id, std::nullopt);
  config.profiles_file = xml;
  config.participant_profile = "secured_by_xml";
  return config;
}

/// A peer of the node: optional cloud and pose writers and readers of the local map and
/// tf_static.
class Peer {
 public:
  Peer(const DdsConfig& config, const std::string& name, bool writers, bool readers = true)
      : participant_(createParticipant(config, name)),
        local_listener_(
            [this](sensor_msgs::PointCloud2_&& m) {
              local_points += m.width_();
              ++local_maps;
            },
            [](const std::string&) {}),
        tf_listener_([this](::tf2_msgs::msg::dds_::TFMessage_&&) { ++tf_static; },
                     [](const std::string&) {}) {
    const TopicNames topics;
    if (readers) {
      fdds::Subscriber* subscriber = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
      local_reader_ = createReader<sensor_msgs::PointCloud2_PubSubType>(
          subscriber, ddsTopicName("", topics.local_map), reliableReaderQos(), &local_listener_);
      tf_reader_ = createReader<::tf2_msgs::msg::dds_::TFMessage_PubSubType>(
          subscriber, ddsTopicName("", "tf_static"), reliableReaderQos(true, 1), &tf_listener_);
    }
    if (writers) {
      // Straight from create_datawriter: access control may refuse the writer (nullptr).
      fdds::Publisher* publisher = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
      cloud = publisher->create_datawriter(findOrCreateTopic<sensor_msgs::PointCloud2_PubSubType>(
                                               participant_.get(), ddsTopicName("", topics.cloud)),
                                           reliableWriterQos(20));
      pose = publisher->create_datawriter(findOrCreateTopic<geometry_msgs::PoseStamped_PubSubType>(
                                              participant_.get(), ddsTopicName("", topics.pose)),
                                          reliableWriterQos(20));
    }
  }

  /// Poses around `stamp_s` of a vehicle hovering at (0, 0, 1) and a wall 3 m ahead.
  void sendFrame(double stamp_s, const Transform& T_B_S) {
    Transform T_W_B = Transform::Identity();
    T_W_B.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
    for (double t : {stamp_s - 0.01, stamp_s + 0.01}) {
      geometry_msgs::PoseStamped_ msg;
      msg.header_().stamp_(toRosTime(t));
      msg.header_().frame_id_("map");
      msg.pose_().position_().z_(1.0);
      msg.pose_().orientation_().w_(1.0);
      if (pose != nullptr) pose->write(&msg);
    }
    const Transform T_S_W = (T_W_B * T_B_S).inverse();
    std::vector<Eigen::Vector3f> wall_S;
    for (double y = -1.0; y <= 1.0; y += 0.05) {
      for (double z = 0.5; z <= 1.5; z += 0.05) {
        wall_S.push_back((T_S_W * Eigen::Vector3d(3.0, y, z)).cast<float>());
      }
    }
    sensor_msgs::PointCloud2_ cloud_msg = encodePointCloud2(wall_S, nullptr, stamp_s, "sensor");
    if (cloud != nullptr) cloud->write(&cloud_msg);
  }

  [[nodiscard]] int matchedReaders() const {
    fdds::SubscriptionMatchedStatus local, tf;
    local_reader_->get_subscription_matched_status(local);
    tf_reader_->get_subscription_matched_status(tf);
    return local.total_count + tf.total_count;
  }
  [[nodiscard]] int matchedWriters() const {
    int n = 0;
    for (fdds::DataWriter* w : {cloud, pose}) {
      fdds::PublicationMatchedStatus status;
      if (w != nullptr && w->get_publication_matched_status(status) == ReturnCode_t::RETCODE_OK) {
        n += status.total_count;
      }
    }
    return n;
  }

  std::atomic<int> local_maps{0}, tf_static{0};
  std::atomic<std::size_t> local_points{0};
  fdds::DataWriter* cloud = nullptr;
  fdds::DataWriter* pose = nullptr;

  // The readers (deleted with the participant) go before the listeners they call.
  ~Peer() { participant_.reset(); }
  Peer(const Peer&) = delete;
  Peer& operator=(const Peer&) = delete;

 private:
  ParticipantPtr participant_;
  TakeListener<sensor_msgs::PointCloud2_> local_listener_;
  TakeListener<::tf2_msgs::msg::dds_::TFMessage_> tf_listener_;
  fdds::DataReader* local_reader_ = nullptr;
  fdds::DataReader* tf_reader_ = nullptr;
};

TEST(SecureGraph, OnlyPermittedPeersReadTheLayersAndOnlyTheSensorFeedsTheNode) {
  // The configuration alone decides (whatever the machine's ROS_SECURITY_* say).
  const ScopedEnv keystore_env("ROS_SECURITY_KEYSTORE", std::nullopt);
  const ScopedEnv enclave_env("ROS_SECURITY_ENCLAVE_OVERRIDE", std::nullopt);
  constexpr int kDomain = 190;
  NodeConfig node_config;
  node_config.dds = peerConfig(kDomain, "/mlmap/node");
  node_config.dds.rates.local_map_hz = 20.0;
  node_config.dds.publish_sensor_tf = true;  // the latched tf_static tells when a peer is in
  MappingNode node(node_config);
  const Transform T_B_S = node_config.map.sensor.T_B_S();

  Peer monitor(peerConfig(kDomain, "/ground/monitor"), "monitor", false);
  Peer xml_monitor(xmlProfileConfig(kDomain, "/ground/monitor"), "xml_monitor", false);
  Peer viewer(peerConfig(kDomain, "/ground/viewer_readonly"), "viewer", true);
  Peer nobody(peerConfig(kDomain, std::nullopt), "nobody", true);
  Peer stranger(peerConfig(kDomain, "/stranger"), "stranger", true);

  // The read-only viewer's permissions refuse it a cloud or pose writer (Fast DDS checks its own
  // permissions); the others may create theirs.
  EXPECT_EQ(viewer.cloud, nullptr);
  EXPECT_EQ(viewer.pose, nullptr);
  ASSERT_NE(nobody.cloud, nullptr);
  ASSERT_NE(stranger.cloud, nullptr);

  // Attack first: clouds and poses from the peers without the right, while the permitted peers
  // get the latched tf_static (so discovery and handshakes with the node are done).
  double stamp_s = wallClockNow_s();
  const bool permitted_joined = waitFor(
      [&] {
        for (Peer* p : {&nobody, &stranger}) p->sendFrame(stamp_s += 0.1, T_B_S);
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        return monitor.tf_static > 0 && xml_monitor.tf_static > 0 && viewer.tf_static > 0;
      },
      kSecureTimeout);
  ASSERT_TRUE(permitted_joined) << "tf_static: monitor " << monitor.tf_static << ", XML monitor "
                                << xml_monitor.tf_static << ", viewer " << viewer.tf_static;
  for (int i = 0; i < 40; ++i) {  // 2 s more of attack, after the node is known to talk
    for (Peer* p : {&nobody, &stranger}) p->sendFrame(stamp_s += 0.1, T_B_S);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  NodeCounters c = node.counters();
  EXPECT_EQ(c.clouds_received, 0u) << "a cloud of an unauthorised peer reached the node";
  EXPECT_EQ(c.poses_received, 0u) << "a pose of an unauthorised peer reached the node";
  EXPECT_EQ(c.publishers_matched, 0u)
      << "the node's readers matched a writer of an unauthorised peer";
  for (Peer* p : {&nobody, &stranger}) {
    EXPECT_EQ(p->matchedWriters(), 0);
    EXPECT_EQ(p->matchedReaders(), 0);
    EXPECT_EQ(p->tf_static, 0);
  }

  // Then the sensor: the node maps, the permitted peers get the map, the others still nothing.
  Peer sensor(peerConfig(kDomain, "/mlmap/sensor"), "sensor", true, false);
  ASSERT_NE(sensor.cloud, nullptr);
  ASSERT_NE(sensor.pose, nullptr);
  const bool mapped = waitFor(
      [&] {
        sensor.sendFrame(stamp_s += 0.1, T_B_S);
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        return monitor.local_points > 0 && xml_monitor.local_points > 0 && viewer.local_points > 0;
      },
      kSecureTimeout);
  c = node.counters();
  EXPECT_TRUE(mapped) << "local map points: monitor " << monitor.local_points << ", XML monitor "
                      << xml_monitor.local_points << ", viewer " << viewer.local_points
                      << "; node: " << c.clouds_received << " clouds, "
                      << node.engineStats().frames_mapped << " frames mapped";
  EXPECT_GT(c.clouds_received, 0u);
  EXPECT_GT(node.engineStats().frames_mapped, 0u);
  for (Peer* p : {&nobody, &stranger}) {
    EXPECT_EQ(p->local_maps, 0);
    EXPECT_EQ(p->matchedReaders(), 0);
  }
  node.stop();
}

using mlmap::test::TempDir;

using TriggerClient =
    test_support::RmwFastrtpsStyleClient<::std_srvs::srv::dds_::Trigger_Request_PubSubType,
                                         ::std_srvs::srv::dds_::Trigger_Response_PubSubType>;
using GetClient = test_support::RmwFastrtpsStyleClient<
    ::rcl_interfaces::srv::dds_::GetParameters_Request_PubSubType,
    ::rcl_interfaces::srv::dds_::GetParameters_Response_PubSubType>;

// Under DDS Security the services are called as the enclaves' permissions say: the monitor calls
// save_map and reads parameters, the read-only viewer reads parameters but may not write a
// save_map or clear_map request, the sensor calls nothing. (The keystore once let no enclave write
// rq/*: nobody could call anything.)
TEST(SecureGraph, ServicesAreCalledAsTheEnclavesPermissionsSay) {
  const ScopedEnv keystore_env("ROS_SECURITY_KEYSTORE", std::nullopt);
  const ScopedEnv enclave_env("ROS_SECURITY_ENCLAVE_OVERRIDE", std::nullopt);
  constexpr int kDomain = 191;
  TempDir dir("mlmap_secure_services");
  NodeConfig node_config;
  node_config.dds = peerConfig(kDomain, "/mlmap/node");
  node_config.map_file.save_path = (dir.path / "saved.mlmap").string();
  MappingNode node(node_config);
  const std::string ns = rosNodeNamespace(node_config.dds.ns);
  const ServiceTopics save_topics = privateServiceTopics(ns, "mlmap_node", "save_map");
  const ServiceTopics clear_topics = privateServiceTopics(ns, "mlmap_node", "clear_map");
  const ServiceTopics get_topics = privateServiceTopics(ns, "mlmap_node", "get_parameters");
  ::rcl_interfaces::srv::dds_::GetParameters_Request_ get_request;
  get_request.names_({"local_map.resolution_m"});

  const ParticipantPtr monitor =
      createParticipant(peerConfig(kDomain, "/ground/monitor"), "monitor");
  TriggerClient save(monitor.get(), save_topics);
  GetClient monitor_get(monitor.get(), get_topics);
  ASSERT_TRUE(waitFor([&] { return save.ready() && monitor_get.ready(); }, kSecureTimeout))
      << "the monitor's service clients did not match the node";
  const auto saved = save.callUntilAnswered({});
  ASSERT_TRUE(saved) << "the monitor's save_map got no reply";
  EXPECT_TRUE(saved->success_()) << saved->message_();
  EXPECT_TRUE(std::filesystem::exists(node_config.map_file.save_path));
  const auto monitor_values = monitor_get.callUntilAnswered(get_request);
  ASSERT_TRUE(monitor_values);
  EXPECT_EQ(monitor_values->values_().size(), 1u);

  const ParticipantPtr viewer =
      createParticipant(peerConfig(kDomain, "/ground/viewer_readonly"), "viewer");
  GetClient viewer_get(viewer.get(), get_topics);
  ASSERT_TRUE(waitFor([&] { return viewer_get.ready(); }, kSecureTimeout));
  const auto viewer_values = viewer_get.callUntilAnswered(get_request);
  ASSERT_TRUE(viewer_values) << "the read-only viewer could not read a parameter";
  EXPECT_EQ(viewer_values->values_().size(), 1u);
  // Fast DDS checks a participant's own permissions when it creates a writer.
  EXPECT_THROW(TriggerClient(viewer.get(), save_topics), std::runtime_error);
  EXPECT_THROW(TriggerClient(viewer.get(), clear_topics), std::runtime_error);

  const ParticipantPtr sensor = createParticipant(peerConfig(kDomain, "/mlmap/sensor"), "sensor");
  EXPECT_THROW(GetClient(sensor.get(), get_topics), std::runtime_error);
  EXPECT_EQ(node.counters().map_saves, 1u);
  node.stop();
}

}  // namespace
}  // namespace mlmap::dds
