// mlmap_node in a ROS 2 graph as a node (issue 30): ros_discovery_info lists the node and exactly
// its endpoints, every endpoint's USER_DATA carries its type's ROS 2 hash, and its log lines
// reach /rosout with rcl's QoS. Each test reads the node from a participant of its own, through
// Fast DDS discovery, as a ROS 2 tool does; domains 220..222.

#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/node/mapping_node.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/graph/ros_graph.h"
#include "mlmap/dds/wire/type_hash.h"

#include "dds_test_support.h"
#include "ros_graph_observer.h"

#include "rcl_interfaces/msg/Log_PubSubTypes.h"
#include "rmw_dds_common/msg/ParticipantEntitiesInfo_PubSubTypes.h"

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <thread>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
namespace rmw = ::rmw_dds_common::msg::dds_;
namespace rcl = ::rcl_interfaces::msg::dds_;
using test_support::Endpoint;
using test_support::gidsOf;
using test_support::localhostConfig;
using test_support::Observer;
using test_support::Received;
using test_support::waitFor;

NodeConfig nodeConfig(int domain_id) {
  NodeConfig config;
  config.dds = localhostConfig(domain_id);
  return config;
}

TEST(RosGraph, NamesAsRclMakesThem) {
  EXPECT_EQ(rosNodeNamespace(""), "/");
  EXPECT_EQ(rosNodeNamespace("uav1"), "/uav1");
  EXPECT_EQ(rosNodeNamespace("/a/b/"), "/a/b");
  EXPECT_EQ(rosLoggerName("/", "mlmap_node"), "mlmap_node");
  EXPECT_EQ(rosLoggerName("/uav1", "mlmap_node"), "uav1.mlmap_node");
  EXPECT_EQ(rosLoggerName("/a/b", "n"), "a.b.n");
}

TEST(RosGraph, GidIsTheGuidPrefixThenTheEntityId) {
  rtps::GUID_t guid;
  for (std::uint8_t i = 0; i < 12; ++i) guid.guidPrefix.value[i] = static_cast<rtps::octet>(i + 1);
  guid.entityId = rtps::EntityId_t(0x00000103);  // a user writer: 0x00 0x00 0x01 0x03
  const Gid gid = toGid(guid);
  EXPECT_EQ(gid, (Gid{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 0x00, 0x00, 0x01, 0x03}));
}

// ros_discovery_info, read by a reader of the test's own: the node's participant GID, one node
// (name, namespace from dds.ns) and exactly the GIDs of the node's readers and writers as Fast
// DDS discovery reports them (the ros_discovery_info writer itself belongs to no node).
TEST(RosGraph, DiscoveryInfoListsTheNodeWithExactlyItsEndpoints) {
  constexpr int kDomain = 220;
  Received<rmw::ParticipantEntitiesInfo_> infos;  // outlives the observer's reader
  Observer observer(kDomain);
  ASSERT_TRUE(observer.participant);
  fdds::DataReaderQos qos = reliableReaderQos(true, 1);
  createReader<rmw::ParticipantEntitiesInfo_PubSubType>(observer.subscriber, "ros_discovery_info",
                                                        qos, &infos.listener);
  NodeConfig config = nodeConfig(kDomain);
  config.dds.ns = "uav1";
  MappingNode node(config);

  bool agreed = false;
  const std::optional<rmw::ParticipantEntitiesInfo_> info =
      agreeingDiscoveryInfo(infos, observer.log, &agreed);
  ASSERT_TRUE(info) << "no ros_discovery_info sample arrived";
  ASSERT_TRUE(observer.log.participant()) << "the node's participant was not discovered";
  EXPECT_TRUE(agreed) << "ros_discovery_info never listed exactly the discovered endpoints";
  EXPECT_EQ(info->gid_().data_(), toGid(*observer.log.participant()));
  ASSERT_EQ(info->node_entities_info_seq_().size(), 1u);
  const rmw::NodeEntitiesInfo_& n = info->node_entities_info_seq_()[0];
  EXPECT_EQ(n.node_name_().to_string(), "mlmap_node");
  EXPECT_EQ(n.node_namespace_().to_string(), "/uav1");
  EXPECT_EQ(gidsOf(n.writer_gid_seq_()),
            gidsOf(observer.log.endpoints(true), "ros_discovery_info"));
  EXPECT_EQ(gidsOf(n.reader_gid_seq_()), gidsOf(observer.log.endpoints(false), ""));
  // The outputs and inputs of the default configuration are among them, by topic (tf stays
  // absolute under a namespace, as tf2 listens to it).
  for (const char* topic : {"rt/uav1/mlmap/grid", "rt/tf", "rt/rosout"}) {
    const std::optional<Endpoint> w = observer.log.on(topic, true);
    ASSERT_TRUE(w) << topic;
    EXPECT_EQ(gidsOf(n.writer_gid_seq_()).count(w->gid), 1u) << topic;
  }
  const std::optional<Endpoint> cloud = observer.log.on("rt/uav1/cloud", false);
  ASSERT_TRUE(cloud);
  EXPECT_EQ(gidsOf(n.reader_gid_seq_()).count(cloud->gid), 1u);
}

