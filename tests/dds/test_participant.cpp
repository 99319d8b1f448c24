// Participants on loopback only: every participant created here either uses
// DiscoveryRange::kLocalhost or a profile whose transports are restricted to 127.0.0.1, and each
// test has its own domain id (150..169), so parallel test processes never meet.
#include "mlmap/dds/transport/participant.h"

#include "mlmap/dds/wire/cloud_sample.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/transport/udp_send_guard.h"

#include "dds_test_support.h"
#include "scoped_env.h"

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
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/utils/IPFinder.h>
#include <fastrtps/utils/IPLocator.h>
#include <fastrtps/xmlparser/XMLProfileManager.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <thread>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
namespace frtps = eprosima::fastrtps::rtps;
using eprosima::fastdds::rtps::SharedMemTransportDescriptor;
using eprosima::fastdds::rtps::UDPv4TransportDescriptor;
using ::sensor_msgs::msg::dds_::PointCloud2_;
using test_support::kDiscoveryTimeout;
using test_support::localhostConfig;
using test_support::readerMatched;
using test_support::ScopedEnv;
using test_support::waitFor;
using test_support::writerMatched;

constexpr std::uint32_t kLargeCloudPoints = 300000;  // x 16 B = 4.8 MB, a depth camera's frame

/// Fast DDS delivers between participants of one process without any transport by default;
/// these tests are about the transports, so that shortcut is switched off.
void deliverThroughTransports() {
  eprosima::fastrtps::LibrarySettingsAttributes settings;
  settings.intraprocess_delivery = eprosima::fastrtps::INTRAPROCESS_OFF;
  eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings(settings);
}

std::string profilePath(const std::string& file) {
  return std::string(MLMAP_SOURCE_DIR) + "/config/dds/" + file;
}

fdds::DomainParticipantQos profileQos(const std::string& profile) {
  fdds::DomainParticipantQos qos;
  EXPECT_EQ(fdds::DomainParticipantFactory::get_instance()->get_participant_qos_from_profile(
                profile, qos),
            ReturnCode_t::RETCODE_OK)
      << profile;
  return qos;
}

template <typename D>
std::shared_ptr<D> onlyTransport(const fdds::DomainParticipantQos& qos) {
  std::shared_ptr<D> found;
  int count = 0;
  for (const auto& t : qos.transport().user_transports) {
    if (auto typed = std::dynamic_pointer_cast<D>(unguarded(t))) {
      found = typed;
      ++count;
    }
  }
  return count == 1 ? found : nullptr;
}

bool isLoopbackOnly(const frtps::LocatorList_t& locators) {
  if (locators.empty()) return false;
  for (const frtps::Locator_t& l : locators) {
    if (l.kind != LOCATOR_KIND_UDPv4 || frtps::IPLocator::toIPv4string(l) != "127.0.0.1") {
      return false;
    }
  }
  return true;
}

