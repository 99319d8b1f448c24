// The fleet under DDS Security (domain 192, loopback): a vehicle speaks only for itself. The test
// keystore's /fleet/uavN enclaves may publish under their own name only (rt/uavN/*), and the
// merger (/fleet/merger, a closed fleet of uav1 and uav2) reads each vehicle's own topic and
// refuses a sample whose name is not its topic's: the vehicle name is bound to the publisher's
// authenticated identity (docs/fleet.md#trust).
#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/fleet/fleet_merger.h"
#include "mlmap/dds/transport/participant.h"
#include "mlmap/dds/fleet/submap_messages.h"

#include "secure_peer.h"

#include "mlmap_msgs/msg/Submap_PubSubTypes.h"

#include <gtest/gtest.h>

#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>

namespace mlmap::dds {
namespace {

namespace fdds = eprosima::fastdds::dds;
using test_support::kSecureTimeout;
using test_support::peerConfig;
using test_support::waitFor;

const SubmapGeometry kGrid{0.2, {16, 16, 6}};
const fleet::SubmapUpdate kTwoVoxels{SubmapIndex(1, 2, 0), {{3, 2000}, {40, 3500}}};

fdds::DataWriter* rawSubmapWriter(fdds::Publisher* publisher, const std::string& vehicle) {
  return createWriter<::mlmap_msgs::msg::dds_::Submap_PubSubType>(
      publisher, vehicleSubmapTopic(vehicle, "mlmap/submaps"), submapWriterQos());
}

TEST(SecureFleet, AVehicleSpeaksOnlyForItselfItsNameIsItsIdentity) {
  constexpr int kDomain = 192;
  FleetMergerConfig mc;
  mc.dds = peerConfig(kDomain, "/fleet/merger");
  mc.publish_hz = 5.0;
  mc.trust.resolution_m = kGrid.resolution_m;
  mc.trust.submap_cells = kGrid.cells;
  mc.trust.vehicles = {"uav1", "uav2"};
  FleetMerger merger(mc);
  merger.start();

  // uav2's permissions do not let it publish on uav1's topic: no writer at all.
  const ParticipantPtr uav2 = createParticipant(peerConfig(kDomain, "/fleet/uav2"), "uav2");
  fdds::Publisher* publisher2 = uav2->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  ASSERT_NE(publisher2, nullptr);
  EXPECT_THROW(SubmapWriter(publisher2, "mlmap/submaps", "uav1", kGrid, "map"), std::runtime_error);
  // On its own topic under uav1's name: matched (it is a fleet vehicle), refused, counted.
  fdds::DataWriter* own = rawSubmapWriter(publisher2, "uav2");
  ASSERT_TRUE(waitFor([&] { return test_support::writerMatched(own); }, kSecureTimeout));
  auto lie = toSubmapMessage({SubmapIndex(0, 0, 0), {{7, 2500}}}, kGrid, "uav1", 1, 1.0, "map");
  ASSERT_TRUE(own->write(&lie));
  ASSERT_TRUE(waitFor([&] { return merger.stats().samples_received >= 1; }, kSecureTimeout));
  EXPECT_EQ(merger.stats().refused[static_cast<std::size_t>(SubmapRefusal::kNotItsTopic)], 1u);

  // A participant without credentials on uav1's topic is never matched.
  const ParticipantPtr anonymous = createParticipant(peerConfig(kDomain, std::nullopt), "anon");
  fdds::DataWriter* forged =
      rawSubmapWriter(anonymous->create_publisher(fdds::PUBLISHER_QOS_DEFAULT), "uav1");

  // uav1 itself, with its identity: merged.
  const ParticipantPtr uav1 = createParticipant(peerConfig(kDomain, "/fleet/uav1"), "uav1");
  SubmapWriter writer1(uav1->create_publisher(fdds::PUBLISHER_QOS_DEFAULT), "mlmap/submaps", "uav1",
                       kGrid, "map");
  ASSERT_TRUE(waitFor([&] { return test_support::writerMatched(writer1.get()); }, kSecureTimeout));
  writer1.write({kTwoVoxels}, 2.0);
  ASSERT_TRUE(waitFor([&] { return merger.stats().merged_voxels == 2u; }, kSecureTimeout))
      << merger.statusLine();
  auto forged_sample = toSubmapMessage({SubmapIndex(0, 0, 1), {}}, kGrid, "uav1",
                                       std::uint64_t{1} << 62, 3.0, "map");
  forged->write(&forged_sample);  // to nobody
  const FleetMergerStats s = merger.stats();
  EXPECT_FALSE(test_support::writerMatched(forged));
  EXPECT_EQ(s.samples_received, 2u);
  EXPECT_EQ(s.samples_rejected, 1u);
  ASSERT_EQ(s.vehicles.size(), 2u);
  EXPECT_EQ(s.vehicles[0].info.name, "uav1");
  EXPECT_EQ(s.vehicles[0].info.voxels, 2u);
  EXPECT_EQ(s.vehicles[1].info.samples, 0u);  // uav2 sent nothing under its own name
  EXPECT_NE(merger.statusLine().find("not its topic 1"), std::string::npos) << merger.statusLine();
}

}  // namespace
}  // namespace mlmap::dds