// Every endpoint of the node carries "typehash=<its type's Jazzy hash>;" in USER_DATA, read from
// discovery as `ros2 topic info -v` reads it.
TEST(RosGraph, EveryEndpointCarriesItsTypesJazzyHash) {
  constexpr int kDomain = 221;
  Observer observer(kDomain);
  ASSERT_TRUE(observer.participant);
  MappingNode node(nodeConfig(kDomain));
  const std::map<std::string, std::string> jazzy = {
      {"sensor_msgs::msg::dds_::PointCloud2_",
       "RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5"},
      {"nav_msgs::msg::dds_::OccupancyGrid_",
       "RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7"},
      {"tf2_msgs::msg::dds_::TFMessage_",
       "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"},
      {"geometry_msgs::msg::dds_::PoseStamped_",
       "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8"},
      {"rcl_interfaces::msg::dds_::Log_",
       "RIHS01_e28ce254ca8abc06abf92773b74602cdbf116ed34fbaf294fb9f81da9f318eac"},
      {"rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_",
       "RIHS01_91a0593bacdcc50ea9bdcf849a938b128412cc1ea821245c663bcd26f83c295e"},
  };
  // A few of the default configuration's endpoints, then all of them are checked.
  ASSERT_TRUE(waitFor([&] {
    return observer.log.on("rt/mlmap/grid", true) && observer.log.on("rt/rosout", true) &&
           observer.log.on("ros_discovery_info", true) && observer.log.on("rt/cloud", false) &&
           observer.log.on("rt/pose", false);
  })) << "the node's endpoints were not discovered";
  std::set<std::string> types;
  for (const bool writer : {true, false}) {
    for (const Endpoint& e : observer.log.endpoints(writer)) {
      const auto known = jazzy.find(e.type);
      const std::string hash = known != jazzy.end() ? known->second : rosTypeHash(e.type);
      ASSERT_EQ(hash.size(), 71u) << e.topic << " has type " << e.type << ", unknown to idl/";
      EXPECT_EQ(e.user_data, "typehash=" + hash + ";") << e.topic;
      types.insert(e.type);
    }
  }
  for (const auto& [type, hash] : jazzy) EXPECT_EQ(types.count(type), 1u) << type << " not seen";
}