fdds::DataWriter* makeWriter(fdds::DomainParticipant* participant, const std::string& topic,
                             const fdds::DataWriterQos& qos) {
  fdds::TypeSupport type(new ::sensor_msgs::msg::dds_::PointCloud2_PubSubType());
  type.register_type(participant);
  fdds::Topic* t = participant->create_topic(topic, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  fdds::Publisher* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  if (t == nullptr || publisher == nullptr) return nullptr;
  return publisher->create_datawriter(t, qos);
}

fdds::DataReader* makeReader(fdds::DomainParticipant* participant, const std::string& topic,
                             const fdds::DataReaderQos& qos) {
  fdds::TypeSupport type(new ::sensor_msgs::msg::dds_::PointCloud2_PubSubType());
  type.register_type(participant);
  fdds::Topic* t = participant->create_topic(topic, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  fdds::Subscriber* subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (t == nullptr || subscriber == nullptr) return nullptr;
  return subscriber->create_datareader(t, qos);
}

/// A PointCloud2 of `points` XYZI float points with seeded random bytes.
PointCloud2_ makeCloud(std::uint32_t points, std::uint32_t seed, std::int32_t stamp_s) {
  PointCloud2_ cloud;
  cloud.header_().stamp_().sec_(stamp_s);
  cloud.header_().stamp_().nanosec_(seed);
  cloud.header_().frame_id_("camera_depth_optical_frame");
  cloud.height_(1);
  cloud.width_(points);
  const char* names[] = {"x", "y", "z", "intensity"};
  for (std::uint32_t i = 0; i < 4; ++i) {
    ::sensor_msgs::msg::dds_::PointField_ field;
    field.name_(names[i]);
    field.offset_(4 * i);
    field.datatype_(7);  // FLOAT32
    field.count_(1);
    cloud.fields_().push_back(field);
  }
  cloud.is_bigendian_(false);
  cloud.point_step_(16);
  cloud.row_step_(16 * points);
  std::mt19937 random(seed);
  std::vector<std::uint8_t> data(static_cast<std::size_t>(16) * points);
  for (std::uint8_t& byte : data) byte = static_cast<std::uint8_t>(random());
  cloud.data_(std::move(data));
  cloud.is_dense_(true);
  return cloud;
}

/// Takes the next valid sample, waiting up to `timeout`.
bool takeCloud(fdds::DataReader* reader, PointCloud2_* cloud,
               std::chrono::milliseconds timeout = kDiscoveryTimeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (!reader->wait_for_unread_message(eprosima::fastrtps::Duration_t(1, 0))) continue;
    fdds::SampleInfo info;
    if (reader->take_next_sample(cloud, &info) == ReturnCode_t::RETCODE_OK && info.valid_data) {
      return true;
    }
  }
  return false;
}

// ---- The shipped profiles ----------------------------------------------------------------

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

int occurrences(const std::string& text, const std::string& part) {
  int n = 0;
  for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
  return n;
}

TEST(ShippedProfiles, EachLoadsCreatesAParticipantAndHasOneDefaultProfile) {
  struct Profile {
    const char* file;
    const char* name;
  };
  const Profile profiles[] = {{"default.xml", "mlmap_default"},
                              {"loopback.xml", "mlmap_loopback"},
                              {"loopback_udp_only.xml", "mlmap_loopback_udp_only"},
                              {"udp_only.xml", "mlmap_udp_only"},
                              {"large_data.xml", "mlmap_large_data"},
                              {"discovery_server_client.xml", "mlmap_discovery_client"}};
  int domain_id = 150;
  for (const Profile& p : profiles) {
    SCOPED_TRACE(p.file);
    const std::string text = readFile(profilePath(p.file));
    EXPECT_EQ(occurrences(text, "is_default_profile=\"true\""), 1);
    EXPECT_EQ(occurrences(text, std::string("<participant profile_name=\"") + p.name +
                                    "\" is_default_profile=\"true\">"),
              1);
    DdsConfig config = localhostConfig(domain_id++);  // LAN profiles: kept off the network
    const std::string file = p.file;
    if (file == "loopback.xml") config.discovery_range = "";              // its own transports
    if (file == "loopback_udp_only.xml") config.discovery_range = "OFF";  // as documented in it
    config.profiles_file = profilePath(p.file);
    config.participant_profile = p.name;
    config.large_data = false;
    const ParticipantPtr participant = createParticipant(config, std::string("test_") + p.name);
    ASSERT_TRUE(participant);
    EXPECT_EQ(participant->get_qos().name().to_string(), std::string("test_") + p.name);
  }
  // What each profile says (read back through Fast DDS's own parser).
  {
    const auto qos = profileQos("mlmap_default");
    EXPECT_TRUE(qos.transport().use_builtin_transports);
    EXPECT_TRUE(qos.transport().user_transports.empty());
  }
  {
    const auto qos = profileQos("mlmap_loopback");
    EXPECT_FALSE(qos.transport().use_builtin_transports);
    EXPECT_EQ(qos.transport().user_transports.size(), 2u);
    const auto shm = onlyTransport<SharedMemTransportDescriptor>(qos);
    ASSERT_NE(shm, nullptr);
    EXPECT_EQ(shm->segment_size(), kLargeDataShmSegmentBytes);
    const auto udp = onlyTransport<UDPv4TransportDescriptor>(qos);
    ASSERT_NE(udp, nullptr);
    EXPECT_EQ(udp->interfaceWhiteList, std::vector<std::string>{"127.0.0.1"});
    EXPECT_EQ(udp->maxInitialPeersRange, kLocalhostMaxInitialPeersRange);
    EXPECT_EQ(udp->sendBufferSize, kLargeDataSocketBufferBytes);
    EXPECT_EQ(udp->receiveBufferSize, kLargeDataSocketBufferBytes);
    EXPECT_TRUE(isLoopbackOnly(qos.wire_protocol().builtin.initialPeersList));
    EXPECT_TRUE(isLoopbackOnly(qos.wire_protocol().builtin.metatrafficUnicastLocatorList));
    EXPECT_TRUE(qos.wire_protocol().builtin.metatrafficMulticastLocatorList.empty());
  }
  {
    const auto qos = profileQos("mlmap_loopback_udp_only");
    EXPECT_FALSE(qos.transport().use_builtin_transports);
    ASSERT_EQ(qos.transport().user_transports.size(), 1u);  // no SHM
    const auto udp = onlyTransport<UDPv4TransportDescriptor>(qos);
    ASSERT_NE(udp, nullptr);
    EXPECT_EQ(udp->interfaceWhiteList, std::vector<std::string>{"127.0.0.1"});
    EXPECT_EQ(udp->maxInitialPeersRange, kLocalhostMaxInitialPeersRange);
    EXPECT_EQ(udp->sendBufferSize, kLargeDataSocketBufferBytes);
    EXPECT_EQ(udp->receiveBufferSize, kLargeDataSocketBufferBytes);
    EXPECT_TRUE(isLoopbackOnly(qos.wire_protocol().builtin.initialPeersList));
    EXPECT_TRUE(isLoopbackOnly(qos.wire_protocol().builtin.metatrafficUnicastLocatorList));
    EXPECT_TRUE(qos.wire_protocol().builtin.metatrafficMulticastLocatorList.empty());
    // As documented (discovery_range OFF, large_data on): still UDP on 127.0.0.1 only, no SHM.
    DdsConfig config;
    config.domain_id = 160;
    config.discovery_range = "OFF";
    config.profiles_file = profilePath("loopback_udp_only.xml");
    config.participant_profile = "mlmap_loopback_udp_only";
    const ParticipantSetup setup = participantSetup(config, "test");
    ASSERT_EQ(setup.qos.transport().user_transports.size(), 1u);
    const auto used = onlyTransport<UDPv4TransportDescriptor>(setup.qos);
    ASSERT_NE(used, nullptr);
    EXPECT_EQ(used->interfaceWhiteList, std::vector<std::string>{"127.0.0.1"});
    EXPECT_TRUE(setup.qos.wire_protocol().builtin.metatrafficMulticastLocatorList.empty());
    EXPECT_TRUE(setup.qos.wire_protocol().default_multicast_locator_list.empty());
    EXPECT_TRUE(isLoopbackOnly(setup.qos.wire_protocol().builtin.initialPeersList));
  }
  {
    const auto qos = profileQos("mlmap_udp_only");
    EXPECT_FALSE(qos.transport().use_builtin_transports);
    ASSERT_EQ(qos.transport().user_transports.size(), 1u);
    const auto udp = onlyTransport<UDPv4TransportDescriptor>(qos);
    ASSERT_NE(udp, nullptr);
    EXPECT_EQ(udp->sendBufferSize, kLargeDataSocketBufferBytes);
    EXPECT_EQ(udp->receiveBufferSize, kLargeDataSocketBufferBytes);
  }
  {
    const auto qos = profileQos("mlmap_large_data");
    EXPECT_FALSE(qos.transport().use_builtin_transports);
    EXPECT_EQ(qos.transport().user_transports.size(), 2u);
    const auto shm = onlyTransport<SharedMemTransportDescriptor>(qos);
    ASSERT_NE(shm, nullptr);
    EXPECT_EQ(shm->segment_size(), kLargeDataShmSegmentBytes);
    const auto udp = onlyTransport<UDPv4TransportDescriptor>(qos);
    ASSERT_NE(udp, nullptr);
    EXPECT_EQ(udp->receiveBufferSize, kLargeDataSocketBufferBytes);
  }
  {
    const auto qos = profileQos("mlmap_discovery_client");
    const auto& discovery = qos.wire_protocol().builtin.discovery_config;
    EXPECT_EQ(discovery.discoveryProtocol, frtps::DiscoveryProtocol_t::CLIENT);
    ASSERT_EQ(discovery.m_DiscoveryServers.size(), 1u);
    const auto& server = discovery.m_DiscoveryServers.front();
    ASSERT_EQ(server.metatrafficUnicastLocatorList.size(), 1u);
    const frtps::Locator_t& locator = *server.metatrafficUnicastLocatorList.begin();
    EXPECT_EQ(frtps::IPLocator::toIPv4string(locator), "127.0.0.1");
    EXPECT_EQ(locator.port, 11811u);
    std::ostringstream prefix;
    prefix << server.guidPrefix;
    EXPECT_EQ(prefix.str(), "44.53.00.5f.45.50.52.4f.53.49.4d.41");  // `fastdds discovery -i 0`
  }
}

TEST(ShippedProfiles, MissingFileOrProfileIsAClearError) {
  DdsConfig config = localhostConfig(151);
  config.profiles_file = profilePath("no_such_profiles.xml");
  config.participant_profile = "mlmap_loopback";
  try {
    createParticipant(config, "test");
    ADD_FAILURE() << "created a participant from a missing profiles file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_profiles.xml"), std::string::npos);
  }
  config.profiles_file = profilePath("loopback.xml");
  config.participant_profile = "mlmap_no_such_profile";
  try {
    createParticipant(config, "test");
    ADD_FAILURE() << "created a participant from a missing profile";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("mlmap_no_such_profile"), std::string::npos);
  }
}

