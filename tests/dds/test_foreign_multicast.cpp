// Foreign participants that announce a default multicast locator, as Cyclone DDS (and so ROS 2
// Jazzy on rmw_cyclonedds_cpp) does by default: Fast DDS 2.9.1 as Debian builds it aborts when a
// reliable writer sends to a locator its UDP transport never opened (udp_send_guard.h). These
// tests put their process in a network namespace of its own, with a multicast-capable veth, so
// that the multicast they cause never reaches the host's real interfaces; they need root.

#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/transport/udp_send_guard.h"

#include "dds_test_support.h"

#include "sensor_msgs/msg/PointCloud2_.h"
#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <gtest/gtest.h>

#include <sched.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
namespace frtps = eprosima::fastrtps::rtps;
using PointCloud2_ = ::sensor_msgs::msg::dds_::PointCloud2_;
using test_support::waitFor;

/// Moves this process (its calling thread, and every thread it starts later) into a new network
/// namespace with loopback and a veth pair 192.0.2.1/24 <-> 192.0.2.2/24, multicast on and
/// routed through the veth, as a host on a LAN. "" when done, else why it could not be.
std::string enterOwnNetwork() {
  if (geteuid() != 0) return "needs root to make a network namespace";
  if (unshare(CLONE_NEWNET) != 0)
    return std::string("unshare(CLONE_NEWNET): ") + std::strerror(errno);
  const char* commands[] = {
      "ip link set lo up",
      "ip link add mlfm0 type veth peer name mlfm1",
      "ip addr add 192.0.2.1/24 dev mlfm0",
      "ip addr add 192.0.2.2/24 dev mlfm1",
      "ip link set mlfm0 up multicast on",
      "ip link set mlfm1 up multicast on",
      "ip route add 224.0.0.0/4 dev mlfm0",
  };
  for (const char* command : commands) {
    if (std::system(command) != 0) return std::string("'") + command + "' failed";
  }
  return "";
}

/// Fast DDS's default multicast port for user data on `domain` (PB + DG * domain + d2): the one
/// Cyclone DDS announces as its default multicast locator, with 239.255.0.1.
frtps::Locator_t defaultDataMulticast(int domain) {
  frtps::Locator_t locator;
  locator.kind = LOCATOR_KIND_UDPv4;
  frtps::IPLocator::setIPv4(locator, 239, 255, 0, 1);
  locator.port = static_cast<std::uint32_t>(7400 + 250 * domain + 1);
  return locator;
}

/// A participant that is not mlmap's: plain Fast DDS over UDPv4 with simple multicast
/// discovery, announcing a default multicast locator for its endpoints beside its unicast ones,
/// as a ROS 2 node on rmw_cyclonedds_cpp does by default. Its unicast data port differs from its
/// discovery port (Fast DDS's scheme), so nothing but the data path ever opens it.
struct ForeignParticipant {
  explicit ForeignParticipant(int domain) {
    fdds::DomainParticipantQos qos;
    qos.name("foreign");
    qos.transport().use_builtin_transports = false;
    qos.transport().user_transports.push_back(
        std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>());
    // Both lists, as Fast DDS computes neither when one is set: the interface's address with the
    // participant's own data port (port 0), and the domain's default data multicast address.
    frtps::Locator_t unicast;
    unicast.kind = LOCATOR_KIND_UDPv4;
    frtps::IPLocator::setIPv4(unicast, "192.0.2.2");
    qos.wire_protocol().default_unicast_locator_list.push_back(unicast);
    qos.wire_protocol().default_multicast_locator_list.push_back(defaultDataMulticast(domain));
    participant.reset(fdds::DomainParticipantFactory::get_instance()->create_participant(
        static_cast<fdds::DomainId_t>(domain), qos));
  }
  ParticipantPtr participant;
};