// /rosout: rcl's QoS on the wire (RELIABLE, TRANSIENT_LOCAL, lifespan 10 s; the depth of 1000 is
// not announced, so it is read from the QoS itself), and the node's lines arriving with their
// level and the node's logger name; the node's first lines reach a reader that joins later.
TEST(RosGraph, RosoutHasRclsQosAndCarriesTheNodesLogLines) {
  const fdds::DataWriterQos qos = rosoutWriterQos();
  EXPECT_EQ(qos.reliability().kind, fdds::RELIABLE_RELIABILITY_QOS);
  EXPECT_EQ(qos.durability().kind, fdds::TRANSIENT_LOCAL_DURABILITY_QOS);
  EXPECT_EQ(qos.history().kind, fdds::KEEP_LAST_HISTORY_QOS);
  EXPECT_EQ(qos.history().depth, 1000);
  EXPECT_EQ(qos.lifespan().duration, eprosima::fastrtps::Duration_t(10, 0));
  EXPECT_EQ(rosLogLevel(LogLevel::kInfo), 20);
  EXPECT_EQ(rosLogLevel(LogLevel::kWarning), 30);
  EXPECT_EQ(rosLogLevel(LogLevel::kError), 40);

  constexpr int kDomain = 222;
  NodeConfig config = nodeConfig(kDomain);
  config.dds.topics.cloud = "";  // logged as a warning at start
  MappingNode node(config);
  Received<rcl::Log_> lines;   // outlives the observer's reader
  Observer observer(kDomain);  // joins after the node's first lines
  ASSERT_TRUE(observer.participant);
  fdds::DataReaderQos reader_qos = reliableReaderQos(true, 1000);
  createReader<rcl::Log_PubSubType>(observer.subscriber, "rt/rosout", reader_qos, &lines.listener);

  auto line = [&](const std::string& part) -> std::optional<rcl::Log_> {
    for (const rcl::Log_& l : lines.all()) {
      if (l.msg_().find(part) != std::string::npos) return l;
    }
    return std::nullopt;
  };
  ASSERT_TRUE(waitFor([&] { return line("no sensor topic") && line("memory of the configured"); }))
      << "the node's start-up lines did not reach a late /rosout reader";
  const rcl::Log_ warning = *line("no sensor topic");
  EXPECT_EQ(warning.level_(), 30);
  EXPECT_EQ(warning.name_(), "mlmap_node");
  EXPECT_GT(warning.stamp_().sec_(), 0);
  EXPECT_EQ(line("memory of the configured")->level_(), 20);
  // A program's own lines logged through the node (mlmap_node's progress and stop lines) too.
  node.log(LogLevel::kWarning, "frames: 3 received, 3 mapped (a program's progress line)");
  ASSERT_TRUE(waitFor([&] { return line("a program's progress line").has_value(); }))
      << "a line logged through MappingNode::log() did not reach /rosout";
  EXPECT_EQ(line("a program's progress line")->level_(), 30);

  const std::optional<Endpoint> writer = observer.log.on("rt/rosout", true);
  ASSERT_TRUE(writer);
  EXPECT_EQ(writer->type, "rcl_interfaces::msg::dds_::Log_");
  EXPECT_EQ(writer->reliability, fdds::RELIABLE_RELIABILITY_QOS);
  EXPECT_EQ(writer->durability, fdds::TRANSIENT_LOCAL_DURABILITY_QOS);
  EXPECT_EQ(writer->lifespan, eprosima::fastrtps::Duration_t(10, 0));
  const std::optional<Endpoint> discovery = observer.log.on("ros_discovery_info", true);
  ASSERT_TRUE(discovery);
  EXPECT_EQ(discovery->reliability, fdds::RELIABLE_RELIABILITY_QOS);
  EXPECT_EQ(discovery->durability, fdds::TRANSIENT_LOCAL_DURABILITY_QOS);
}

}  // namespace
}  // namespace mlmap::dds

namespace mlmap::dds {
namespace {

// One run of tests/dds/discovery_latency.sh: a participant created in a process of its own (as a
// one-shot ROS 2 command is) on MLMAP_PROBE_DOMAIN, timed until it learns of mlmap_node's status
// writer. Prints "PROBE <ms>". Skipped without the variable (the script sets it).
TEST(DiscoveryProbe, TimeUntilANewParticipantSeesTheNodesWriters) {
  const char* domain = std::getenv("MLMAP_PROBE_DOMAIN");  // NOLINT(concurrency-mt-unsafe)
  if (domain == nullptr) GTEST_SKIP() << "run by tests/dds/discovery_latency.sh";
  const auto start = std::chrono::steady_clock::now();
  Observer observer(std::atoi(domain));
  ASSERT_TRUE(waitFor([&] { return observer.log.on("rt/mlmap/status", true).has_value(); },
                      std::chrono::seconds(10)));
  std::printf(
      "PROBE %.1f\n",
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
}

}  // namespace
}  // namespace mlmap::dds