// ---- Discovery range and large data --------------------------------------------------------

TEST(ParticipantSetup, LocalhostUsesTheHostsOwnAddressesOnlyAndSharedMemoryOnlyWhenAsked) {
  const ParticipantSetup setup = participantSetup(localhostConfig(152), "test");
  EXPECT_EQ(setup.discovery_range, DiscoveryRange::kLocalhost);
  const auto& qos = setup.qos;
  EXPECT_FALSE(qos.transport().use_builtin_transports);
  ASSERT_EQ(qos.transport().user_transports.size(), 1u) << "no SHM unless dds.shared_memory";
  const auto udp = onlyTransport<UDPv4TransportDescriptor>(qos);
  ASSERT_NE(udp, nullptr);
  // This host's own addresses, 127.0.0.1 first, listened on and announced (no other).
  const std::vector<std::string> addresses = localhostAddresses();
  ASSERT_FALSE(addresses.empty());
  EXPECT_EQ(addresses.front(), "127.0.0.1");
  // No whitelist: Fast DDS 2.9 would send each datagram once per whitelisted interface.
  EXPECT_TRUE(udp->interfaceWhiteList.empty());
  EXPECT_EQ(udp->maxInitialPeersRange, kLocalhostMaxInitialPeersRange);
  EXPECT_EQ(udp->receiveBufferSize, kLargeDataSocketBufferBytes);  // large_data defaults to true
  const auto& builtin = qos.wire_protocol().builtin;
  EXPECT_TRUE(builtin.metatrafficMulticastLocatorList.empty());
  EXPECT_TRUE(qos.wire_protocol().default_multicast_locator_list.empty());
  for (const frtps::LocatorList_t* list : {&builtin.metatrafficUnicastLocatorList,
                                           &qos.wire_protocol().default_unicast_locator_list}) {
    std::vector<std::string> announced;
    for (const frtps::Locator_t& l : *list) {
      EXPECT_EQ(l.kind, LOCATOR_KIND_UDPv4);
      EXPECT_EQ(l.port, 0u) << "Fast DDS computes the domain's ports";
      announced.push_back(frtps::IPLocator::toIPv4string(l));
    }
    EXPECT_EQ(announced, addresses);
  }
  ASSERT_EQ(builtin.initialPeersList.size(), 1u);
  EXPECT_TRUE(isLoopbackOnly(builtin.initialPeersList));
  EXPECT_EQ(qos.name().to_string(), "test");
  EXPECT_TRUE(setup.warnings.empty());

  DdsConfig with_shm = localhostConfig(152);
  with_shm.shared_memory = true;
  const ParticipantSetup shm_setup = participantSetup(with_shm, "test");
  EXPECT_EQ(shm_setup.qos.transport().user_transports.size(), 2u);
  const auto shm = onlyTransport<SharedMemTransportDescriptor>(shm_setup.qos);
  ASSERT_NE(shm, nullptr);
  EXPECT_EQ(shm->segment_size(), kLargeDataShmSegmentBytes);
  ASSERT_NE(onlyTransport<UDPv4TransportDescriptor>(shm_setup.qos), nullptr);

  with_shm.large_data = false;
  const ParticipantSetup plain = participantSetup(with_shm, "test");
  const auto plain_shm = onlyTransport<SharedMemTransportDescriptor>(plain.qos);
  ASSERT_NE(plain_shm, nullptr);
  EXPECT_EQ(plain_shm->segment_size(), SharedMemTransportDescriptor().segment_size());
  EXPECT_EQ(onlyTransport<UDPv4TransportDescriptor>(plain.qos)->receiveBufferSize, 0u);
}