fdds::Topic* cloudTopic(fdds::DomainParticipant* participant, const std::string& name) {
  fdds::TypeSupport type(new ::sensor_msgs::msg::dds_::PointCloud2_PubSubType());
  type.register_type(participant);
  return participant->create_topic(name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
}

fdds::DataReader* reliableCloudReader(fdds::DomainParticipant* participant,
                                      const std::string& name) {
  fdds::Topic* topic = cloudTopic(participant, name);
  fdds::Subscriber* subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (topic == nullptr || subscriber == nullptr) return nullptr;
  fdds::DataReaderQos qos = reliableReaderQos();
  qos.data_sharing().off();  // a foreign reader: over the transports only
  return subscriber->create_datareader(topic, qos);
}

int matchedReaders(fdds::DataWriter* writer) {
  fdds::PublicationMatchedStatus status;
  writer->get_publication_matched_status(status);
  return status.current_count;
}

/// True when `reader` takes a valid cloud stamped `stamp_s` within the discovery timeout.
bool receives(fdds::DataReader* reader, std::int32_t stamp_s) {
  return waitFor([&] {
    PointCloud2_ cloud;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&cloud, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data && cloud.header_().stamp_().sec_() == stamp_s) return true;
    }
    return false;
  });
}

PointCloud2_ stampedCloud(std::int32_t stamp_s) {
  PointCloud2_ cloud;
  cloud.header_().stamp_().sec_(stamp_s);
  cloud.header_().frame_id_("map");
  return cloud;
}

// Two foreign readers of one of mlmap's reliable writers, both on the default multicast locator:
// when the second matches, Fast DDS's selection sends to that shared multicast locator and opens
// only it, while the writer's first heartbeat goes to the new reader's own unicast locator. Fast
// DDS 2.9.1 aborted there (OutputTrafficManager.hpp:87); the guard opens it first. Both readers
// must then get every sample, and the guard must have opened that destination.
TEST(ForeignMulticastPeers, ASecondReaderOnTheSameMulticastLocatorIsServedWithoutAborting) {
  const std::string why_not = enterOwnNetwork();
  if (!why_not.empty()) GTEST_SKIP() << why_not;
  const test_support::NoIntraprocessDelivery between_processes;
  constexpr int kDomain = 185;
  DdsConfig config;
  config.domain_id = kDomain;
  config.discovery_range = "SUBNET";  // what ROS 2 uses when ROS_AUTOMATIC_DISCOVERY_RANGE is unset
  config.security.enable = false;
  const ParticipantPtr node = createParticipant(config, "mlmap_side");
  ASSERT_TRUE(node);
  fdds::Topic* topic = cloudTopic(node.get(), "rt/mlmap/probe");
  fdds::Publisher* publisher = node->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  ASSERT_NE(topic, nullptr);
  ASSERT_NE(publisher, nullptr);
  fdds::DataWriter* writer = publisher->create_datawriter(topic, reliableWriterQos(5));
  ASSERT_NE(writer, nullptr);
  const UdpSendGuardStats before = udpSendGuardStats();

  ForeignParticipant first(kDomain);
  ASSERT_TRUE(first.participant);
  fdds::DataReader* first_reader = reliableCloudReader(first.participant.get(), "rt/mlmap/probe");
  ASSERT_NE(first_reader, nullptr);
  ASSERT_TRUE(waitFor([&] { return matchedReaders(writer) == 1; }));
  PointCloud2_ cloud = stampedCloud(1);
  ASSERT_TRUE(writer->write(&cloud));
  ASSERT_TRUE(receives(first_reader, 1)) << "the first foreign reader got nothing";

  ForeignParticipant second(kDomain);  // the writer has history now
  ASSERT_TRUE(second.participant);
  fdds::DataReader* second_reader = reliableCloudReader(second.participant.get(), "rt/mlmap/probe");
  ASSERT_NE(second_reader, nullptr);
  ASSERT_TRUE(waitFor([&] { return matchedReaders(writer) == 2; }));
  for (std::int32_t stamp = 2; stamp <= 4; ++stamp) {
    cloud = stampedCloud(stamp);
    ASSERT_TRUE(writer->write(&cloud));
    EXPECT_TRUE(receives(first_reader, stamp)) << "sample " << stamp << " missed the first reader";
    EXPECT_TRUE(receives(second_reader, stamp))
        << "sample " << stamp << " missed the second reader";
  }
  const UdpSendGuardStats after = udpSendGuardStats();
  EXPECT_GT(after.destinations_opened, before.destinations_opened)
      << "the second reader's unicast locator was opened before the writer sent to it: this "
         "test no longer reproduces what made Fast DDS 2.9.1 abort";
  EXPECT_EQ(after.destinations_refused, before.destinations_refused);
}

}  // namespace
}  // namespace mlmap::dds