TEST(ParticipantSetup, SubnetUsesFastDdsUdpWithoutSharedMemoryUnlessAskedAndLargeDataSizesIt) {
  DdsConfig config;
  config.domain_id = 153;
  config.discovery_range = "SUBNET";
  config.large_data = false;
  const ParticipantSetup plain = participantSetup(config, "test");
  // Fast DDS's built-in transports are UDPv4 + SHM: the same UDPv4 alone, every interface.
  EXPECT_FALSE(plain.qos.transport().use_builtin_transports);
  ASSERT_EQ(plain.qos.transport().user_transports.size(), 1u);
  const auto plain_udp = onlyTransport<UDPv4TransportDescriptor>(plain.qos);
  ASSERT_NE(plain_udp, nullptr);
  EXPECT_TRUE(plain_udp->interfaceWhiteList.empty());
  EXPECT_EQ(plain_udp->receiveBufferSize, 0u);  // the OS default, as the built-in one
  EXPECT_TRUE(plain.qos.wire_protocol().builtin.initialPeersList.empty());
  EXPECT_TRUE(plain.warnings.empty()) << "nothing the user asked for was left out";

  // Asked for: the built-in pair, sized.
  config.large_data = true;
  config.shared_memory = true;
  const ParticipantSetup sized = participantSetup(config, "test");
  EXPECT_FALSE(sized.qos.transport().use_builtin_transports);
  EXPECT_EQ(sized.qos.transport().user_transports.size(), 2u);
  const auto shm = onlyTransport<SharedMemTransportDescriptor>(sized.qos);
  ASSERT_NE(shm, nullptr);
  EXPECT_EQ(shm->segment_size(), kLargeDataShmSegmentBytes);
  const auto udp = onlyTransport<UDPv4TransportDescriptor>(sized.qos);
  ASSERT_NE(udp, nullptr);
  EXPECT_TRUE(udp->interfaceWhiteList.empty());  // every interface, as the built-in one
  EXPECT_EQ(udp->sendBufferSize, kLargeDataSocketBufferBytes);
  EXPECT_EQ(udp->receiveBufferSize, kLargeDataSocketBufferBytes);
}

// A loopback-only profile with small (and one large) transport sizes and no initial peers.
const char kTestProfiles[] = R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>test_shm_1mb</transport_id>
        <type>SHM</type>
        <segment_size>1048576</segment_size>
      </transport_descriptor>
      <transport_descriptor>
        <transport_id>test_udp_loopback</transport_id>
        <type>UDPv4</type>
        <sendBufferSize>65536</sendBufferSize>
        <receiveBufferSize>8388608</receiveBufferSize>
        <interfaceWhiteList><address>127.0.0.1</address></interfaceWhiteList>
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="mlmap_test_shm_only">
      <rtps>
        <useBuiltinTransports>false</useBuiltinTransports>
        <userTransports><transport_id>test_shm_1mb</transport_id></userTransports>
      </rtps>
    </participant>
    <participant profile_name="mlmap_test_loopback_no_peers">
      <rtps>
        <useBuiltinTransports>false</useBuiltinTransports>
        <userTransports>
          <transport_id>test_shm_1mb</transport_id>
          <transport_id>test_udp_loopback</transport_id>
        </userTransports>
      </rtps>
    </participant>
  </profiles>
</dds>
)";

/// Loads kTestProfiles once per process (profile names cannot be loaded twice).
bool loadTestProfiles() {
  static const bool loaded =
      fdds::DomainParticipantFactory::get_instance()->load_XML_profiles_string(
          kTestProfiles, sizeof(kTestProfiles) - 1) == ReturnCode_t::RETCODE_OK;
  return loaded;
}

// Every UDP transport of every participant mlmap makes is behind the send guard
// (udp_send_guard.h), whatever the range, shared memory or profile; nothing else is wrapped.
TEST(ParticipantSetup, EveryUdpTransportIsBehindTheSendGuardAndNothingElseIs) {
  ASSERT_TRUE(loadTestProfiles());
  for (const char* range : {"LOCALHOST", "SUBNET", "OFF"}) {
    for (const bool shared_memory : {false, true}) {
      for (const char* profile : {"", "mlmap_test_loopback_no_peers"}) {
        DdsConfig config;
        config.domain_id = 153;
        config.discovery_range = range;
        config.shared_memory = shared_memory;
        config.participant_profile = profile;
        const ParticipantSetup setup = participantSetup(config, "test");
        int udp = 0;
        for (const auto& transport : setup.qos.transport().user_transports) {
          const auto below = unguarded(transport);
          const bool is_udp = std::dynamic_pointer_cast<UDPv4TransportDescriptor>(below) != nullptr;
          udp += is_udp ? 1 : 0;
          EXPECT_EQ(isUdpSendGuard(transport), is_udp)
              << range << ", shared memory " << shared_memory << ", profile '" << profile << "'";
        }
        EXPECT_GE(udp, 1) << range << ", profile '" << profile << "'";
      }
    }
  }
  // The guard takes UDP only, and never twice.
  const auto udp = std::make_shared<UDPv4TransportDescriptor>();
  const auto guarded = withUdpSendGuard(udp);
  EXPECT_TRUE(isUdpSendGuard(guarded));
  EXPECT_EQ(unguarded(guarded), udp);
  EXPECT_EQ(withUdpSendGuard(guarded), guarded);
  const auto shm = std::make_shared<SharedMemTransportDescriptor>();
  EXPECT_EQ(withUdpSendGuard(shm), shm);
}

TEST(ParticipantSetup, LargeDataRaisesAProfilesSizesOnACopyAndNeverLowersThem) {
  ASSERT_TRUE(loadTestProfiles());
  DdsConfig config;
  config.domain_id = 154;
  config.discovery_range = "OFF";  // no multicast: this participant sends nothing at all
  config.participant_profile = "mlmap_test_loopback_no_peers";
  config.large_data = true;
  config.shared_memory = true;  // the profile's SHM transport is kept
  const ParticipantSetup setup = participantSetup(config, "test");
  const auto shm = onlyTransport<SharedMemTransportDescriptor>(setup.qos);
  ASSERT_NE(shm, nullptr);
  EXPECT_EQ(shm->segment_size(), kLargeDataShmSegmentBytes);
  const auto udp = onlyTransport<UDPv4TransportDescriptor>(setup.qos);
  ASSERT_NE(udp, nullptr);
  EXPECT_EQ(udp->sendBufferSize, kLargeDataSocketBufferBytes);
  EXPECT_EQ(udp->receiveBufferSize, 8388608u);  // already larger: kept
  EXPECT_EQ(udp->interfaceWhiteList, std::vector<std::string>{"127.0.0.1"});  // the rest kept
  // The profile itself is unchanged.
  const auto profile = profileQos("mlmap_test_loopback_no_peers");
  EXPECT_EQ(onlyTransport<SharedMemTransportDescriptor>(profile)->segment_size(), 1048576u);
  EXPECT_EQ(onlyTransport<UDPv4TransportDescriptor>(profile)->sendBufferSize, 65536u);
  // And a participant accepts the sized transports.
  const ParticipantPtr participant = createParticipant(config, "test");
  EXPECT_TRUE(participant);
}

TEST(ParticipantSetup, AProfilesSharedMemoryIsLeftOutUnlessAskedAndThatIsSaid) {
  ASSERT_TRUE(loadTestProfiles());
  DdsConfig config;
  config.domain_id = 162;
  config.discovery_range = "OFF";
  config.participant_profile = "mlmap_test_loopback_no_peers";
  const ParticipantSetup setup = participantSetup(config, "test");
  ASSERT_EQ(setup.qos.transport().user_transports.size(), 1u);
  const auto udp = onlyTransport<UDPv4TransportDescriptor>(setup.qos);
  ASSERT_NE(udp, nullptr);
  EXPECT_EQ(udp->interfaceWhiteList, std::vector<std::string>{"127.0.0.1"});
  ASSERT_EQ(setup.warnings.size(), 1u);
  EXPECT_NE(setup.warnings[0].find("'mlmap_test_loopback_no_peers'"), std::string::npos)
      << setup.warnings[0];
  EXPECT_NE(setup.warnings[0].find("dds.shared_memory"), std::string::npos) << setup.warnings[0];
  const ParticipantPtr participant = createParticipant(config, "test");
  EXPECT_TRUE(participant);

  // A profile with shared memory alone would leave no transport: a clear error instead.
  config.participant_profile = "mlmap_test_shm_only";
  try {
    participantSetup(config, "test");
    ADD_FAILURE() << "a participant without any transport was set up";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'mlmap_test_shm_only'"), std::string::npos) << what;
    EXPECT_NE(what.find("dds.shared_memory: true"), std::string::npos) << what;
  }
  config.shared_memory = true;
  EXPECT_NE(onlyTransport<SharedMemTransportDescriptor>(participantSetup(config, "test").qos),
            nullptr);
}

TEST(Participant, OffAddsNoPeersAndNoMulticastSoTwoParticipantsNeverMeet) {
  deliverThroughTransports();
  ASSERT_TRUE(loadTestProfiles());
  DdsConfig config;
  config.domain_id = 155;
  config.participant_profile = "mlmap_test_loopback_no_peers";
  config.discovery_range = "OFF";
  const ParticipantSetup setup = participantSetup(config, "off");
  EXPECT_EQ(setup.discovery_range, DiscoveryRange::kOff);
  const auto& builtin = setup.qos.wire_protocol().builtin;
  EXPECT_TRUE(builtin.initialPeersList.empty());
  EXPECT_TRUE(builtin.metatrafficMulticastLocatorList.empty());
  EXPECT_EQ(builtin.metatrafficUnicastLocatorList.size(), 1u);
  EXPECT_TRUE(setup.qos.wire_protocol().default_multicast_locator_list.empty());

  const ParticipantPtr a = createParticipant(config, "off_a");
  const ParticipantPtr b = createParticipant(config, "off_b");
  fdds::DataWriter* writer = makeWriter(a.get(), "rt/test/off", reliableWriterQos());
  fdds::DataReader* reader = makeReader(b.get(), "rt/test/off", reliableReaderQos());
  ASSERT_NE(writer, nullptr);
  ASSERT_NE(reader, nullptr);
  // The same pair finds itself within this window when discovery works (LOCALHOST test below).
  EXPECT_FALSE(waitFor([&] { return writerMatched(writer) || readerMatched(reader); },
                       std::chrono::milliseconds(1500)));
}

// ---- ROS_AUTOMATIC_DISCOVERY_RANGE with a profile, and ROS_STATIC_PEERS (as Jazzy) ----------

bool hasPeer(const frtps::LocatorList_t& peers, const std::string& address) {
  return std::any_of(peers.begin(), peers.end(), [&](const frtps::Locator_t& l) {
    return l.kind == LOCATOR_KIND_UDPv4 && frtps::IPLocator::toIPv4string(l) == address;
  });
}

TEST(ParticipantSetup, LocalhostKeepsAProfilesTransportsAndAddsLoopbackUdpAsJazzy) {
  ASSERT_TRUE(loadTestProfiles());
  ScopedEnv peers("ROS_STATIC_PEERS", std::nullopt);
  DdsConfig config = localhostConfig(158);
  config.participant_profile = "mlmap_test_loopback_no_peers";
  config.large_data = false;
  const ParticipantSetup setup = participantSetup(config, "test");
  const auto& transports = setup.qos.transport().user_transports;
  EXPECT_FALSE(setup.qos.transport().use_builtin_transports);
  // The profile's UDPv4 (its 8 MB receive buffer) stays, mlmap's loopback UDPv4 is added; the
  // profile's SHM is left out (dds.shared_memory false), which is said.
  ASSERT_EQ(transports.size(), 2u);
  // Both behind the send guard (udp_send_guard.h).
  EXPECT_TRUE(isUdpSendGuard(transports[0]));
  EXPECT_TRUE(isUdpSendGuard(transports[1]));
  const auto profile_udp =
      std::dynamic_pointer_cast<UDPv4TransportDescriptor>(unguarded(transports[0]));
  const auto added_udp =
      std::dynamic_pointer_cast<UDPv4TransportDescriptor>(unguarded(transports[1]));
  ASSERT_NE(profile_udp, nullptr);
  ASSERT_NE(added_udp, nullptr);
  EXPECT_EQ(profile_udp->receiveBufferSize, 8388608u);
  EXPECT_EQ(added_udp->maxInitialPeersRange, kLocalhostMaxInitialPeersRange);
  EXPECT_TRUE(added_udp->interfaceWhiteList.empty());
  EXPECT_EQ(onlyTransport<SharedMemTransportDescriptor>(setup.qos), nullptr);
  EXPECT_EQ(setup.warnings.size(), 1u);
  const auto& builtin = setup.qos.wire_protocol().builtin;
  EXPECT_TRUE(builtin.metatrafficMulticastLocatorList.empty());
  EXPECT_TRUE(isLoopbackOnly(builtin.initialPeersList));
  // With the profile's SHM asked for, it stays and mlmap adds its own, as rmw_fastrtps does.
  config.shared_memory = true;
  const ParticipantSetup with_shm = participantSetup(config, "test");
  EXPECT_EQ(with_shm.qos.transport().user_transports.size(), 4u);
  EXPECT_TRUE(with_shm.warnings.empty());
  // And a participant accepts it.
  config.shared_memory = false;
  EXPECT_TRUE(createParticipant(config, "test"));
}

TEST(ParticipantSetup, StaticPeersJoinTheInitialPeersForLocalhostAndSubnetOnly) {
  DdsConfig config = localhostConfig(158);
  ScopedEnv env("ROS_STATIC_PEERS", " 127.0.0.2 ;;10.1.2.3; ");
  {
    const ParticipantSetup setup = participantSetup(config, "test");
    EXPECT_EQ(setup.static_peers, (std::vector<std::string>{"127.0.0.2", "10.1.2.3"}));
    const auto& peers = setup.qos.wire_protocol().builtin.initialPeersList;
    EXPECT_EQ(peers.size(), 3u);
    EXPECT_TRUE(hasPeer(peers, "127.0.0.1"));
    EXPECT_TRUE(hasPeer(peers, "127.0.0.2"));
    EXPECT_TRUE(hasPeer(peers, "10.1.2.3"));
    // A peer on another host must be reachable: the added UDPv4 is not confined to loopback.
    const auto udp = onlyTransport<UDPv4TransportDescriptor>(setup.qos);
    ASSERT_NE(udp, nullptr);
    EXPECT_TRUE(udp->interfaceWhiteList.empty());
    EXPECT_TRUE(setup.warnings.empty());
  }
  {
    config.discovery_range = "SUBNET";
    const ParticipantSetup setup = participantSetup(config, "test");
    const auto& peers = setup.qos.wire_protocol().builtin.initialPeersList;
    EXPECT_EQ(peers.size(), 3u);  // the peers and the default multicast address
    EXPECT_TRUE(hasPeer(peers, "239.255.0.1"));
    EXPECT_FALSE(hasPeer(peers, "127.0.0.1"));
  }
  for (const char* range : {"OFF", "SYSTEM_DEFAULT"}) {
    SCOPED_TRACE(range);
    config.discovery_range = range;
    const ParticipantSetup setup = participantSetup(config, "test");
    const auto& peers = setup.qos.wire_protocol().builtin.initialPeersList;
    EXPECT_FALSE(hasPeer(peers, "127.0.0.2"));
    ASSERT_EQ(setup.warnings.size(), 1u);
    EXPECT_NE(setup.warnings[0].find("static peers are ignored"), std::string::npos);
  }
  // The config key wins over the environment.
  config.discovery_range = "LOCALHOST";
  config.static_peers = "127.0.0.3";
  const ParticipantSetup from_key = participantSetup(config, "test");
  const auto& peers = from_key.qos.wire_protocol().builtin.initialPeersList;
  EXPECT_TRUE(hasPeer(peers, "127.0.0.3"));
  EXPECT_FALSE(hasPeer(peers, "127.0.0.2"));
}

TEST(ParticipantSetup, BadStaticPeersAreClearErrors) {
  DdsConfig config = localhostConfig(158);
  const auto error_of = [&](const std::string& peers) {
    config.static_peers = peers;
    try {
      participantSetup(config, "test");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error_of("no-such-host.invalid").find("'no-such-host.invalid'"), std::string::npos);
  EXPECT_NE(error_of("10.0.0.1 10.0.0.2").find("separated by ';'"), std::string::npos);
  EXPECT_NE(error_of(std::string(300, 'a')).find("longer than 255"), std::string::npos);
  std::string many;
  for (int i = 0; i <= static_cast<int>(kMaxStaticPeers); ++i) many += "10.0.0.1;";
  EXPECT_NE(error_of(many).find("more than 64"), std::string::npos);
  // validate() reports the same for the config key.
  config.static_peers = "a b";
  const std::vector<std::string> errors = config.validate();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("dds.static_peers"), std::string::npos) << errors[0];
}

TEST(Participant, OneTypeNameHasOneImplementationPerParticipant) {
  // mlmap_node reads clouds as CloudSample: a writer registering the generated PointCloud2 type in
  // the same participant would hand CloudSample's deserialize() plain messages, or the reverse.
  DdsConfig config = localhostConfig(161);
  config.discovery_range = "OFF";
  const ParticipantPtr participant = createParticipant(config, "types");
  const std::string name = registerType<CloudSamplePubSubType>(participant.get());
  EXPECT_EQ(name, "sensor_msgs::msg::dds_::PointCloud2_");
  EXPECT_EQ(registerType<CloudSamplePubSubType>(participant.get()), name);  // again: fine
  EXPECT_THROW(registerType<::sensor_msgs::msg::dds_::PointCloud2_PubSubType>(participant.get()),
               std::runtime_error);
  const ParticipantPtr other = createParticipant(config, "types_other");
  registerType<::sensor_msgs::msg::dds_::PointCloud2_PubSubType>(other.get());
  EXPECT_THROW(registerType<CloudSamplePubSubType>(other.get()), std::runtime_error);
}

// ---- Data over the transports --------------------------------------------------------------

TEST(Participant, LocalhostParticipantsExchangeALargePointCloudByteExactly) {
  deliverThroughTransports();
  const ParticipantPtr sender = createParticipant(localhostConfig(156), "sender");
  const ParticipantPtr receiver = createParticipant(localhostConfig(156), "receiver");
  fdds::DataWriter* writer = makeWriter(sender.get(), "rt/test/cloud", reliableWriterQos());
  fdds::DataReader* reader = makeReader(receiver.get(), "rt/test/cloud", reliableReaderQos());
  ASSERT_NE(writer, nullptr);
  ASSERT_NE(reader, nullptr);
  ASSERT_TRUE(waitFor([&] { return writerMatched(writer) && readerMatched(reader); }))
      << "LOCALHOST participants did not discover each other";

  for (std::uint32_t seed = 1; seed <= 2; ++seed) {
    PointCloud2_ sent = makeCloud(kLargeCloudPoints, seed, static_cast<std::int32_t>(seed));
    ASSERT_EQ(sent.data_().size(), 4800000u);
    const auto start = std::chrono::steady_clock::now();
    ASSERT_TRUE(writer->write(&sent));
    PointCloud2_ received;
    ASSERT_TRUE(takeCloud(reader, &received)) << "cloud " << seed << " never arrived";
    const double latency_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    std::printf("4.8 MB PointCloud2 over LOCALHOST: %.1f ms\n", latency_ms);
    ASSERT_EQ(received.data_().size(), sent.data_().size());
    EXPECT_TRUE(received.data_() == sent.data_()) << "payload bytes differ";
    EXPECT_TRUE(received == sent) << "header, fields or layout differ";
  }
}

// A ROS 2 Jazzy node on rmw_fastrtps_cpp with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and no XML
// profile listens on every interface but announces only its network interface's address (Fast DDS
// leaves 127.0.0.1 out when the host has another interface); it sends its announcements to
// 127.0.0.1. Set up as that node here (Fast DDS 2.9, the locators a 2.14 node announced on this
// VM), it and a LOCALHOST participant of mlmap's must find each other and exchange samples both
// ways. Skipped on a host with no IPv4 address but 127.0.0.1 (there such a node announces
// 127.0.0.1).
TEST(Participant, LocalhostFindsANodeThatAnnouncesOnlyItsNetworkAddress) {
  deliverThroughTransports();
  constexpr int kDomain = 163;
  std::vector<frtps::IPFinder::info_IP> ips;
  ASSERT_TRUE(frtps::IPFinder::getIPs(&ips, false));
  std::string network_address;
  for (const auto& ip : ips) {
    if (ip.type == frtps::IPFinder::IP4) network_address = ip.name;
  }
  if (network_address.empty()) GTEST_SKIP() << "this host has no IPv4 address but 127.0.0.1";

  fdds::DomainParticipantQos jazzy;
  jazzy.name("jazzy_localhost_node");
  jazzy.transport().use_builtin_transports = false;
  auto udp = std::make_shared<UDPv4TransportDescriptor>();
  udp->maxInitialPeersRange = kLocalhostMaxInitialPeersRange;
  jazzy.transport().user_transports.push_back(udp);
  frtps::Locator_t network;
  network.kind = LOCATOR_KIND_UDPv4;
  frtps::IPLocator::setIPv4(network, network_address);
  frtps::Locator_t loopback;
  loopback.kind = LOCATOR_KIND_UDPv4;
  frtps::IPLocator::setIPv4(loopback, "127.0.0.1");
  auto& wire = jazzy.wire_protocol();
  wire.builtin.metatrafficMulticastLocatorList.clear();
  wire.builtin.metatrafficUnicastLocatorList.push_back(network);
  wire.default_unicast_locator_list.push_back(network);
  wire.builtin.initialPeersList.push_back(loopback);
  const ParticipantPtr node(
      fdds::DomainParticipantFactory::get_instance()->create_participant(kDomain, jazzy));
  ASSERT_TRUE(node);
  const ParticipantPtr ours = createParticipant(localhostConfig(kDomain), "mlmap");
  ASSERT_TRUE(ours);

  fdds::DataWriter* to_node = makeWriter(ours.get(), "rt/test/to_node", reliableWriterQos());
  fdds::DataReader* node_reads = makeReader(node.get(), "rt/test/to_node", reliableReaderQos());
  fdds::DataWriter* from_node = makeWriter(node.get(), "rt/test/from_node", reliableWriterQos());
  fdds::DataReader* we_read = makeReader(ours.get(), "rt/test/from_node", reliableReaderQos());
  ASSERT_TRUE(to_node && node_reads && from_node && we_read);
  ASSERT_TRUE(waitFor([&] {
    return writerMatched(to_node) && readerMatched(node_reads) && writerMatched(from_node) &&
           readerMatched(we_read);
  })) << "mlmap's LOCALHOST participant and a node announcing only "
      << network_address << " did not find each other";
  PointCloud2_ sent = makeCloud(1000, 21, 1);
  ASSERT_TRUE(to_node->write(&sent));
  PointCloud2_ received;
  ASSERT_TRUE(takeCloud(node_reads, &received)) << "no sample reached the node";
  EXPECT_TRUE(received == sent);
  sent = makeCloud(1000, 22, 2);
  ASSERT_TRUE(from_node->write(&sent));
  ASSERT_TRUE(takeCloud(we_read, &received)) << "no sample from the node arrived";
  EXPECT_TRUE(received == sent);
}

TEST(Participant, LatchedWritersLastSampleReachesALateJoiningReader) {
  deliverThroughTransports();
  const ParticipantPtr sender = createParticipant(localhostConfig(157), "latched_sender");
  fdds::DataWriter* writer = makeWriter(sender.get(), "rt/test/map", latchedWriterQos());
  ASSERT_NE(writer, nullptr);
  const PointCloud2_ first = makeCloud(1000, 11, 1);
  const PointCloud2_ last = makeCloud(2000, 12, 2);
  PointCloud2_ sample = first;
  ASSERT_TRUE(writer->write(&sample));
  sample = last;
  ASSERT_TRUE(writer->write(&sample));

  // The reader's participant exists only after both were published.
  const ParticipantPtr late = createParticipant(localhostConfig(157), "late_receiver");
  fdds::DataReader* reader = makeReader(late.get(), "rt/test/map", reliableReaderQos(true));
  ASSERT_NE(reader, nullptr);
  PointCloud2_ received;
  ASSERT_TRUE(takeCloud(reader, &received)) << "the latched sample never arrived";
  EXPECT_TRUE(received == last) << "got the sample of stamp " << received.header_().stamp_().sec_();
  // KEEP_LAST 1: the older sample is not replayed.
  PointCloud2_ extra;
  fdds::SampleInfo info;
  EXPECT_NE(reader->take_next_sample(&extra, &info), ReturnCode_t::RETCODE_OK);
}

TEST(Participant, DomainAndRangeFromTheEnvironmentAreTheOnesUsed) {
  ScopedEnv range("ROS_AUTOMATIC_DISCOVERY_RANGE", std::string("LOCALHOST"));
  DdsConfig config;  // domain_id -1, discovery_range "": both from the environment
  {
    ScopedEnv domain("ROS_DOMAIN_ID", std::string("158"));
    const ParticipantSetup setup = participantSetup(config, "env");
    EXPECT_EQ(setup.discovery_range, DiscoveryRange::kLocalhost);
    EXPECT_TRUE(isLoopbackOnly(setup.qos.wire_protocol().builtin.initialPeersList));
    const ParticipantPtr participant = createParticipant(config, "env");
    EXPECT_EQ(participant->get_domain_id(), 158u);
  }
  {
    ScopedEnv domain("ROS_DOMAIN_ID", std::string("158"));
    config.domain_id = 159;  // the config wins over the environment
    const ParticipantPtr participant = createParticipant(config, "config");
    EXPECT_EQ(participant->get_domain_id(), 159u);
    config.domain_id = -1;
  }
  {
    ScopedEnv domain("ROS_DOMAIN_ID", std::string("forty"));
    try {
      createParticipant(config, "bad_env");
      ADD_FAILURE() << "created a participant with ROS_DOMAIN_ID=forty";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("ROS_DOMAIN_ID"), std::string::npos);
    }
  }
}

// ---- QoS presets ---------------------------------------------------------------------------

// Also the two deliberate differences from rmw_fastrtps: DYNAMIC_REUSABLE history memory (not
// PREALLOCATED_WITH_REALLOC, which Fast DDS fixes to the size bound that CloudSamplePubSubType
// claims) and writers that never offer data-sharing (their slots would have that size too).
TEST(QosPresets, MatchRos2AndRmwFastrtps) {
  const fdds::DataReaderQos sensor = sensorReaderQos();
  EXPECT_EQ(sensor.reliability().kind, fdds::BEST_EFFORT_RELIABILITY_QOS);
  EXPECT_EQ(sensor.durability().kind, fdds::VOLATILE_DURABILITY_QOS);
  EXPECT_EQ(sensor.history().kind, fdds::KEEP_LAST_HISTORY_QOS);
  EXPECT_EQ(sensor.history().depth, 5);
  EXPECT_EQ(sensor.endpoint().history_memory_policy, frtps::DYNAMIC_REUSABLE_MEMORY_MODE);
  EXPECT_EQ(sensor.data_sharing().kind(), fdds::AUTO);
  // Only with mlmap's own writers: never Fast DDS's automatic id (the host's MAC in the upper 48
  // bits), which every other same-host Fast DDS endpoint announces.
  EXPECT_EQ(sensor.data_sharing().domain_ids(), std::vector<std::uint64_t>{dataSharingDomainId()});
  EXPECT_NE(dataSharingDomainId(), 0u);
  EXPECT_EQ(reliableReaderQos(true).data_sharing().domain_ids(),
            sensor.data_sharing().domain_ids());

  const fdds::DataWriterQos writer = reliableWriterQos();
  EXPECT_EQ(writer.reliability().kind, fdds::RELIABLE_RELIABILITY_QOS);
  EXPECT_EQ(writer.durability().kind, fdds::VOLATILE_DURABILITY_QOS);
  EXPECT_EQ(writer.history().kind, fdds::KEEP_LAST_HISTORY_QOS);
  EXPECT_EQ(writer.history().depth, 10);
  EXPECT_EQ(writer.publish_mode().kind, fdds::SYNCHRONOUS_PUBLISH_MODE);
  EXPECT_EQ(writer.endpoint().history_memory_policy, frtps::DYNAMIC_REUSABLE_MEMORY_MODE);
  EXPECT_EQ(writer.data_sharing().kind(), fdds::OFF);
  EXPECT_EQ(reliableWriterQos(3).history().depth, 3);

  const fdds::DataWriterQos latched = latchedWriterQos();
  EXPECT_EQ(latched.reliability().kind, fdds::RELIABLE_RELIABILITY_QOS);
  EXPECT_EQ(latched.durability().kind, fdds::TRANSIENT_LOCAL_DURABILITY_QOS);
  EXPECT_EQ(latched.history().kind, fdds::KEEP_LAST_HISTORY_QOS);
  EXPECT_EQ(latched.history().depth, 1);
  EXPECT_EQ(latched.publish_mode().kind, fdds::SYNCHRONOUS_PUBLISH_MODE);
  EXPECT_EQ(latched.data_sharing().kind(), fdds::OFF);

  const fdds::DataReaderQos reader = reliableReaderQos();
  EXPECT_EQ(reader.reliability().kind, fdds::RELIABLE_RELIABILITY_QOS);
  EXPECT_EQ(reader.durability().kind, fdds::VOLATILE_DURABILITY_QOS);
  EXPECT_EQ(reader.history().depth, 10);
  EXPECT_EQ(reader.endpoint().history_memory_policy, frtps::DYNAMIC_REUSABLE_MEMORY_MODE);
  const fdds::DataReaderQos latched_reader = reliableReaderQos(true, 1);
  EXPECT_EQ(latched_reader.durability().kind, fdds::TRANSIENT_LOCAL_DURABILITY_QOS);
  EXPECT_EQ(latched_reader.history().depth, 1);

  EXPECT_THROW(sensorReaderQos(0), std::invalid_argument);
  EXPECT_THROW(reliableWriterQos(-1), std::invalid_argument);
  EXPECT_THROW(reliableReaderQos(false, 0), std::invalid_argument);
}

}  // namespace
}  // namespace mlmap::dds
